// Runs the Khronos glTF validator on one .gltf or .glb file and prints
//   errors=E warnings=W infos=I hints=H
// then one line per error or warning (code, pointer, message).
// usage: node validate_gltf.js VALIDATOR_DIR FILE   (exit 0 = validated)
const fs = require('fs');
const path = require('path');
const validator = require(path.join(process.argv[2], 'node_modules', 'gltf-validator'));
const file = process.argv[3];

validator
  .validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 100,
    // Our files are self-contained: any external resource is a failure.
    externalResourceFunction: (uri) => Promise.reject(new Error('external resource ' + uri)),
  })
  .then((report) => {
    const i = report.issues;
    console.log(`errors=${i.numErrors} warnings=${i.numWarnings} infos=${i.numInfos} ` +
                `hints=${i.numHints}`);
    for (const m of i.messages.filter((m) => m.severity <= 1))
      console.log(`${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ` +
                  m.message);
  })
  .catch((error) => {
    console.error(`${file}: validator failed: ${error}`);
    process.exit(1);
  });
