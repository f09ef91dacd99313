// Converts one model file to glTF 2.0 binary with assimpjs (assimp built to WebAssembly, from
// npm), for the rig corpus. Used where Debian's assimp 5.2 command line fails on a file
// (its B3D reader stops at a key one frame past the clip's end).
// Usage: node assimpjs-convert.js ASSIMPJS_PACKAGE_DIR IN OUT.glb [SIDE_FILE...]
'use strict';
const fs = require('fs');
const path = require('path');

const [pkg, input, output, ...side] = process.argv.slice(2);
if (!output) {
  console.error('usage: node assimpjs-convert.js ASSIMPJS_PACKAGE_DIR IN OUT.glb [SIDE_FILE...]');
  process.exit(2);
}
require(path.resolve(pkg, 'dist', 'assimpjs.js'))().then((ajs) => {
  const files = new ajs.FileList();
  for (const f of [input, ...side]) files.AddFile(path.basename(f), fs.readFileSync(f));
  const result = ajs.ConvertFileList(files, 'glb2');
  if (!result.IsSuccess() || result.FileCount() === 0) {
    console.error(`assimpjs-convert: ${input}: ${result.GetErrorCode()}`);
    process.exit(1);
  }
  fs.writeFileSync(output, result.GetFile(0).GetContent());
}).catch((e) => {
  console.error(`assimpjs-convert: ${input}: ${e}`);
  process.exit(1);
});
