// Reads a KTX2 file with Basis Universal's own transcoder as three.js ships it
// (three/examples/jsm/libs/basis/basis_transcoder.{js,wasm}, the one its KTX2Loader runs), and
// transcodes every face of every level as the loader does: to BC6H (desktops without ASTC HDR)
// and to RGBA half floats (devices with neither).
//   node uastc_check.cjs OUTDIR FILE
// Writes OUTDIR/bc6h_<level>_<face>.bin and OUTDIR/half_<level>_<face>.bin and prints one JSON
// line: what the transcoder makes of the file, and which images it could not transcode.
// Needs three (target/tools, or CUBEFORGE_TOOLS).
'use strict';
const path = require('path');
const fs = require('fs');
const tools = path.join(process.env.CUBEFORGE_TOOLS || path.join(__dirname, '..', '..', 'target', 'tools'), 'node_modules');
const basis = path.join(tools, 'three', 'examples', 'jsm', 'libs', 'basis');
// three's package is an ES module package, so its CommonJS-style script is evaluated here
// with the names it expects rather than required.
const script = path.join(basis, 'basis_transcoder.js');
const BASIS = new Function('require', '__filename', '__dirname', 'module', 'exports',
  `${fs.readFileSync(script, 'utf8')}\nreturn BASIS;`)(require, script, basis, {}, {});

// The loader's TranscoderFormat values (KTX2Loader.TranscoderFormat).
const BC6H = 22;
const RGBA_HALF = 25;

const [outDir, file] = process.argv.slice(2);
BASIS({ wasmBinary: fs.readFileSync(path.join(basis, 'basis_transcoder.wasm')) }).then((M) => {
  M.initializeBasis();
  const ktx2 = new M.KTX2File(new Uint8Array(fs.readFileSync(file)));
  const result = {
    valid: ktx2.isValid(),
    hdr: ktx2.isHDR(),
    uastc: ktx2.isUASTC(),
    etc1s: ktx2.isETC1S(),
    width: ktx2.getWidth(),
    height: ktx2.getHeight(),
    faces: ktx2.getFaces(),
    levels: ktx2.getLevels(),
    failed: [],
  };
  if (result.valid && ktx2.startTranscoding()) {
    for (let level = 0; level < result.levels; level++) {
      for (let face = 0; face < result.faces; face++) {
        for (const [name, format] of [['bc6h', BC6H], ['half', RGBA_HALF]]) {
          const dst = new Uint8Array(ktx2.getImageTranscodedSizeInBytes(level, 0, face, format));
          if (ktx2.transcodeImage(dst, level, 0, face, format, 0, -1, -1)) {
            fs.writeFileSync(path.join(outDir, `${name}_${level}_${face}.bin`), dst);
          } else {
            result.failed.push(`${name} level ${level} face ${face}`);
          }
        }
      }
    }
  } else {
    result.failed.push('startTranscoding');
  }
  ktx2.close();
  ktx2.delete();
  console.log(JSON.stringify(result));
});
