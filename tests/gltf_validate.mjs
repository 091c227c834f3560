// Validate glTF files with the Khronos glTF validator (npm `gltf-validator`).
//
//   node tests/gltf_validate.mjs VALIDATOR_DIR FILE.glb [FILE.glb ...]
//
// VALIDATOR_DIR is the installed package folder (.../node_modules/gltf-validator).
// Prints one JSON array: each file's validation report, in the order given,
// with the file name in `uri`. Exits 1 when the validator cannot run.
import { createRequire } from "node:module";
import { readFileSync } from "node:fs";
import { basename, resolve } from "node:path";

const [validatorDir, ...files] = process.argv.slice(2);
if (!validatorDir || files.length === 0) {
  console.error("usage: node gltf_validate.mjs VALIDATOR_DIR FILE.glb [FILE.glb ...]");
  process.exit(1);
}
const require = createRequire(import.meta.url);
const validator = require(resolve(validatorDir));

const reports = [];
for (const file of files) {
  const bytes = new Uint8Array(readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: basename(file),
    maxIssues: 0, // 0: report every issue
  });
  reports.push(report);
}
process.stdout.write(JSON.stringify(reports, null, 1) + "\n");
