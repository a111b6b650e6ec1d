// Validates a GLB with the Khronos glTF validator; prints the summary, exits 1 on any error.
// Usage: node scripts/validate-gltf.mjs file.glb [--max-issues N]
import { readFile } from 'node:fs/promises';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: validate-gltf.mjs file.glb');
  process.exit(2);
}
const bytes = new Uint8Array(await readFile(file));
const report = await validator.validateBytes(bytes, { maxIssues: 200 });
const { numErrors, numWarnings, numInfos, messages } = report.issues;
for (const m of messages.filter((m) => m.severity === 0).slice(0, 20)) {
  console.error(`error ${m.code} at ${m.pointer ?? ''}: ${m.message}`);
}
console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos`);
process.exit(numErrors === 0 ? 0 : 1);
