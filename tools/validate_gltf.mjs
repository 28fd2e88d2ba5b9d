// Runs the Khronos glTF validator on each file given and prints one JSON object per file:
// {"file", "errors", "warnings", "infos", "hints", "messages": [first 20 issues]}.
// Exit code: 0 if no file has errors, 1 if some file has errors, 2 on usage or read failure.
// Usage: node tools/validate_gltf.mjs FILE.glb [FILE.glb …]
import { readFile } from 'node:fs/promises';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const validator = require('gltf-validator');

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate_gltf.mjs FILE.glb [FILE.glb …]');
  process.exit(2);
}
let failed = false;
for (const file of files) {
  let bytes;
  try {
    bytes = new Uint8Array(await readFile(file));
  } catch (e) {
    console.error(`${file}: ${e.message}`);
    process.exit(2);
  }
  const report = await validator.validateBytes(bytes, { uri: file, maxIssues: 1000 });
  const issues = report.issues;
  if (issues.numErrors > 0) failed = true;
  console.log(JSON.stringify({
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    hints: issues.numHints,
    messages: issues.messages.slice(0, 20).map((m) => `${['error', 'warning', 'info', 'hint'][m.severity]} ${m.code} ${m.pointer ?? ''}: ${m.message}`),
  }));
}
process.exit(failed ? 1 : 0);
