// The JavaScript binding over the wasm build: typed arrays in and out, the
// engine's errors as FfsegError with its message, the step report as an object.
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const { ROOT, ballPhantom, count, load, fs, path } = require("./helpers.js");
const { FfsegError } = require("../ffseg.js");

let lib;
test.before(async () => { lib = await load(); });

function binaryEngine(opts = {}) {
  const e = new lib.Engine({ maxObjects: 1, meshResolution: 12, ...opts });
  e.setParams({ targetMode: "binary" });
  return e;
}

test("the library reports the header's version", () => {
  const h = fs.readFileSync(path.join(ROOT, "include", "ffseg.h"), "utf8");
  const v = ["MAJOR", "MINOR", "PATCH"].map((w) => Number(h.match(new RegExp(`#define FFSEG_VERSION_${w} (\\d+)`))[1]));
  assert.deepStrictEqual(lib.version(), v);
  assert.match(lib.statusString(-11), /sphere/i);
});

test("a ball phantom: the mesh grows to the ball, the mask is a typed array over the grid", () => {
  const ph = ballPhantom();
  const e = binaryEngine();
  try {
    e.setVolume(ph.voxels, ph.dims, ph.affine);
    e.initSphere(0, ph.centre, 3);
    let r, steps = 0;
    do { r = e.step(); ++steps; } while (!r.atRest && steps < 200);
    assert.ok(r.atRest, "at rest within 200 steps");
    assert.strictEqual(r.status, "converged");
    assert.strictEqual(r.stepIndex, steps);
    assert.strictEqual(r.meanDisplacementMm.length, 1);
    assert.ok(r.meanDisplacementMm[0] < 0.05);
    assert.deepStrictEqual(Object.keys(r.stageUs), ["search", "flips", "diffusion", "intersection", "assembly",
      "factor", "solve", "features", "guard", "regions"]);
    assert.strictEqual(r.flagsAll, 0);
    const mask = e.rasterize(0);
    assert.ok(mask instanceof Uint8Array);
    assert.strictEqual(mask.length, ph.voxels.length);
    const n = count(mask);
    assert.ok(Math.abs(n - ph.inside) < 0.1 * ph.inside, `mask ${n} voxels, ball ${ph.inside}`);
    // every masked voxel lies within a voxel of the ball
    const [nx, ny] = ph.dims;
    for (let i = 0; i < mask.length; ++i) {
      if (!mask[i]) continue;
      const x = i % nx, y = Math.floor(i / nx) % ny, z = Math.floor(i / (nx * ny)) * 1.5;
      assert.ok(Math.hypot(x - ph.centre[0], y - ph.centre[1], z - ph.centre[2]) < 8 + 1.5, `voxel ${i} is outside the ball`);
    }
    const { vertices, triangles } = e.extractMesh(0);
    assert.ok(vertices instanceof Float32Array && triangles instanceof Uint32Array);
    assert.strictEqual(vertices.length % 3, 0);
    assert.strictEqual(triangles.length % 3, 0);
    const nv = vertices.length / 3;
    assert.ok(triangles.every((t) => t < nv));
    // a closed triangle mesh of genus 0: V - E + F = 2 with E = 3F/2
    assert.strictEqual(nv - (3 * triangles.length / 3) / 2 + triangles.length / 3, 2);
    // out= fills the caller's array
    const out = new Uint8Array(mask.length);
    assert.strictEqual(e.rasterize(0, out), out);
    assert.deepStrictEqual(out, mask);
  } finally {
    e.close();
  }
});

test("errors are FfsegError with the engine's status, code and message", () => {
  assert.throws(() => new lib.Engine({ maxObjects: 0 }),
    (ex) => ex instanceof FfsegError && ex.code === "INVALID_ARGUMENT" && /max_objects/.test(ex.message));
  const ph = ballPhantom();
  const e = binaryEngine();
  try {
    assert.throws(() => e.step(), (ex) => ex.code === "MISUSE" && ex.status === -8 && ex.call === "ffseg_step");
    assert.throws(() => e.setVolume(ph.voxels.subarray(1), ph.dims, ph.affine), (ex) => ex.code === "INVALID_VOLUME");
    assert.throws(() => e.setVolume(new Int8Array(10), [10, 1, 1], ph.affine), (ex) => ex.code === "INVALID_VOLUME" && /Int8Array/.test(ex.message));
    const singular = ph.affine.slice(); singular[0] = 0;
    assert.throws(() => e.setVolume(ph.voxels, ph.dims, singular),
      (ex) => ex.code === "INVALID_VOLUME" && ex.call === "ffseg_set_volume" && ex.engineMessage.length > 0);
    e.setVolume(ph.voxels, ph.dims, ph.affine);
    assert.throws(() => e.initSphere(0, [500, 500, 500], 2), (ex) => ex.code === "SPHERE_OUTSIDE");
    assert.throws(() => e.initSphere(3, ph.centre, 2), (ex) => ex.code === "OBJECT_OUT_OF_RANGE");
    assert.throws(() => e.initSphere(0, [1, 2], 2), (ex) => ex.code === "INVALID_ARGUMENT");
    assert.throws(() => e.extractMesh(0), (ex) => ex.code === "MISUSE");
    // a refused parameter changes nothing, and the message names the field
    const before = e.params;
    assert.throws(() => e.setParams({ stepSize: 2, lambdaUniform: 3 }), (ex) => ex.code === "INVALID_ARGUMENT" && /step_size/.test(ex.message));
    assert.deepStrictEqual(e.params, before);
    assert.throws(() => e.setParams({ noSuchThing: 1 }), /unknown parameter 'noSuchThing'/);
    assert.throws(() => e.setParams({ targetMode: "colour" }), /binary.*intensity/);
    e.setParams({ stepSize: 0.25 });
    assert.strictEqual(e.params.stepSize, 0.25);
  } finally {
    e.close();
  }
  assert.throws(() => e.step(), (ex) => ex.code === "MISUSE" && /closed/.test(ex.message));
});

test("two objects segment together and own disjoint bounding regions", () => {
  const nx = 48, ny = 24, nz = 24;
  const voxels = new Uint8Array(nx * ny * nz);
  for (let k = 0; k < nz; ++k) for (let j = 0; j < ny; ++j) for (let i = 0; i < nx; ++i) {
    const a = (i - 13) ** 2 + (j - 12) ** 2 + (k - 12) ** 2 < 49, b = (i - 35) ** 2 + (j - 12) ** 2 + (k - 12) ** 2 < 49;
    if (a || b) voxels[i + nx * (j + ny * k)] = 1;
  }
  const e = new lib.Engine({ maxObjects: 2, meshResolution: 10, targetMode: "binary" });
  try {
    e.setParams({ targetMode: "binary" });
    e.setVolume(voxels, [nx, ny, nz], [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    e.initSphere(0, [13, 12, 12], 3);
    e.initSphere(1, [35, 12, 12], 3);
    let r;
    for (let s = 0; s < 200 && !(r = e.step()).atRest; ++s);
    assert.ok(r.atRest);
    assert.strictEqual(r.meanDisplacementMm.length, 2);
    const m0 = e.rasterize(0), m1 = e.rasterize(1), g0 = e.regionMask(0), g1 = e.regionMask(1);
    assert.ok(count(m0) > 800 && count(m1) > 800, `${count(m0)} and ${count(m1)} voxels`);
    for (let i = 0; i < g0.length; ++i) assert.ok(!(g0[i] && g1[i]), "regions overlap");
  } finally {
    e.close();
  }
});

// ffseg_config.max_region_voxels (0.6.0): the library reads it (a smaller
// workspace, a refusal naming it), and two objects in a bar of ones get
// disjoint regions on voxels and on cells of 3 voxels when 256 cannot hold a
// region's box (the Rust and C# bindings' test).
test("maxRegionVoxels sizes the bounding regions: smaller workspace, regions on cells", () => {
  const fine = new lib.Engine({ maxObjects: 2, meshResolution: 6, maxRoiVoxels: 1 << 16, targetMode: "binary" });
  const coarse = new lib.Engine({ maxObjects: 2, meshResolution: 6, maxRoiVoxels: 1 << 16, maxRegionVoxels: 256, targetMode: "binary" });
  try {
    assert.strictEqual(fine.config.maxRegionVoxels, 0);
    assert.strictEqual(coarse.config.maxRegionVoxels, 256);
    assert.ok(coarse.workspaceBytes < fine.workspaceBytes, `${coarse.workspaceBytes} >= ${fine.workspaceBytes} bytes`);
  } finally {
    fine.close();
    coarse.close();
  }
  for (const bad of [-1, 2 ** 40 + 1])
    assert.throws(() => new lib.Engine({ maxObjects: 2, maxRegionVoxels: bad }),
      (ex) => ex.code === "INVALID_ARGUMENT" && /max_region_voxels/.test(ex.message));
  assert.throws(() => new lib.Engine({ maxRegionVoxels: 1.5 }), (ex) => ex.code === "INVALID_ARGUMENT" && /maxRegionVoxels/.test(ex.message));

  const dims = [40, 12, 12];
  const bar = new Uint8Array(dims[0] * dims[1] * dims[2]);
  for (let k = 3; k < 9; ++k) for (let j = 3; j < 9; ++j) for (let i = 4; i < 36; ++i) bar[i + dims[0] * (j + dims[1] * k)] = 1;
  for (const maxRegionVoxels of [0, 256]) {
    const e = new lib.Engine({ maxObjects: 2, meshResolution: 6, maxRegionVoxels });
    try {
      e.setParams({ targetMode: "binary" });
      e.setVolume(bar, dims, [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
      e.initSphere(0, [10, 5.5, 5.5], 2);
      e.initSphere(1, [29, 5.5, 5.5], 2);
      assert.throws(() => e.regionMask(0), (ex) => ex.code === "MISUSE");
      for (let s = 0; s < 3; ++s) e.step();
      const g0 = e.regionMask(0), g1 = e.regionMask(1);
      assert.ok(count(g0) > 100 && count(g1) > 100, `maxRegionVoxels ${maxRegionVoxels}: regions of ${count(g0)} and ${count(g1)} voxels`);
      for (let i = 0; i < g0.length; ++i) assert.ok(!(g0[i] && g1[i]), `maxRegionVoxels ${maxRegionVoxels}: regions overlap`);
    } finally {
      e.close();
    }
  }
});

test("coarse to fine: a mesh from an engine at n = 8 placed with initMesh into one at n = 16 goes on from there", () => {
  const ph = ballPhantom();
  const coarse = binaryEngine({ meshResolution: 8 });
  let source;
  try {
    coarse.setVolume(ph.voxels, ph.dims, ph.affine);
    coarse.initSphere(0, ph.centre, 3);
    for (let s = 0; s < 200 && !coarse.step().atRest; ++s);
    source = coarse.extractMesh(0).vertices;
  } finally {
    coarse.close();
  }
  assert.strictEqual(source.length, 6 * 8 * 8 * 3);
  const fine = binaryEngine({ meshResolution: 16 });
  try {
    fine.setVolume(ph.voxels, ph.dims, ph.affine);
    fine.initSphere(0, ph.centre, 3);
    let fromSphere = 0;
    while (!fine.step().atRest && fromSphere < 200) ++fromSphere;
    assert.throws(() => fine.initMesh(0, ph.centre, 3, source.subarray(3)), (ex) => ex.code === "INVALID_ARGUMENT" && ex.call === "ffseg_init_mesh");
    fine.initMesh(0, ph.centre, 3, source);
    assert.strictEqual(fine.extractMesh(0).vertices.length, 6 * 16 * 16 * 3);
    let r, steps = 0;
    do { r = fine.step(); ++steps; } while (!r.atRest && steps < 200);
    assert.strictEqual(r.status, "converged");
    assert.ok(steps < fromSphere, `${steps} steps from the coarse mesh, ${fromSphere + 1} from the sphere`);
    assert.deepStrictEqual([r.guardHeld.length, r.farOutward.length, r.farInward.length], [1, 1, 1]);
    const n = count(fine.rasterize(0));
    assert.ok(Math.abs(n - ph.inside) < 0.08 * ph.inside, `mask ${n} voxels, ball ${ph.inside}`);
  } finally {
    fine.close();
  }
});
