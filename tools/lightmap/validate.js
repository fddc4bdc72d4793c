// Runs the Khronos glTF validator on one .glb/.gltf and prints its report
// (JSON) on stdout; exit status 1 when it found errors.
// Usage: node tools/lightmap/validate.js FILE (after `npm ci` in tools/lightmap).
const fs = require("fs");
const validator = require("gltf-validator");

const data = new Uint8Array(fs.readFileSync(process.argv[2]));
validator
  .validateBytes(data, { maxIssues: 100 })
  .then((report) => {
    console.log(JSON.stringify(report.issues));
    process.exit(report.issues.numErrors > 0 ? 1 : 0);
  })
  .catch((error) => {
    console.error(String(error));
    process.exit(2);
  });
