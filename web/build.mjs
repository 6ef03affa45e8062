// Builds the viewer into dist/ (or the directory given with --outdir DIR):
// dist/app.js (src/main.js bundled with three.js, minified), dist/index.html and
// dist/style.css (minified). The output is deterministic: the same sources and lockfile
// give the same bytes, so the committed dist/ can be checked against a fresh build.

import { build, transform } from "esbuild";
import { mkdirSync, readFileSync, writeFileSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const i = args.indexOf("--outdir");
const outdir = resolve(i >= 0 && args[i + 1] ? args[i + 1] : join(here, "dist"));
mkdirSync(outdir, { recursive: true });

await build({
  entryPoints: [join(here, "src", "main.js")],
  outfile: join(outdir, "app.js"),
  bundle: true,
  format: "esm",
  platform: "browser",
  target: ["es2020", "chrome90", "firefox90", "safari15"],
  minify: true,
  sourcemap: false,
  legalComments: "eof",
  charset: "utf8",
  logLevel: "warning",
  absWorkingDir: here,
});

const css = await transform(readFileSync(join(here, "src", "style.css"), "utf8"), { loader: "css", minify: true });
writeFileSync(join(outdir, "style.css"), css.code);
writeFileSync(join(outdir, "index.html"), readFileSync(join(here, "src", "index.html")));
console.log(`built ${outdir}`);
