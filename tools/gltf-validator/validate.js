#!/usr/bin/env node
// Validates one glTF 2.0 asset (.gltf or .glb) with the vendored Khronos glTF validator and
// prints the issue counts as one line of JSON:
//   {"file":"...","validator":"2.0.0-dev.3.10","errors":0,"warnings":0,"infos":0,"hints":0,
//    "messages":[{"code":"...","severity":0,"pointer":"...","message":"..."}]}
// severity: 0 error, 1 warning, 2 info, 3 hint. Exit status: 0 when the asset has no errors,
// 1 when it has errors, 2 when it could not be validated (unreadable, not glTF).
//
//   node tools/gltf-validator/validate.js FILE [--max-messages N]
// External resources (a .gltf's .bin or images) are read relative to FILE.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('./index.js');

function usage() {
  process.stderr.write('usage: node validate.js FILE.{gltf,glb} [--max-messages N]\n');
  process.exit(2);
}

const args = process.argv.slice(2);
if (args.length < 1 || args[0] === '--help' || args[0] === '-h') usage();
const file = args[0];
let maxMessages = 20;
for (let i = 1; i < args.length; ++i) {
  if (args[i] === '--max-messages' && i + 1 < args.length) {
    maxMessages = Number(args[++i]);
    if (!Number.isInteger(maxMessages) || maxMessages < 0) usage();
  } else {
    usage();
  }
}

let bytes;
try {
  bytes = fs.readFileSync(file);
} catch (e) {
  process.stdout.write(JSON.stringify({file, error: 'cannot read: ' + e.message}) + '\n');
  process.exit(2);
}

validator
    .validateBytes(new Uint8Array(bytes), {
      uri: path.basename(file),
      maxIssues: 0,
      writeTimestamp: false,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        const resolved = path.resolve(path.dirname(file), decodeURIComponent(uri));
        fs.readFile(resolved, (err, data) => err ? reject(err.toString()) : resolve(data));
      }),
    })
    .then((report) => {
      const issues = report.issues;
      const out = {
        file,
        validator: report.validatorVersion,
        errors: issues.numErrors,
        warnings: issues.numWarnings,
        infos: issues.numInfos,
        hints: issues.numHints,
        messages: issues.messages.slice(0, maxMessages).map(
            (m) => ({code: m.code, severity: m.severity, pointer: m.pointer, message: m.message})),
      };
      process.stdout.write(JSON.stringify(out) + '\n');
      process.exit(issues.numErrors === 0 ? 0 : 1);
    })
    .catch((error) => {
      process.stdout.write(JSON.stringify({file, error: String(error)}) + '\n');
      process.exit(2);
    });
