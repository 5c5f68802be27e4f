// Runs the Khronos glTF validator (npm `gltf-validator`, pinned in
// package.json) on each file given and prints one JSON line per file:
// {"file", "errors", "warnings", "infos", "messages": [first errors and
// warnings]}. Exits 1 when any file has an error, 2 on bad usage.
// Used by crates/cli/tests/views.rs; runnable by hand:
//   node tests/js/validate_gltf.cjs scene.glb
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function main(files) {
  if (files.length === 0) {
    console.error('usage: node validate_gltf.cjs FILE.glb...');
    return 2;
  }
  let failed = false;
  for (const file of files) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file),
      maxIssues: 100,
      // A .glb written by vpctl is self-contained: any external reference is a bug.
      externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
    });
    const issues = report.issues;
    const messages = issues.messages
      .filter((m) => m.severity <= 1)
      .slice(0, 10)
      .map((m) => `${m.severity === 0 ? 'error' : 'warning'} ${m.code} at ${m.pointer || '-'}: ${m.message}`);
    console.log(JSON.stringify({
      file,
      errors: issues.numErrors,
      warnings: issues.numWarnings,
      infos: issues.numInfos,
      messages,
    }));
    if (issues.numErrors > 0) failed = true;
  }
  return failed ? 1 : 0;
}

main(process.argv.slice(2)).then(
  (code) => process.exit(code),
  (e) => { console.error(e && e.stack ? e.stack : String(e)); process.exit(1); },
);
