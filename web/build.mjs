// Bundles the studio front end: web/src/main.js (+ its CSS) → OUTDIR/app.js and OUTDIR/app.css.
// Run by the CMake build (node web/build.mjs OUTDIR); uses only the installed esbuild package.
import * as esbuild from 'esbuild';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const outdir = process.argv[2];
if (!outdir) {
  console.error('usage: node web/build.mjs OUTDIR');
  process.exit(2);
}
await esbuild.build({
  entryPoints: { app: path.join(here, 'src', 'main.js') },
  bundle: true,
  minify: true,
  format: 'esm',
  target: 'es2020',
  outdir,
  logLevel: 'warning',
  legalComments: 'none',
});
