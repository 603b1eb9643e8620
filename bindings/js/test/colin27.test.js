// The wasm build against the native tool on Colin27: the left putamen (AAL 73)
// from its protocol sphere (--sphere-from-label), grey levels, n = 33, must give
// the same mask voxel for voxel, by the same runs (the binding's segment()
// makes them as the tool does: n = 12 first, then n = 33 from its mesh,
// coarse to fine). The tool is FFSEG_CLI (default build/ffseg).
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const os = require("os");
const { execFileSync } = require("child_process");
const { ROOT, count, load, readNifti, labelMapDiffers, runsText, fs, path } = require("./helpers.js");

const MRI = "/usr/share/mricron/templates";
const CLI = process.env.FFSEG_CLI || path.join(ROOT, "build", "ffseg");
const N = 33;

test("the left putamen: the wasm build's mask is the native tool's, voxel for voxel", async (t) => {
  assert.ok(fs.existsSync(CLI), `${CLI} is missing (make build, or set FFSEG_CLI)`);
  const out = fs.mkdtempSync(path.join(os.tmpdir(), "ffseg-js-colin27-"));
  t.after(() => fs.rmSync(out, { recursive: true, force: true }));
  execFileSync(CLI, ["segment", `${MRI}/ch2.nii.gz`, "--sphere-from-label", `${MRI}/aal.nii.gz:73`,
    "--mesh-resolution", String(N), "--names", "putamen_L", "--out", out, "--force", "--quiet"], { stdio: "pipe" });
  const report = JSON.parse(fs.readFileSync(path.join(out, "report.json"), "utf8"));
  const obj = report.objects[0];
  const native = await readNifti(path.join(out, "labels.nii.gz"));

  const img = await readNifti(`${MRI}/ch2.nii.gz`);
  // the reader picks the tool's affine
  assert.strictEqual(img.which, report.input.affine_source);
  assert.deepStrictEqual(img.affine, report.input.index_to_world.flat());
  const lib = await load();
  const run = await lib.segment(img, [{ centre: obj.sphere.center_mm, radius: obj.sphere.radius_mm }], { meshResolution: N });
  const mask = run.masks[0];
  t.diagnostic(`runs: ${runsText(run)}`);

  assert.strictEqual(run.runs.length, report.passes, "the tool's runs");
  assert.ok(report.config.refined_from_first_run && run.runs[1].from === "first run", "n = 33 from the first run's mesh");
  assert.strictEqual(run.steps, report.steps, "steps to rest");
  assert.strictEqual(run.meshes[0].vertices.length / 3, obj.vertices);
  let differ = 0, first = -1;
  for (let i = 0; i < mask.length; ++i)
    if ((mask[i] !== 0) !== (native.voxels[i] !== 0)) { ++differ; if (first < 0) first = i; }
  assert.strictEqual(differ, 0, `${differ} voxels differ (first at index ${first})`);
  assert.strictEqual(count(mask), obj.voxels);
  // The masks agree; the last bits of the displacement figures need not (the
  // report says by how much: wasm's libm and the x86 build's kernels).
  const a = run.last.meanDisplacementMm[0], b = obj.final_mean_displacement_mm;
  const rel = Math.abs(a - b) / Math.abs(b);
  t.diagnostic(`final mean displacement: wasm ${a}, native ${b}, relative difference ${rel.toExponential(2)}`);
  assert.ok(rel < 1e-9, `final mean displacement wasm ${a} vs native ${b}`);
});

// Several objects coarse to fine: Colin27's eight deep nuclei (AAL 71-78) at
// n = 33 start from their n = 12 meshes, the larger organs placed first; the
// binding must place them as the tool does, in a new engine.
test("the eight deep nuclei at n = 33: the wasm build's label map is the native tool's, voxel for voxel", async (t) => {
  assert.ok(fs.existsSync(CLI), `${CLI} is missing (make build, or set FFSEG_CLI)`);
  const out = fs.mkdtempSync(path.join(os.tmpdir(), "ffseg-js-nuclei-"));
  t.after(() => fs.rmSync(out, { recursive: true, force: true }));
  const labels = [71, 72, 73, 74, 75, 76, 77, 78];
  const args = ["segment", `${MRI}/ch2.nii.gz`, "--mesh-resolution", String(N), "--out", out, "--force", "--quiet"];
  for (const l of labels) args.push("--sphere-from-label", `${MRI}/aal.nii.gz:${l}`);
  execFileSync(CLI, args, { stdio: "pipe" });
  const report = JSON.parse(fs.readFileSync(path.join(out, "report.json"), "utf8"));
  assert.ok(report.config.refined_from_first_run, "the finer run starts from the first run's meshes");
  const starts = report.objects.map((o) => o.started_from);
  assert.ok(starts.includes("first run"), `starts: ${starts}`);
  const native = await readNifti(path.join(out, "labels.nii.gz"));

  const img = await readNifti(`${MRI}/ch2.nii.gz`);
  const lib = await load();
  const spheres = report.objects.map((o) => ({ centre: o.sphere.center_mm, radius: o.sphere.radius_mm }));
  const run = await lib.segment(img, spheres, { meshResolution: N });
  t.diagnostic(`runs: ${runsText(run)}`);
  assert.strictEqual(run.runs.length, report.passes);
  assert.strictEqual(run.steps, report.steps, "steps to rest");
  // labels.nii.gz: object k as its AAL label, a voxel inside two meshes as the first's.
  const differ = labelMapDiffers(native.voxels, run.masks, labels);
  assert.strictEqual(differ, 0, `${differ} voxels differ`);
});
