// Reads a Babylon.js .env file with Babylon's own parser (GetEnvInfo and
// CreateRadianceImageDataArrayBufferViews from @babylonjs/core's environmentTextureTools, the
// functions its loader calls before the WebGL upload), prints the manifest as Babylon normalises
// it, and writes every specular image Babylon sliced out to <out dir>/m<level>_f<face>.png.
//
//   node env_check.mjs <dir holding node_modules/@babylonjs/core> <file.env> <out dir> [faces.f32]
//
// With faces.f32 (level 0's six faces, +X -X +Y -Y +Z -Z, RGBA float32 little-endian, rows in
// the OpenGL face order) it also runs Babylon's CubeMapToSphericalPolynomialTools on them, the
// irradiance Babylon itself would store, and evaluates the file's polynomial the way Babylon's
// shader does through harmonics (SphericalHarmonics.FromPolynomial, preScaleForRendering) at
// the six axes and the diagonal. Exits non-zero when Babylon refuses the file.
import { readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';

const [toolsDir, file, outDir, facesFile] = process.argv.slice(2);
if (!toolsDir || !file || !outDir) {
  console.error('usage: node env_check.mjs <tools dir> <file.env> <out dir> [faces.f32]');
  process.exit(2);
}
const core = join(toolsDir, 'node_modules', '@babylonjs', 'core');
const load = (p) => import(pathToFileURL(join(core, p)).href);
const pkg = JSON.parse(readFileSync(join(core, 'package.json'), 'utf8'));
const env = await load('Misc/environmentTextureTools.js');
const { Constants } = await load('Engines/constants.js');
const { SphericalPolynomial } = await load('Maths/sphericalPolynomial.js');
const { CubeMapToSphericalPolynomialTools } = await load(
  'Misc/HighDynamicRange/cubemapToSphericalPolynomial.js',
);

const bytes = new Uint8Array(readFileSync(file));
const info = env.GetEnvInfo(bytes);
if (!info) {
  console.error('Babylon GetEnvInfo refused the file');
  process.exit(1);
}
const views = env.CreateRadianceImageDataArrayBufferViews(bytes, info);
views.forEach((faces, level) =>
  faces.forEach((v, f) => writeFileSync(join(outDir, `m${level}_f${f}.png`), v)),
);

const keys = ['x', 'y', 'z', 'xx', 'yy', 'zz', 'yz', 'zx', 'xy'];
const asArrays = (p) => Object.fromEntries(keys.map((k) => [k, [p[k].x, p[k].y, p[k].z]]));
const result = {
  babylonVersion: pkg.version,
  version: info.version,
  width: info.width,
  imageType: info.imageType,
  lodGenerationScale: info.specular.lodGenerationScale,
  levels: views.length,
  images: views.reduce((n, faces) => n + faces.length, 0),
  irradiance: info.irradiance,
};

if (info.irradiance) {
  // The file's polynomial through Babylon's harmonics shader path.
  const sp = SphericalPolynomial.FromArray(keys.map((k) => info.irradiance[k]));
  const h = sp.preScaledHarmonics;
  const dirs = [
    [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
    [1 / Math.sqrt(3), 1 / Math.sqrt(3), 1 / Math.sqrt(3)],
  ];
  result.shaderIrradiance = dirs.map(([x, y, z]) => {
    const terms = [
      [h.l00, 1], [h.l1_1, y], [h.l10, z], [h.l11, x], [h.l2_2, y * x], [h.l2_1, y * z],
      [h.l20, 3 * z * z - 1], [h.l21, z * x], [h.l22, x * x - y * y],
    ];
    return [0, 1, 2].map((c) => terms.reduce((s, [v, t]) => s + [v.x, v.y, v.z][c] * t, 0));
  });
}

if (facesFile) {
  const raw = readFileSync(facesFile);
  const all = new Float32Array(raw.buffer, raw.byteOffset, raw.byteLength / 4);
  const size = Math.round(Math.sqrt(all.length / 24));
  const face = (i) => all.subarray(i * size * size * 4, (i + 1) * size * size * 4);
  const polynomial = CubeMapToSphericalPolynomialTools.ConvertCubeMapToSphericalPolynomial({
    size,
    right: face(0),
    left: face(1),
    up: face(2),
    down: face(3),
    front: face(4),
    back: face(5),
    format: Constants.TEXTUREFORMAT_RGBA,
    type: Constants.TEXTURETYPE_FLOAT,
    gammaSpace: false,
  });
  result.babylonPolynomial = asArrays(polynomial);
}
console.log(JSON.stringify(result));
