// Runs `ibl --target three`'s printed snippet (its import lines and its loader call, given in a
// file) in headless Chromium on the page's WebGL2 renderer, the snippet's files served beside the
// page, then draws the scene's background it set, looking along each given direction:
//   node three_background.cjs SNIPPET_JS FOLDER X,Y,Z...
// Prints one JSON line {"looks": [[r, g, b], ...]} (the mean of the 8 x 8 centre texels of a
// 64 x 64 view with a 20 degree field, 0-255 sRGB as drawn, no tone mapping) or {"error": "..."}.
// A background three draws black (a one-level cube sampled through a mip-map filter) reads 0.
// Needs puppeteer-core and three (target/tools) and chromium.
'use strict';
const path = require('path');
const fs = require('fs');
const { ORIGIN, IMPORTS, withPage } = require('./three_page.cjs');

const PAGE = `<!doctype html><canvas id="c" width="64" height="64"></canvas>
${IMPORTS}
<script type="module">
import * as THREE from 'three';
const renderer = new THREE.WebGLRenderer({ canvas: document.getElementById('c'), preserveDrawingBuffer: true });
renderer.setSize(64, 64, false);
renderer.toneMapping = THREE.NoToneMapping;
window.look = async (dirs) => {
  const scene = new THREE.Scene();
  (await import('${ORIGIN}snippet.js')).default(THREE, renderer, scene);
  for (let i = 0; i < 600 && !scene.background; i++) await new Promise((r) => setTimeout(r, 100));
  if (!scene.background) throw new Error('the snippet set no background in 60 s');
  const camera = new THREE.PerspectiveCamera(20, 1, 0.1, 10);
  const gl = renderer.getContext();
  const looks = [];
  for (const [x, y, z] of dirs) {
    camera.up.set(Math.abs(y) > 0.99 ? 1 : 0, Math.abs(y) > 0.99 ? 0 : 1, 0);
    camera.lookAt(x, y, z);
    renderer.render(scene, camera);
    const px = new Uint8Array(8 * 8 * 4);
    gl.readPixels(28, 28, 8, 8, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const mean = [0, 0, 0];
    for (let i = 0; i < 64; i++) for (let c = 0; c < 3; c++) mean[c] += px[i * 4 + c] / 64;
    looks.push(mean);
  }
  return looks;
};
window.pageReady = true;
</script>`;

(async () => {
  const [snippetFile, folder, ...dirs] = process.argv.slice(2);
  // The snippet's imports stay module imports; the rest runs with THREE, renderer and scene.
  const lines = fs.readFileSync(snippetFile, 'utf8').split('\n');
  const imports = lines.filter((l) => l.trim().startsWith('import '));
  const body = lines.filter((l) => !l.trim().startsWith('import '));
  const snippet = imports.join('\n') + '\nexport default (THREE, renderer, scene) => {\n' + body.join('\n') + '\n};\n';
  // The snippet as a module; anything else by its name from the snippet's folder.
  const serve = (rel) => rel === 'snippet.js'
    ? { contentType: 'text/javascript', body: snippet }
    : path.join(folder, path.basename(rel));
  await withPage(PAGE, serve, async (tab) => {
    const looks = await tab.evaluate((d) => window.look(d), dirs.map((d) => d.split(',').map(Number)));
    console.log(JSON.stringify({ looks }));
  });
})().catch((e) => { console.log(JSON.stringify({ error: String(e && e.message || e) })); process.exit(1); });
