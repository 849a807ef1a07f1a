// Bundles the viewer (src/viewer.js with three.js and uPlot) into one script with esbuild and
// writes it as a C++ raw string the CLI embeds (cli/view_page.cpp):
//   node build.mjs NODE_MODULES_DIR OUT_DIR   ->  OUT_DIR/viewer.js, OUT_DIR/viewer_bundle.inc
// The output depends only on the sources and the locked packages (reproducible).
import { createRequire } from 'node:module';
import { mkdirSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [modules, outDir] = process.argv.slice(2);
if (!modules || !outDir) throw new Error('usage: node build.mjs NODE_MODULES_DIR OUT_DIR');
const here = path.dirname(fileURLToPath(import.meta.url));
const esbuild = createRequire(path.join(path.resolve(modules), 'x.js'))('esbuild');
const result = await esbuild.build({
  entryPoints: [path.join(here, 'src', 'viewer.js')],
  bundle: true,
  minify: true,
  format: 'iife',
  target: 'es2020',
  nodePaths: [path.resolve(modules)],
  loader: { '.css': 'text' },
  legalComments: 'eof',
  charset: 'ascii',
  write: false,
  logLevel: 'warning',
});
const js = result.outputFiles[0].text;
// The page inlines the script: no closing tag, no end of the raw string inside it.
const delimiter = 'spacearm_js';
if (/<\/script/i.test(js) || /<!--/.test(js)) throw new Error('bundle contains </script or <!--');
if (js.includes(')' + delimiter + '"')) throw new Error('bundle contains the raw-string end');
mkdirSync(outDir, { recursive: true });
writeFileSync(path.join(outDir, 'viewer.js'), js);
// GCC takes long raw strings; the bundle is split into pieces of 60000 characters that the
// compiler concatenates.
const pieces = [];
for (let i = 0; i < js.length; i += 60000)
  pieces.push('R"' + delimiter + '(' + js.slice(i, i + 60000) + ')' + delimiter + '"');
writeFileSync(path.join(outDir, 'viewer_bundle.inc'), pieces.join('\n') + '\n');
console.log('spacearm: viewer bundle ' + js.length + ' bytes');
