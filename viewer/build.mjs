// Builds the viewer into one folder: index.html, viewer.js (main.js and three.js bundled by
// esbuild, minified) and draco/ (three.js's copy of Google's Draco decoder, WebAssembly and
// its JavaScript fallback), with the licences of what is bundled.
//   node viewer/build.mjs --out DIR      (run from anywhere, after `npm ci` in DIR/../viewer-npm
//                                          or in viewer/; --modules names node_modules)
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const value = (name, fallback) => (args.includes(name) ? args[args.indexOf(name) + 1] : fallback);
const out = path.resolve(value('--out', path.join(here, 'dist')));
const modules = path.resolve(value('--modules', path.join(here, 'node_modules')));
const require = createRequire(path.join(modules, 'index.js'));
const esbuild = require('esbuild');

fs.mkdirSync(path.join(out, 'draco'), { recursive: true });
await esbuild.build({
  entryPoints: [path.join(here, 'main.js')],
  bundle: true,
  minify: true,
  format: 'esm',
  target: 'es2020',
  nodePaths: [modules],
  outfile: path.join(out, 'viewer.js'),
  legalComments: 'none',
  logLevel: 'warning',
});
fs.copyFileSync(path.join(here, 'index.html'), path.join(out, 'index.html'));
const dracoDir = path.join(modules, 'three/examples/jsm/libs/draco');
for (const file of ['draco_decoder.wasm', 'draco_wasm_wrapper.js', 'draco_decoder.js']) {
  fs.copyFileSync(path.join(dracoDir, file), path.join(out, 'draco', file));
}
fs.copyFileSync(path.join(modules, 'three/LICENSE'), path.join(out, 'LICENSE-three.txt'));
fs.copyFileSync(path.join(dracoDir, 'README.md'), path.join(out, 'draco', 'README.md'));
console.log(`viewer: ${out}`);
