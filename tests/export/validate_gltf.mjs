// Validates glTF files (.glb, or .gltf with its external buffers) with the Khronos glTF validator.
//
//   node validate_gltf.mjs [--fail-on-warnings] FILE...
//
// Prints one summary line per file and every error, warning and info with its JSON pointer.
// Exit status: 0 all valid, 1 errors (or warnings with --fail-on-warnings), 2 usage or set-up
// problem (validator not installed, file unreadable).
// The npm package `gltf-validator` is looked up in $GLTF_VALIDATOR_DIR/node_modules (the build
// tree's `npm install --prefix` folder), else by Node's usual resolution.
import { createRequire } from 'node:module';
import fs from 'node:fs';
import path from 'node:path';

function loadValidator() {
  const dir = process.env.GLTF_VALIDATOR_DIR;
  const require = createRequire(dir ? path.join(path.resolve(dir), 'resolve-from-here.js') : import.meta.url);
  try {
    return require('gltf-validator');
  } catch (e) {
    console.error(`gltf-validator is not installed${dir ? ` under ${dir}/node_modules` : ''}: ${e.message}`);
    console.error('install it with: npm install --prefix <dir> gltf-validator (see tests/CMakeLists.txt)');
    process.exit(2);
  }
}

const args = process.argv.slice(2);
const failOnWarnings = args.includes('--fail-on-warnings');
const files = args.filter((a) => a !== '--fail-on-warnings');
if (files.length === 0) {
  console.error('usage: node validate_gltf.mjs [--fail-on-warnings] FILE...');
  process.exit(2);
}

const validator = loadValidator();
const severityName = ['error', 'warning', 'info', 'hint'];
let failed = false;

for (const file of files) {
  let bytes;
  try {
    bytes = fs.readFileSync(file);
  } catch (e) {
    console.error(`${file}: cannot read: ${e.message}`);
    process.exit(2);
  }
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 0,  // report everything
    writeTimestamp: false,
    // .gltf files name their .bin by a relative URI: read it from beside the file.
    externalResourceFunction: (uri) =>
      fs.promises.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ${numHints} hints`);
  for (const m of messages) {
    if (m.severity > 2) continue;  // hints are noise for our files
    console.log(`  ${severityName[m.severity] ?? m.severity} ${m.code} at ${m.pointer ?? m.offset ?? '?'}: ${m.message}`);
  }
  if (numErrors > 0 || (failOnWarnings && numWarnings > 0)) failed = true;
}
process.exit(failed ? 1 : 0);
