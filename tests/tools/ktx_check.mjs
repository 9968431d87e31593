// Parses a KTX2 file with ktx-parse (an independent reader) and prints what it found as JSON.
//
//   node ktx_check.mjs <dir holding node_modules/ktx-parse> <file.ktx2>
//
// Used by tests/containers.rs; exits non-zero (with the reason on stderr) if parsing fails.
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';

const [toolsDir, file] = process.argv.slice(2);
if (!toolsDir || !file) {
  console.error('usage: node ktx_check.mjs <tools dir> <file.ktx2>');
  process.exit(2);
}
const pkg = JSON.parse(
  readFileSync(join(toolsDir, 'node_modules', 'ktx-parse', 'package.json'), 'utf8'),
);
const entry = pkg.exports?.['.']?.default ?? pkg.exports?.['.']?.import ?? pkg.module ?? pkg.main;
const { read, write } = await import(
  pathToFileURL(join(toolsDir, 'node_modules', 'ktx-parse', entry)).href
);

const bytes = new Uint8Array(readFileSync(file));
const c = read(bytes);
const dfd = c.dataFormatDescriptor[0];
const text = (v) => (typeof v === 'string' ? v : new TextDecoder().decode(v)).replace(/\0+$/, '');
console.log(
  JSON.stringify({
    ktxParseVersion: pkg.version,
    vkFormat: c.vkFormat,
    typeSize: c.typeSize,
    pixelWidth: c.pixelWidth,
    pixelHeight: c.pixelHeight,
    pixelDepth: c.pixelDepth,
    layerCount: c.layerCount,
    faceCount: c.faceCount,
    levelCount: c.levelCount ?? c.levels.length,
    supercompressionScheme: c.supercompressionScheme,
    levels: c.levels.map((l) => l.levelData.byteLength),
    uncompressedLevels: c.levels.map((l) => l.uncompressedByteLength),
    dfd: {
      colorModel: dfd.colorModel,
      colorPrimaries: dfd.colorPrimaries,
      transferFunction: dfd.transferFunction,
      flags: dfd.flags,
      bytesPlane0: dfd.bytesPlane[0],
      samples: dfd.samples.map((s) => ({
        bitOffset: s.bitOffset,
        bitLength: s.bitLength,
        channelType: s.channelType,
        lower: s.sampleLower,
        upper: s.sampleUpper,
      })),
    },
    writer: c.keyValue.KTXwriter === undefined ? null : text(c.keyValue.KTXwriter),
    // ktx-parse writing the parsed container back out gives the same bytes: the layout
    // (offsets, alignment, padding, level order) is the canonical one.
    rewriteIdentical: Buffer.from(write(c, { keepWriter: true })).equals(Buffer.from(bytes)),
  }),
);
