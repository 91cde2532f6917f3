// Reads a `shvis export` folder as an engine's tools would, with nothing of shvis: every
// KTX2 file through ktx-parse (the reader of three.js' KTX2Loader and glTF-Transform) and
// the scene through the Khronos glTF validator. Prints one JSON object on stdout:
//   { "ktx2": [ { file, vkFormat, pixelWidth, pixelHeight, pixelDepth, layerCount,
//                 faceCount, levelCount, supercompressionScheme, levelBytes,
//                 colorModel, colorPrimaries, transferFunction,
//                 samples: [ { channelType, bitLength, lower, upper } ],  (bounds as u32 bits)
//                 keyValue: { KTXorientation, KTXwriter } } ],
//     "gltf": { numErrors, numWarnings, messages: [ { code, severity, message, pointer } ] } }
// Usage: node check_export.mjs EXPORT_DIR
import { readFileSync, readdirSync } from 'node:fs';
import { join } from 'node:path';
import { read } from 'ktx-parse';
import validator from 'gltf-validator';

const dir = process.argv[2];
const manifest = JSON.parse(readFileSync(join(dir, 'manifest.json'), 'utf8'));
const u32 = (v) => v >>> 0;
const ktx2 = readdirSync(dir)
  .filter((f) => f.endsWith('.ktx2'))
  .sort()
  .map((file) => {
    const c = read(new Uint8Array(readFileSync(join(dir, file))));
    const dfd = c.dataFormatDescriptor[0];
    const text = (v) => (typeof v === 'string' ? v : null);
    return {
      file,
      vkFormat: c.vkFormat,
      pixelWidth: c.pixelWidth,
      pixelHeight: c.pixelHeight,
      pixelDepth: c.pixelDepth,
      layerCount: c.layerCount,
      faceCount: c.faceCount,
      levelCount: c.levels.length,
      supercompressionScheme: c.supercompressionScheme,
      levelBytes: c.levels[0].levelData.byteLength,
      colorModel: dfd.colorModel,
      colorPrimaries: dfd.colorPrimaries,
      transferFunction: dfd.transferFunction,
      samples: dfd.samples.map((s) => ({
        channelType: s.channelType,
        bitLength: s.bitLength,
        lower: u32(s.sampleLower),
        upper: u32(s.sampleUpper),
      })),
      keyValue: {
        KTXorientation: text(c.keyValue.KTXorientation),
        KTXwriter: text(c.keyValue.KTXwriter),
      },
    };
  });

let gltf = null;
if (manifest.geometry) {
  const name = manifest.geometry.gltf;
  const report = await validator.validateBytes(new Uint8Array(readFileSync(join(dir, name))), {
    uri: name,
    externalResourceFunction: (uri) =>
      Promise.resolve(new Uint8Array(readFileSync(join(dir, decodeURIComponent(uri))))),
  });
  gltf = {
    numErrors: report.issues.numErrors,
    numWarnings: report.issues.numWarnings,
    messages: report.issues.messages.map(({ code, severity, message, pointer }) => ({
      code,
      severity,
      message,
      pointer,
    })),
  };
}
process.stdout.write(JSON.stringify({ ktx2, gltf }) + '\n');
