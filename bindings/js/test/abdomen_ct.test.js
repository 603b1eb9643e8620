// The wasm build against the native tool on the shared abdominal CT
// (../shared/data/abdomen_ct, 3 mm): the nine organs at n = 22, where the
// vena cava's first-run mesh, resampled from n = 12, crosses the
// gallbladder's by a fraction of a voxel and both the tool and the binding's
// segment() place it scaled by 0.99 about its centroid (report.json:
// first_run_scale). The label maps must agree voxel for voxel, so the
// binding's scaling is the tool's to the bit. The tool is FFSEG_CLI.
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const os = require("os");
const { execFileSync } = require("child_process");
const { ROOT, load, readNifti, labelMapDiffers, runsText, fs, path } = require("./helpers.js");

const DATA = process.env.FFSEG_ABDOMEN_CT || path.join(ROOT, "..", "shared", "data", "abdomen_ct");
const CLI = process.env.FFSEG_CLI || path.join(ROOT, "build", "ffseg");
const N = 22;

test("nine organs at n = 22 through the scaled placement: the wasm build's label map is the native tool's",
  { skip: fs.existsSync(DATA) ? false : `${DATA} is absent: the shared data beside the repository` }, async (t) => {
    assert.ok(fs.existsSync(CLI), `${CLI} is missing (make build, or set FFSEG_CLI)`);
    const out = fs.mkdtempSync(path.join(os.tmpdir(), "ffseg-js-abdomen-"));
    t.after(() => fs.rmSync(out, { recursive: true, force: true }));
    const ids = [5, 1, 3, 4, 7, 2, 6, 8, 10];
    const args = ["segment", path.join(DATA, "ct.nii.gz"), "--mesh-resolution", String(N), "--out", out, "--force", "--quiet"];
    for (const id of ids) args.push("--sphere-from-label", `${path.join(DATA, "labels.nii.gz")}:${id}`);
    try {
      execFileSync(CLI, args, { stdio: "pipe" });
    } catch (ex) {
      assert.strictEqual(ex.status, 6, `the tool failed: ${ex.stderr}`);  // exit 6: an organ stalled, outputs written
    }
    const report = JSON.parse(fs.readFileSync(path.join(out, "report.json"), "utf8"));
    const scales = report.objects.map((o) => o.first_run_scale);
    assert.ok(report.objects.every((o) => o.started_from === "first run"), "every organ from its first-run mesh");
    assert.ok(scales.some((s) => s !== undefined && s < 1), `first_run_scale: ${scales}`);
    const native = await readNifti(path.join(out, "labels.nii.gz"));

    const img = await readNifti(path.join(DATA, "ct.nii.gz"));
    const lib = await load();
    const spheres = report.objects.map((o) => ({ centre: o.sphere.center_mm, radius: o.sphere.radius_mm }));
    const run = await lib.segment(img, spheres, { meshResolution: N });
    t.diagnostic(`runs: ${runsText(run)}`);
    assert.strictEqual(run.runs.length, report.passes);
    assert.strictEqual(run.steps, report.steps, "steps to rest");
    // labels.nii.gz: object k as its label, a voxel inside two meshes as the first's.
    const differ = labelMapDiffers(native.voxels, run.masks, ids);
    assert.strictEqual(differ, 0, `${differ} voxels differ`);
  });
