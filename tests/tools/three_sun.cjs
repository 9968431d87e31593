// Renders ibl --sun's scene in three.js (npm `three`) in headless Chromium: a white diffuse
// sphere (radius 1 at the origin) on a ground plane (y = -1), seen from (0, 5, 7) looking at
// the sphere's centre (as preview's --pitch 35.54 --distance 8.602 --fov 45 sees it), lit once
// by the full map alone and once by the map without its sun plus the snippet's
// DirectionalLight (its shadow on):
//   node three_sun.cjs FULL.hdr SUNLESS.hdr SUN.json
// SUN.json is ibl --sun's sun.json (engine_direction, engine_intensity, engine_color). Prints
// one JSON line: for each render the sphere's mean radiance (RGB, linear, over the disc it
// covers on screen) and the ground's luminance where the sun's shadow of the sphere falls and
// on the sunlit side opposite; the same with a diffuse-only material (full_diffuse,
// sun_diffuse); or {"error": "..."}. Needs puppeteer-core and three
// (target/tools) and chromium.
'use strict';
const fs = require('fs');
const { ORIGIN, IMPORTS, withPage } = require('./three_page.cjs');

const PAGE = `<!doctype html>${IMPORTS}
<script type="module">
import * as THREE from 'three';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
const W = 256, H = 256;
const renderer = new THREE.WebGLRenderer();
renderer.shadowMap.enabled = true;
renderer.shadowMap.type = THREE.PCFSoftShadowMap;
const load = (url) => new Promise((ok, fail) => new HDRLoader().setDataType(THREE.FloatType).load(url, ok, undefined, fail));
window.render = async (mapUrl, sun, diffuseOnly) => {
  const tex = await load(mapUrl);
  tex.mapping = THREE.EquirectangularReflectionMapping;
  const pmrem = new THREE.PMREMGenerator(renderer);
  const scene = new THREE.Scene();
  scene.environment = pmrem.fromEquirectangular(tex).texture;
  // Diffuse only: specularIntensity 0 makes F0 = F90 = 0, so no specular lobe and no (1 - F)
  // on the diffuse one: Lambert alone, the map's light through getIBLIrradiance.
  const white = diffuseOnly
    ? new THREE.MeshPhysicalMaterial({ color: 0xffffff, roughness: 1, metalness: 0, specularIntensity: 0 })
    : new THREE.MeshStandardMaterial({ color: 0xffffff, roughness: 1, metalness: 0 });
  const ball = new THREE.Mesh(new THREE.SphereGeometry(1, 96, 48), white);
  ball.castShadow = true;
  scene.add(ball);
  const ground = new THREE.Mesh(new THREE.PlaneGeometry(40, 40), white);
  ground.rotation.x = -Math.PI / 2;
  ground.position.y = -1;
  ground.receiveShadow = true;
  scene.add(ground);
  if (sun) {
    // The snippet's lines, with its numbers.
    const [x, y, z] = sun.engine_direction;
    const light = new THREE.DirectionalLight(new THREE.Color(...sun.engine_color), sun.engine_intensity);
    light.position.set(x * 50, y * 50, z * 50);
    light.castShadow = true;
    light.shadow.mapSize.set(2048, 2048);
    Object.assign(light.shadow.camera, { left: -6, right: 6, top: 6, bottom: -6, near: 1, far: 100 });
    light.shadow.bias = -0.0005;
    scene.add(light);
  }
  const camera = new THREE.PerspectiveCamera(45, W / H, 0.1, 100);
  camera.position.set(0, 5, 7);
  camera.lookAt(0, 0, 0);
  camera.updateMatrixWorld();
  const rt = new THREE.WebGLRenderTarget(W, H, { type: THREE.FloatType });
  renderer.setRenderTarget(rt);
  renderer.render(scene, camera);
  const px = new Float32Array(W * H * 4);
  renderer.readRenderTargetPixels(rt, 0, 0, W, H, px);
  renderer.setRenderTarget(null);
  // Screen position (x right, y up from the bottom row, as read) of a world point.
  const at = (p) => {
    const v = new THREE.Vector3(...p).project(camera);
    return [(v.x + 1) / 2 * W, (v.y + 1) / 2 * H];
  };
  const lum = (i) => 0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2];
  const mean = (cx, cy, r) => {
    const s = [0, 0, 0]; let n = 0;
    for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
      if ((x + 0.5 - cx) ** 2 + (y + 0.5 - cy) ** 2 > r * r) continue;
      const i = (y * W + x) * 4;
      for (let c = 0; c < 3; c++) s[c] += px[i + c];
      n++;
    }
    return s.map((v) => v / n);
  };
  // The sphere's disc on screen, taken at 0.8 of its radius (no edge, no ground).
  const [cx, cy] = at([0, 0, 0]);
  const edge = at(new THREE.Vector3(1, 0, 0).applyQuaternion(camera.quaternion).toArray());
  const r = Math.hypot(edge[0] - cx, edge[1] - cy) * 0.8;
  const [dx, dy, dz] = window.sunDir;
  const shadow = at([-dx / dy, -1, -dz / dy]);
  const spot = (p) => { const m = mean(p[0], p[1], 3); return 0.2126 * m[0] + 0.7152 * m[1] + 0.0722 * m[2]; };
  // The sunlit ground beside the shadow: 2.5 units across the shadow's axis, on either side
  // (the brighter: the other may lie behind the sphere on screen).
  const k = 2.5 / Math.hypot(dx, dz);
  const sides = [1, -1].map((s) => at([-dx / dy - s * dz * k, -1, -dz / dy + s * dx * k]));
  const lits = sides.map(spot);
  const i = lits[0] >= lits[1] ? 0 : 1;
  return { sphere: mean(cx, cy, r), shadow: spot(shadow), lit: lits[i], shadow_px: shadow, lit_px: sides[i] };
};
window.pageReady = true;
</script>`;

(async () => {
  const [full, sunless, sunJson] = process.argv.slice(2);
  const sun = JSON.parse(fs.readFileSync(sunJson, 'utf8'));
  const files = [full, sunless];
  const serve = (rel) => rel.startsWith('file/') && files[Number(rel.split('/')[1])];
  await withPage(PAGE, serve, async (tab) => {
    await tab.evaluate((d) => { window.sunDir = d; }, sun.engine_direction);
    const url = (k) => `${ORIGIN}file/${k}/x.hdr`;
    const run = (k, s, d) => tab.evaluate((u, s, d) => window.render(u, s, d), url(k), s, d);
    const a = await run(0, null, false);
    const b = await run(1, sun, false);
    const ad = await run(0, null, true);
    const bd = await run(1, sun, true);
    console.log(JSON.stringify({ full: a, sun: b, full_diffuse: ad, sun_diffuse: bd }));
  });
})().catch((e) => { console.log(JSON.stringify({ error: String(e) })); process.exit(1); });
