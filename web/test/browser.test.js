// make check-browser: the viewer page in headless Chromium (Debian's, driven by
// playwright-core). It opens Colin27, places the left putamen's protocol
// sphere (a click, then the exact figures the tool computes with
// --sphere-from-label), segments, and compares the label map the page saves
// with the tool's, voxel for voxel; the screenshot after segmenting must show
// the volume and the mesh. Then the page's errors: a file that is no NIfTI,
// a sphere outside the volume.
// Last, the tool's report.html opened from disk.
// Environment: FFSEG_CLI (default build/ffseg), CHROMIUM (default /usr/bin/chromium),
// FFSEG_SCREENSHOT (also save the screenshot there, e.g. docs/viewer.png).
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const path = require("path");
const fs = require("fs");
const os = require("os");
const { execFileSync } = require("child_process");
const { chromium } = require("playwright-core");
const { start } = require("../serve.js");
const { decodePng } = require("./png.js");
const nifti = require("../../bindings/js/nifti.js");

const ROOT = path.join(__dirname, "..", "..");
const MRI = "/usr/share/mricron/templates";
const CLI = process.env.FFSEG_CLI || path.join(ROOT, "build", "ffseg");
const CHROMIUM = process.env.CHROMIUM || "/usr/bin/chromium";
const SEGMENT_TIMEOUT_MS = 180000;

const tmp = fs.mkdtempSync(path.join(os.tmpdir(), "ffseg-browser-"));
let server, context, page, native, report;
const pageErrors = [];

test.before(async () => {
  assert.ok(fs.existsSync(path.join(__dirname, "..", "dist", "viewer.js")), "web/dist is not built (make web-dist)");
  execFileSync(CLI, ["segment", `${MRI}/ch2.nii.gz`, "--sphere-from-label", `${MRI}/aal.nii.gz:73`, "--mesh-resolution", "33",
    "--names", "putamen_L", "--out", path.join(tmp, "cli"), "--force", "--quiet", "--html"], { stdio: "pipe" });
  report = JSON.parse(fs.readFileSync(path.join(tmp, "cli", "report.json"), "utf8"));
  native = nifti.read(await nifti.gunzip(fs.readFileSync(path.join(tmp, "cli", "labels.nii.gz"))));
  server = await start(0);
  context = await chromium.launchPersistentContext(path.join(tmp, "profile"), {
    executablePath: CHROMIUM,
    headless: true,
    acceptDownloads: true,
    viewport: { width: 1100, height: 640 },
    args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
      "--disable-component-update", "--disable-sync", "--use-gl=angle", "--use-angle=swiftshader-webgl", "--enable-unsafe-swiftshader"],
  });
  page = context.pages()[0] || (await context.newPage());
  // A software renderer on a shared 2-core machine: a redraw can hold the
  // page's thread for seconds.
  page.setDefaultTimeout(120000);
  page.on("pageerror", (e) => pageErrors.push(`pageerror: ${e.message}`));
  page.on("console", (m) => { if (m.type() === "error") pageErrors.push(`console: ${m.text()}`); });
  // Nothing may come from anywhere but the local server.
  await page.route("**/*", (route) => {
    const u = new URL(route.request().url());
    if (["blob:", "data:", "file:"].includes(u.protocol) || u.hostname === "127.0.0.1") route.continue();
    else { pageErrors.push(`request outside the page's server: ${u.href}`); route.abort(); }
  });
  await page.goto(`http://127.0.0.1:${server.address().port}/`);
});

test.after(async () => {
  if (context) await context.close();
  if (server) server.close();
  fs.rmSync(tmp, { recursive: true, force: true });
});

async function waitState(s, timeout = 60000) {
  await page.waitForFunction((want) => document.body.dataset.state === want || !document.getElementById("message").hidden,
    s, { timeout });
  const msg = await page.$eval("#message", (el) => (el.hidden ? null : el.textContent));
  assert.strictEqual(msg, null, `the page reports an error: ${msg}`);
  assert.strictEqual(await page.evaluate(() => document.body.dataset.state), s);
}

async function setSphere(row, centre, radius) {
  const inputs = [".c0", ".c1", ".c2", ".r"];
  const values = [...centre, radius];
  for (let a = 0; a < 4; ++a) {
    const sel = `#spheres tbody tr:nth-child(${row + 1}) ${inputs[a]}`;
    await page.fill(sel, String(values[a]));
    await page.dispatchEvent(sel, "change");
  }
}

test("the page opens Colin27, a click places a sphere, Segment grows the putamen: the saved label map is the tool's", async () => {
  await page.setInputFiles("#file", `${MRI}/ch2.nii.gz`);
  await waitState("ready");
  assert.match(await page.textContent("#status"), /181 × 217 × 181/);

  // a click on the canvas places a sphere at the crosshair
  const box = await page.locator("#gl").boundingBox();
  await page.mouse.click(box.x + box.width * 0.25, box.y + box.height * 0.25);
  await page.waitForSelector("#spheres tbody tr");
  assert.strictEqual(await page.locator("#spheres tbody tr").count(), 1);
  const sphere = report.objects[0].sphere;
  await setSphere(0, sphere.center_mm, sphere.radius_mm);
  const placed = await page.evaluate(() => window.ffsegViewer.state.spheres.map((s) => [...s.centre, s.radius]));
  assert.deepStrictEqual(placed, [[...sphere.center_mm, sphere.radius_mm]]);

  await page.click("#segment");
  await waitState("done", SEGMENT_TIMEOUT_MS);
  const run = await page.evaluate(() => window.ffsegViewer.state.lastRun);
  assert.strictEqual(run.steps, report.steps);
  assert.match(await page.textContent("#status"), /converged after \d+ steps/);

  // The screenshot: not blank, and the mesh's colour is on it.
  await page.waitForTimeout(500);
  const png = await page.screenshot();
  if (process.env.FFSEG_SCREENSHOT) fs.writeFileSync(process.env.FFSEG_SCREENSHOT, png);
  const img = decodePng(png);
  const colours = new Set();
  let meshPixels = 0, lit = 0;
  for (let i = 0; i < img.pixels.length; i += img.channels) {
    const r = img.pixels[i], g = img.pixels[i + 1], b = img.pixels[i + 2];
    colours.add((r << 16) | (g << 8) | b);
    if (r > 40 || g > 40 || b > 40) ++lit;
    if (r > 150 && g < 140 && b < 120 && r - g > 60) ++meshPixels;
  }
  const total = img.width * img.height;
  assert.ok(colours.size > 500, `the screenshot has only ${colours.size} colours`);
  assert.ok(lit > 0.2 * total, `only ${lit} of ${total} pixels are lit`);
  assert.ok(meshPixels > 30, `${meshPixels} pixels of the mesh's colour`);

  // Save label map: the download is the tool's labels, voxel for voxel.
  const [download] = await Promise.all([page.waitForEvent("download"), page.click("#save-labels")]);
  const saved = path.join(tmp, "labels.nii");
  await download.saveAs(saved);
  const labels = nifti.read(fs.readFileSync(saved));
  assert.deepStrictEqual(labels.dims, native.dims);
  assert.deepStrictEqual(labels.affine, native.affine);
  let differ = 0, voxels = 0;
  for (let i = 0; i < labels.voxels.length; ++i) {
    if ((labels.voxels[i] !== 0) !== (native.voxels[i] !== 0)) ++differ;
    voxels += labels.voxels[i] !== 0;
  }
  assert.strictEqual(differ, 0, `${differ} voxels differ from the tool's label map`);
  assert.strictEqual(voxels, report.objects[0].voxels);

  // Save mesh: a binary PLY with the engine's vertex count.
  const [plyDownload] = await Promise.all([page.waitForEvent("download"), page.click("#save-mesh")]);
  const plyPath = path.join(tmp, "meshes.ply");
  await plyDownload.saveAs(plyPath);
  const head = fs.readFileSync(plyPath).subarray(0, 400).toString("latin1");
  assert.match(head, new RegExp(`element vertex ${report.objects[0].vertices}\\n`));
  assert.match(head, new RegExp(`element face ${report.objects[0].triangles}\\n`));
  assert.deepStrictEqual(pageErrors, []);
});

test("errors show as a message: a sphere outside the volume, a file that is no NIfTI", async () => {
  await page.evaluate(() => window.ffsegViewer.addSphere([500, 500, 500], 3));
  await page.click("#segment");
  await page.waitForSelector("#message:not([hidden])", { timeout: 30000 });
  assert.match(await page.textContent("#message"), /sphere 2 .*does not meet the volume/);
  assert.strictEqual(await page.evaluate(() => window.ffsegViewer.state.running), false);

  // Two spheres together in empty corners of the scan (all zero) with a binary
  // target: the engine flags the result (today object 1 stalls short of the
  // head) and the page names each flagged object and why.
  await page.evaluate(() => {
    while (window.ffsegViewer.state.spheres.length) window.ffsegViewer.removeSphere(0);
    window.ffsegViewer.addSphere([-80, -115, -60], 3);
    window.ffsegViewer.addSphere([80, 75, 95], 3);
  });
  await page.selectOption("#target", "binary");
  await page.fill("#mesh-n", "12");  // one run (n above 12 makes up to three)
  await page.click("#segment");
  await page.waitForFunction(() => document.body.dataset.state === "done", null, { timeout: SEGMENT_TIMEOUT_MS });
  const flagged = await page.$eval("#message", (el) => (el.hidden ? "" : el.textContent));
  const last = await page.evaluate(() => window.ffsegViewer.state.lastRun);
  assert.strictEqual(last.status, "degenerate");
  assert.strictEqual(last.objectFlags.length, 2);
  const WHY = [[1, /no vertex found a boundary/], [2, /fills most of the volume/], [4, /stalled short of its boundary/]];
  last.objectFlags.forEach((f, k) => {
    const line = (flagged.split("\n").find((l) => l.startsWith(`object ${k + 1}:`))) || "";
    if (f === 0) assert.strictEqual(line, "", `object ${k + 1} is not flagged`);
    for (const [bit, text] of WHY) if (f & bit) assert.match(line, text);
  });
  assert.strictEqual(await page.evaluate(() => window.ffsegViewer.state.meshes.length), 2);
  await page.selectOption("#target", "intensity");
  await page.fill("#mesh-n", "33");

  const bad = path.join(tmp, "not-a-volume.nii");
  fs.writeFileSync(bad, "this is no NIfTI file\n".repeat(40));
  await page.setInputFiles("#file", bad);
  await page.waitForFunction(() => /cannot open the volume/.test(document.getElementById("message").textContent), null, { timeout: 30000 });
  assert.match(await page.textContent("#message"), /not a NIfTI-1 file/);
  // the volume already open stays on screen
  assert.strictEqual(await page.evaluate(() => window.ffsegViewer.nv.volumes.length > 0), true);
  assert.deepStrictEqual(pageErrors, []);
});

test("ffseg segment --html: report.html opens from disk with the volume, the labels, the mesh and the table", async () => {
  const pageErrorsBefore = pageErrors.length;
  await page.goto("file://" + path.join(tmp, "cli", "report.html"));
  await page.waitForFunction(() => document.body.dataset.state, null, { timeout: 120000 });
  assert.strictEqual(await page.evaluate(() => document.body.dataset.state), "shown");
  assert.strictEqual(await page.locator("#message").count(), 0);
  const shown = await page.evaluate(() => ({ volumes: window.ffsegReport.nv.volumes.map((v) => v.name),
    meshes: window.ffsegReport.nv.meshes.map((m) => m.pts.length / 3) }));
  assert.deepStrictEqual(shown, { volumes: ["ch2.nii.gz", "labels.nii.gz"], meshes: [report.objects[0].vertices] });
  const row = await page.locator("table tr").nth(1).textContent();
  assert.match(row, new RegExp(`putamen_L.*73.*${report.objects[0].voxels}`));
  assert.deepStrictEqual(pageErrors.slice(pageErrorsBefore), []);
});

test("ffseg segment --html without the viewer script: a usage error that says how to get it, no output", () => {
  const out = path.join(tmp, "no-viewer");
  let failure = null;
  try {
    execFileSync(CLI, ["segment", `${MRI}/ch2.nii.gz`, "--sphere", "-20,14,-4,3", "--out", out, "--html"],
      { stdio: "pipe", env: { ...process.env, FFSEG_VIEWER_JS: path.join(tmp, "missing.js") } });
  } catch (ex) {
    failure = ex;
  }
  assert.ok(failure, "the tool accepted --html without a viewer script");
  assert.strictEqual(failure.status, 2);
  assert.match(failure.stderr.toString(), /report-viewer\.js.*make web-dist/s);
  assert.strictEqual(fs.existsSync(out), false);
});
