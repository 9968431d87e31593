// Parses a KTX 1 file with PlayCanvas's KtxParser (an independent reader, the one the PlayCanvas
// engine loads .ktx textures with) and prints what it found as JSON; writes each face's bytes as
// PlayCanvas sliced them to <out dir>/m<level>_f<face>.bin.
//
//   node ktx1_check.mjs <dir holding node_modules/playcanvas> <file.ktx> <out dir>
//
// PlayCanvas does not read key/value data: the pairs are listed here by a plain reading of the
// KTX 1.1 layout, for the test to check against what cubeforge wrote. Exits non-zero (with the
// reason on stderr) when PlayCanvas refuses the file.
import { readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';

const [toolsDir, file, outDir] = process.argv.slice(2);
if (!toolsDir || !file || !outDir) {
  console.error('usage: node ktx1_check.mjs <tools dir> <file.ktx> <out dir>');
  process.exit(2);
}
const root = join(toolsDir, 'node_modules', 'playcanvas');
const pkg = JSON.parse(readFileSync(join(root, 'package.json'), 'utf8'));
const src = join(root, 'build', 'playcanvas', 'src');
const { KtxParser } = await import(
  pathToFileURL(join(src, 'framework', 'parsers', 'texture', 'ktx.js')).href
);
const { pixelFormatInfo } = await import(
  pathToFileURL(join(src, 'platform', 'graphics', 'constants.js')).href
);

const bytes = readFileSync(file);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const parsed = new KtxParser(null).parse(buffer);
if (!parsed) {
  console.error('PlayCanvas KtxParser refused the file');
  process.exit(1);
}
const faceLists = parsed.cubemap ? parsed.levels : parsed.levels.map((l) => [l]);
const faceBytes = faceLists.map((faces, level) =>
  faces.map((face, f) => {
    const u8 = new Uint8Array(face.buffer, face.byteOffset, face.byteLength);
    writeFileSync(join(outDir, `m${level}_f${f}.bin`), u8);
    return u8.byteLength;
  }),
);

// Key/value pairs by the specification's layout (little-endian files only).
const view = new DataView(buffer);
const kvLen = view.getUint32(60, true);
const keyValues = {};
for (let at = 64; at < 64 + kvLen; ) {
  const n = view.getUint32(at, true);
  const kv = bytes.subarray(at + 4, at + 4 + n);
  const nul = kv.indexOf(0);
  keyValues[Buffer.from(kv.subarray(0, nul)).toString('utf8')] = Buffer.from(
    kv.subarray(nul + 1),
  ).toString('latin1');
  at += 4 + n + ((4 - (n % 4)) % 4);
}

console.log(
  JSON.stringify({
    playcanvasVersion: pkg.version,
    format: pixelFormatInfo.get(parsed.format)?.name ?? parsed.format,
    width: parsed.width,
    height: parsed.height,
    cubemap: parsed.cubemap,
    levels: faceLists.length,
    faceBytes,
    keyValues,
  }),
);
