// The core's promise in the browser build: nothing is allocated inside the
// engine's calls. ffseg_nomalloc.wasm is the same core objects as ffseg.wasm,
// linked with nomalloc_trap.cpp, which counts every malloc-family call (and so
// every operator new) while armed.
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const { ballPhantom, load } = require("./helpers.js");

let lib, C, mod;
test.before(async () => {
  lib = await load("ffseg_nomalloc");
  mod = lib.module;
  C = lib.calls;
});

test("the trap counts an allocation (so the tests below can fail)", () => {
  mod._ffseg_trap_arm(1);
  const calls = mod._ffseg_trap_probe();
  mod._ffseg_trap_arm(0);
  assert.strictEqual(calls, 2);
});

test("the C calls create, set_params, set_volume, init_sphere, step, extract_mesh, init_mesh, rasterize, region_mask and destroy allocate nothing", () => {
  // Everything the caller provides is allocated before the trap is armed:
  // the workspace, the volume, the structs and the output buffers.
  const ph = ballPhantom();
  const L = require("../ffseg.js").LAYOUTS;
  const blocks = [];
  const alloc = (n) => { const p = mod._malloc(n + 64); blocks.push(p); return p + ((64 - (p % 64)) % 64); };
  const cfg = alloc(L.ffseg_config.size), params = alloc(L.ffseg_params.size);
  const vol = alloc(L.ffseg_volume.size), info = alloc(L.ffseg_step_info.size), small = alloc(64);
  C.ffseg_config_init_default(cfg);
  new DataView(mod.HEAPU8.buffer).setUint32(cfg + 4, 2, true);    // max_objects
  new DataView(mod.HEAPU8.buffer).setUint32(cfg + 8, 12, true);   // mesh_resolution
  assert.strictEqual(C.ffseg_workspace_size(cfg, small), 0);
  const bytes = new DataView(mod.HEAPU8.buffer).getUint32(small, true);
  const ws = alloc(bytes), data = alloc(ph.voxels.byteLength), mask = alloc(ph.voxels.length);
  const xyz = alloc(6 * 13 * 13 * 12), tris = alloc(12 * 13 * 13 * 12);
  mod.HEAPU8.set(new Uint8Array(ph.voxels.buffer), data);
  const dv = () => new DataView(mod.HEAPU8.buffer);
  const v = L.ffseg_volume.fields;
  dv().setUint32(vol, L.ffseg_volume.size, true);
  dv().setUint32(vol + v.voxel_type.offset, 5, true);
  dv().setUint32(vol + v.data.offset, data, true);
  dv().setBigInt64(vol + v.data_bytes.offset, BigInt(ph.voxels.byteLength), true);
  ph.dims.forEach((d, a) => {
    dv().setBigInt64(vol + v.dims.offset + 8 * a, BigInt(d), true);
    dv().setBigInt64(vol + v.strides.offset + 8 * a, BigInt(4 * [1, ph.dims[0], ph.dims[0] * ph.dims[1]][a]), true);
  });
  ph.affine.forEach((x, i) => dv().setFloat64(vol + v.index_to_world.offset + 8 * i, x, true));
  dv().setFloat64(vol + v.rescale_slope.offset, 1, true);
  C.ffseg_params_init_default(params);
  dv().setUint32(info, L.ffseg_step_info.size, true);
  const centres = [[ph.centre[0] - 3, ph.centre[1], ph.centre[2]], [ph.centre[0] + 3, ph.centre[1], ph.centre[2]]];

  const statuses = [];
  mod._ffseg_trap_arm(1);
  statuses.push(C.ffseg_create(cfg, ws, bytes, small));
  const e = dv().getUint32(small, true);
  statuses.push(C.ffseg_set_params(e, params));
  statuses.push(C.ffseg_set_volume(e, vol));
  centres.forEach((c, k) => {
    new Float64Array(mod.HEAPU8.buffer, small + 8, 3).set(c);
    statuses.push(C.ffseg_init_sphere(e, k, small + 8, 2));
  });
  let st = 0, steps = 0;
  while ((st = C.ffseg_step(e, info)) === 0 && steps < 100) ++steps;
  statuses.push(st < 0 ? st : 0);
  for (let k = 0; k < 2; ++k) {
    statuses.push(C.ffseg_extract_mesh(e, k, xyz, 6 * 13 * 13, tris, 12 * 13 * 13, small + 32, small + 36));
    statuses.push(C.ffseg_rasterize(e, k, mask, 0));
    statuses.push(C.ffseg_region_mask(e, k, mask, 0));
  }
  // object 1 placed again from its own mesh (the last extracted)
  new Float64Array(mod.HEAPU8.buffer, small + 8, 3).set(centres[1]);
  statuses.push(C.ffseg_init_mesh(e, 1, small + 8, 2, xyz, dv().getUint32(small + 32, true)));
  statuses.push(C.ffseg_step(e, info) < 0 ? -1 : 0);
  C.ffseg_destroy(e);
  mod._ffseg_trap_arm(0);
  const calls = mod._ffseg_trap_calls();
  for (const p of blocks) mod._free(p);
  assert.deepStrictEqual(statuses, statuses.map(() => 0), `every call succeeded: ${statuses}`);
  assert.ok(steps >= 2, `stepped ${steps} times`);
  assert.strictEqual(calls, 0, `${calls} allocation(s) inside the engine's calls`);
});

test("the binding's step, extractMesh and rasterize allocate nothing in the module's memory", () => {
  const ph = ballPhantom();
  const e = new lib.Engine({ maxObjects: 1, meshResolution: 12, targetMode: "binary" });
  try {
    e.setParams({ targetMode: "binary" });
    e.setVolume(ph.voxels, ph.dims, ph.affine);
    e.initSphere(0, ph.centre, 3);
    mod._ffseg_trap_arm(1);
    let r;
    for (let s = 0; s < 100 && !(r = e.step()).atRest; ++s) e.extractMesh(0);
    e.rasterize(0);
    mod._ffseg_trap_arm(0);
    assert.ok(r.atRest);
    assert.strictEqual(mod._ffseg_trap_calls(), 0);
  } finally {
    mod._ffseg_trap_arm(0);
    e.close();
  }
});
