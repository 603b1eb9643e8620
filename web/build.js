// Lays out web/dist/: the viewer bundled with NiiVue (esbuild, one IIFE file:
// the page loads it with a plain <script>, from a server or from disk), the
// worker, and the wasm build with its binding. Usage: node build.js [build-wasm dir]
"use strict";
const path = require("path");
const fs = require("fs");
const esbuild = require("esbuild");

const here = __dirname;
const root = path.join(here, "..");
const wasmDir = path.resolve(process.argv[2] || path.join(root, "build-wasm"));
const dist = path.join(here, "dist");

for (const f of ["ffseg.js", "ffseg.wasm"])
  if (!fs.existsSync(path.join(wasmDir, f))) {
    console.error(`web/build.js: ${path.join(wasmDir, f)} is missing; run \`make wasm\` first`);
    process.exit(1);
  }
fs.mkdirSync(dist, { recursive: true });
const copies = [
  [path.join(wasmDir, "ffseg.js"), "ffseg.js"],
  [path.join(wasmDir, "ffseg.wasm"), "ffseg.wasm"],
  [path.join(root, "bindings", "js", "ffseg.js"), "ffseg-binding.js"],
  [path.join(root, "bindings", "js", "nifti.js"), "nifti.js"],
  [path.join(here, "src", "worker.js"), "worker.js"],
];
for (const [from, to] of copies) fs.copyFileSync(from, path.join(dist, to));

esbuild.buildSync({
  entryPoints: [path.join(here, "src", "main.js")],
  bundle: true,
  format: "iife",
  target: "es2020",
  minify: true,
  sourcemap: false,
  legalComments: "none",
  outfile: path.join(dist, "viewer.js"),
  logLevel: "warning",
});
if (fs.existsSync(path.join(here, "src", "report.js")))
  esbuild.buildSync({
    entryPoints: [path.join(here, "src", "report.js")],
    bundle: true,
    format: "iife",
    target: "es2020",
    minify: true,
    legalComments: "none",
    outfile: path.join(dist, "report-viewer.js"),
    logLevel: "warning",
  });
console.log(`web/dist: ${fs.readdirSync(dist).join(", ")}`);
