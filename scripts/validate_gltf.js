// The Khronos glTF validator over the files given (scripts/validate-gltf installs it):
// external buffers and images are read from each file's own folder.
const validator = require('gltf-validator');
const fs = require('fs');
const path = require('path');

(async () => {
  let failed = 0;
  for (const file of process.argv.slice(2)) {
    const folder = path.dirname(file);
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file),
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => fs.readFile(path.join(folder, decodeURIComponent(uri)),
          (err, data) => err ? reject(err.toString()) : resolve(new Uint8Array(data)))),
    });
    const issues = report.issues;
    console.log(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
                `${issues.numInfos} infos`);
    for (const m of issues.messages.filter((m) => m.severity <= 1))
      console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ` +
                  m.message);
    if (issues.numErrors > 0) ++failed;
  }
  process.exit(failed > 0 ? 1 : 0);
})();
