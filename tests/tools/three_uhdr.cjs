// Reads image files with three.js's own loaders in headless Chromium: UltraHDRLoader for .jpg,
// HDRLoader for .hdr, EXRLoader for .exr, KTX2Loader for .ktx2 (npm `three`, as an application
// imports them; KTX2Loader with detectSupport on the page's WebGL2 renderer, its Basis
// transcoder in a worker):
//   node three_uhdr.cjs OUTDIR FILE...
// For each file writes OUTDIR/<i>.f32 (the texture's data as three.js holds it: RGBA float32,
// rows as stored in the file, top first; for .ktx2, level 0's bytes as the loader made them,
// "format" saying which: "bc6h" blocks or "half" RGBA half floats) and prints one JSON line
// {"width", "height", "flipY"[, "format", "mips"]} or {"error": "..."}. Pages are served from
// memory (request interception), so ES modules load without a server. Needs puppeteer-core
// and three (target/tools) and chromium.
'use strict';
const path = require('path');
const fs = require('fs');
const { ORIGIN, IMPORTS, withPage } = require('./three_page.cjs');

const PAGE = `<!doctype html>${IMPORTS}
<script type="module">
import * as THREE from 'three';
import { UltraHDRLoader } from 'three/addons/loaders/UltraHDRLoader.js';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
const base64 = (bytes) => {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
};
const ktx2 = new KTX2Loader()
  .setTranscoderPath('${ORIGIN}three/examples/jsm/libs/basis/')
  .detectSupport(new THREE.WebGLRenderer());
window.readKtx2 = (url) => new Promise((resolve) => {
  ktx2.load(url, (tex) => {
    const m = tex.mipmaps[0];
    const format = tex.format === THREE.RGB_BPTC_UNSIGNED_Format ? 'bc6h'
      : tex.format === THREE.RGBAFormat && tex.type === THREE.HalfFloatType ? 'half'
      : 'format ' + tex.format + ' type ' + tex.type;
    const bytes = new Uint8Array(m.data.buffer, m.data.byteOffset, m.data.byteLength);
    resolve({ width: m.width, height: m.height, flipY: tex.flipY, format, mips: tex.mipmaps.length, data: base64(bytes) });
  }, undefined, (e) => resolve({ error: String(e && e.message || e) }));
});
window.readFile = (url) => new Promise((resolve) => {
  const ext = url.split('.').pop().toLowerCase();
  if (ext === 'ktx2') return window.readKtx2(url).then(resolve);
  const loader = ext === 'jpg' ? new UltraHDRLoader() : ext === 'hdr' ? new HDRLoader() : new EXRLoader();
  loader.setDataType(THREE.FloatType);
  loader.load(url, (tex) => {
    const img = tex.image;
    const data = new Float32Array(img.data.buffer, img.data.byteOffset, img.data.length);
    const channels = data.length / (img.width * img.height);
    const rgba = new Float32Array(img.width * img.height * 4);
    for (let i = 0; i < img.width * img.height; i++) {
      for (let c = 0; c < 4; c++) rgba[i * 4 + c] = c < channels ? data[i * channels + c] : 1;
    }
    resolve({ width: img.width, height: img.height, flipY: tex.flipY, data: base64(new Uint8Array(rgba.buffer)) });
  }, undefined, (e) => resolve({ error: String(e && e.message || e) }));
});
window.pageReady = true;
</script>`;

(async () => {
  const [outdir, ...files] = process.argv.slice(2);
  const serve = (rel) => rel.startsWith('file/') && files[Number(rel.split('/')[1])];
  await withPage(PAGE, serve, async (tab) => {
    for (const [i, file] of files.entries()) {
      const ext = path.extname(file);
      const r = await tab.evaluate((u) => window.readFile(u), `${ORIGIN}file/${i}/x${ext}`);
      if (r.error) {
        console.log(JSON.stringify({ error: r.error }));
        continue;
      }
      fs.writeFileSync(path.join(outdir, i + '.f32'), Buffer.from(r.data, 'base64'));
      const { data, ...rest } = r;
      console.log(JSON.stringify(rest));
    }
  });
})().catch((e) => { console.log(JSON.stringify({ error: String(e) })); process.exit(1); });
