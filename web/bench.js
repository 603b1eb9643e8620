// Step time of the WebAssembly build against the native tool on the same
// machine (BENCHMARKS.md): the left putamen (grey levels, its protocol sphere,
// n = 33) and the brain mask (ch2bet, binary, sphere 0,-17,19,80, n = 49).
// Each case: the native tool (report.json's stepping time / steps: its last
// run, as the tool makes them), the wasm build under Node (the binding's
// segment(), the same runs; SIMD, and scalar when a second build folder is
// given) and in headless Chromium (web/bench.html: the page's worker, no drawing).
// Usage: node web/bench.js [build/ffseg] [build-wasm-scalar]   (after make web-dist)
"use strict";
const path = require("path");
const fs = require("fs");
const os = require("os");
const { execFileSync } = require("child_process");
const { chromium } = require("playwright-core");
const ffseg = require("../bindings/js/ffseg.js");
const nifti = require("../bindings/js/nifti.js");
const { start } = require("./serve.js");

const ROOT = path.join(__dirname, "..");
const MRI = "/usr/share/mricron/templates";
const CLI = path.resolve(process.argv[2] || path.join(ROOT, "build", "ffseg"));
const SCALAR = process.argv[3] ? path.resolve(process.argv[3]) : null;
const REPEAT = 3;  // the best of three runs: the machine is shared

const CASES = [
  { name: "putamen L", volume: "ch2.nii.gz", target: "intensity", n: 33, args: ["--sphere-from-label", `${MRI}/aal.nii.gz:73`] },
  { name: "brain mask", volume: "ch2bet.nii.gz", target: "binary", n: 49, args: ["--sphere", "0,-17,19,80"] },
];

const perStep = (ms) => ms.reduce((a, b) => a + b, 0) / ms.length;

async function main() {
  let chromiumVersion = "";
  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), "ffseg-bench-"));
  const rows = [];
  const server = await start(0);
  const browser = await chromium.launch({ executablePath: "/usr/bin/chromium", headless: true,
    args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync"] });
  chromiumVersion = browser.version();
  try {
    for (const c of CASES) {
      const vol = `${MRI}/${c.volume}`;
      let native = Infinity, report;
      for (let r = 0; r < REPEAT; ++r) {
        const out = path.join(tmp, `native-${r}`);
        execFileSync(CLI, ["segment", vol, ...c.args, "--target", c.target, "--mesh-resolution", String(c.n), "--out", out, "--force", "--quiet"]);
        report = JSON.parse(fs.readFileSync(path.join(out, "report.json"), "utf8"));
        native = Math.min(native, report.time_ms.stepping / report.steps);
      }
      const sphere = { centre: report.objects[0].sphere.center_mm, radius: report.objects[0].sphere.radius_mm };
      const img = nifti.read(await nifti.gunzip(fs.readFileSync(vol)));
      const wasm = {};
      for (const [label, dir] of [["simd", path.join(ROOT, "build-wasm")], ["scalar", SCALAR]]) {
        if (!dir) continue;
        const lib = await ffseg.load({ dir });
        let best = Infinity, run;
        for (let r = 0; r < REPEAT; ++r) {
          run = await lib.segment(img, [sphere], { meshResolution: c.n, targetMode: c.target });
          best = Math.min(best, perStep(run.stepMs));
        }
        wasm[label] = { ms: best, steps: run.steps, voxels: run.masks[0].reduce((a, v) => a + (v !== 0), 0) };
      }
      let browserMs = Infinity, browserRun;
      for (let r = 0; r < REPEAT; ++r) {
        const page = await browser.newPage();
        const s = [...sphere.centre, sphere.radius].join(",");
        await page.goto(`http://127.0.0.1:${server.address().port}/bench.html?target=${c.target}&n=${c.n}&sphere=${s}`);
        await page.setInputFiles("#file", vol);
        await page.waitForFunction(() => window.benchResult, null, { timeout: 300000 });
        browserRun = await page.evaluate(() => window.benchResult);
        await page.close();
        if (browserRun.error) throw new Error(`${c.name} in the browser: ${browserRun.error}`);
        browserMs = Math.min(browserMs, perStep(browserRun.stepMs));
      }
      rows.push({ c, report, native, wasm, browserMs, browserRun });
    }
  } finally {
    await browser.close();
    server.close();
    fs.rmSync(tmp, { recursive: true, force: true });
  }
  console.log(`| case | n | steps (native / wasm) | voxels (native / wasm) | native ms/step | wasm SIMD, Node ms/step | ${SCALAR ? "wasm scalar, Node ms/step | " : ""}wasm SIMD, Chromium worker ms/step | Chromium / native |`);
  console.log(`|---|---|---|---|---|---|${SCALAR ? "---|" : ""}---|---|`);
  for (const { c, report, native, wasm, browserMs, browserRun } of rows) {
    const o = report.objects[0];
    console.log(`| ${c.name} (${c.target}) | ${c.n} | ${report.steps} / ${wasm.simd.steps} | ${o.voxels} / ${wasm.simd.voxels} | ${native.toFixed(1)} | ${wasm.simd.ms.toFixed(1)} | ` +
      `${SCALAR ? wasm.scalar.ms.toFixed(1) + " | " : ""}${browserMs.toFixed(1)} | ${(browserMs / native).toFixed(2)}x |`);
    if (browserRun.steps !== report.steps || browserRun.labels !== o.voxels)
      console.log(`(the browser run took ${browserRun.steps} steps and labelled ${browserRun.labels} voxels)`);
  }
  console.log(`\n${os.cpus()[0].model}, ${os.cpus().length} cores; best of ${REPEAT} runs each; Node ${process.version}; Chromium ${chromiumVersion}`);
}

main().catch((e) => { console.error(e); process.exit(1); });
