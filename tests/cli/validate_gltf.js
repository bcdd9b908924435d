// Validates glTF files with the Khronos glTF validator (npm gltf-validator): prints
// each file's error, warning and info counts and its first issues, and exits 1 when
// any file has an error or a warning. Usage: node validate_gltf.js VALIDATOR_DIR FILE...
// (VALIDATOR_DIR: the node_modules folder that holds gltf-validator).
const fs = require('fs');
const path = require('path');
const validator = require(path.join(path.resolve(process.argv[2]), 'gltf-validator'));

async function main() {
  let failed = false;
  for (const file of process.argv.slice(3)) {
    const dir = path.dirname(file);
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file),
      maxIssues: 20,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.join(dir, decodeURIComponent(uri)), (err, data) => err ? reject(err.toString()) : resolve(new Uint8Array(data)));
      }),
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos`);
    for (const m of i.messages) console.log(`  ${['error', 'warning', 'info', 'hint'][m.severity]} ${m.code} ${m.pointer || ''}: ${m.message}`);
    if (i.numErrors > 0 || i.numWarnings > 0) failed = true;
  }
  process.exit(failed ? 1 : 0);
}
main().catch((e) => { console.error(`validate_gltf.js: ${e}`); process.exit(2); });
