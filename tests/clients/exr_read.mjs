// Decodes OpenEXR files with three.js's EXRLoader (a JavaScript decoder written apart from the
// OpenEXR library that writes them) and prints each as JSON lines: {file, width, height, channels,
// compression, values} with values row-major from the top row (EXRLoader stores rows bottom-up for
// WebGL; this script puts them back). Usage: node exr_read.mjs THREE_DIR FILE...
import { readFileSync } from 'node:fs';
import { pathToFileURL } from 'node:url';

const [threeDir, ...files] = process.argv.slice(2);
const three = await import(pathToFileURL(`${threeDir}/build/three.module.js`).href);
const { EXRLoader } = await import(pathToFileURL(`${threeDir}/examples/jsm/loaders/EXRLoader.js`).href);

for (const file of files) {
  const bytes = readFileSync(file);
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const loader = new EXRLoader();
  loader.setDataType(three.FloatType);
  const out = loader.parse(buffer);
  const { width, height } = out;
  const per = out.data.length / (width * height);
  const values = new Array(width * height);
  for (let y = 0; y < height; y++)
    for (let x = 0; x < width; x++) values[y * width + x] = out.data[((height - 1 - y) * width + x) * per];
  console.log(JSON.stringify({
    file, width, height, channels: out.header.channels.map((c) => c.name), compression: out.header.compression, values,
  }));
}
