// The NIfTI-1 reader and label-map writer the page and the tests use.
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const zlib = require("zlib");
const nifti = require("../nifti.js");

// A small NIfTI-1 file: dims, datatype, geometry codes and values chosen by the test.
function makeNifti({ dims = [3, 4, 5], datatype = 4, bitpix = 16, le = true, sform = null, qform = null, pixdim = [1, 2, 3],
  slope = 0, inter = 0, values = null } = {}) {
  const n = dims[0] * dims[1] * dims[2], bpv = bitpix / 8;
  const buf = new Uint8Array(352 + n * bpv);
  const dv = new DataView(buf.buffer);
  dv.setInt32(0, 348, le);
  dv.setInt16(40, 3, le);
  dims.forEach((d, i) => dv.setInt16(42 + 2 * i, d, le));
  for (let i = 3; i < 7; ++i) dv.setInt16(42 + 2 * i, 1, le);
  dv.setInt16(70, datatype, le);
  dv.setInt16(72, bitpix, le);
  dv.setFloat32(76, qform && qform.qfac < 0 ? -1 : 1, le);
  pixdim.forEach((p, i) => dv.setFloat32(80 + 4 * i, p, le));
  dv.setFloat32(108, 352, le);
  dv.setFloat32(112, slope, le);
  dv.setFloat32(116, inter, le);
  if (qform) {
    dv.setInt16(252, 1, le);
    qform.quatern.forEach((q, i) => dv.setFloat32(256 + 4 * i, q, le));
    qform.offset.forEach((o, i) => dv.setFloat32(268 + 4 * i, o, le));
  }
  if (sform) {
    dv.setInt16(254, 2, le);
    sform.forEach((v, i) => dv.setFloat32(280 + 4 * i, v, le));
  }
  buf.set([0x6e, 0x2b, 0x31, 0], 344);
  for (let i = 0; i < n; ++i) {
    const v = values ? values[i] : i;
    if (datatype === 4) dv.setInt16(352 + 2 * i, v, le);
    else if (datatype === 256) dv.setInt8(352 + i, v);
    else if (datatype === 2) dv.setUint8(352 + i, v);
  }
  return buf;
}

test("int16, little and big endian, read the same values on the sform", () => {
  const sform = [0, -2, 0, 10, 1, 0, 0, -5, 0, 0, 3, 7];
  for (const le of [true, false]) {
    const img = nifti.read(makeNifti({ le, sform }));
    assert.deepStrictEqual(img.dims, [3, 4, 5]);
    assert.ok(img.voxels instanceof Int16Array);
    assert.deepStrictEqual(Array.from(img.voxels.slice(0, 5)), [0, 1, 2, 3, 4]);
    assert.strictEqual(img.voxels[59], 59);
    assert.strictEqual(img.which, "sform");
    assert.deepStrictEqual(img.affine, [...sform, 0, 0, 0, 1]);
    assert.deepStrictEqual(img.spacing, [1, 2, 3]);
    assert.deepStrictEqual([img.sclSlope, img.sclInter], [1, 0]);
  }
});

test("the qform when there is no sform (a 90 degree turn about z, qfac -1), else the voxel sizes", () => {
  const s = Math.SQRT1_2;
  const q = nifti.read(makeNifti({ qform: { quatern: [0, 0, s], offset: [1, 2, 3], qfac: -1 } }));
  assert.strictEqual(q.which, "qform");
  const expect = [0, -2, 0, 1, 1, 0, 0, 2, 0, 0, -3, 3, 0, 0, 0, 1];
  q.affine.forEach((v, i) => assert.ok(Math.abs(v - expect[i]) < 1e-6, `affine[${i}] = ${v}, expected ${expect[i]}`));
  const p = nifti.read(makeNifti({ slope: 2, inter: -1 }));
  assert.strictEqual(p.which, "pixdim");
  assert.deepStrictEqual(p.affine, [1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 3, 0, 0, 0, 0, 1]);
  assert.deepStrictEqual([p.sclSlope, p.sclInter], [2, -1]);
});

test("int8 is widened to Int16Array, as the tool does", () => {
  const img = nifti.read(makeNifti({ datatype: 256, bitpix: 8, values: Array.from({ length: 60 }, (_, i) => i - 30) }));
  assert.ok(img.voxels instanceof Int16Array);
  assert.strictEqual(img.voxels[0], -30);
  assert.strictEqual(img.datatypeName, "int8");
});

test("files it cannot read give a message, never a crash", () => {
  const good = makeNifti();
  assert.throws(() => nifti.read(good.subarray(0, 100)), /348/);
  assert.throws(() => nifti.read(good.subarray(0, 400)), /truncated/);
  const two = good.slice(); new DataView(two.buffer).setInt32(0, 540, true);
  assert.throws(() => nifti.read(two), /NIfTI-2/);
  const bad = good.slice(); new DataView(bad.buffer).setInt16(70, 128, true);
  assert.throws(() => nifti.read(bad), /datatype 128 is not supported/);
  const fourD = good.slice(); new DataView(fourD.buffer).setInt16(40, 4, true); new DataView(fourD.buffer).setInt16(48, 2, true);
  assert.throws(() => nifti.read(fourD), /only 3-D/);
  assert.throws(() => nifti.read(new TextEncoder().encode("hello ".repeat(100))), /not a NIfTI-1 file/);
});

test("gunzip inflates, and a damaged stream is an error", async () => {
  const raw = makeNifti();
  const gz = zlib.gzipSync(raw);
  assert.deepStrictEqual(await nifti.gunzip(new Uint8Array(gz)), raw);
  assert.strictEqual(await nifti.gunzip(raw), raw);
  const broken = new Uint8Array(gz.subarray(0, gz.length / 2));
  await assert.rejects(nifti.gunzip(broken), nifti.NiftiError);
});

test("writeLabels: a uint8 map on the source's grid and geometry, read back unchanged", () => {
  const sform = [0, -2, 0, 10, 1, 0, 0, -5, 0, 0, 3, 7];
  for (const le of [true, false]) {
    const src = nifti.read(makeNifti({ le, sform, slope: 2 }));
    const labels = new Uint8Array(60).map((_, i) => (i % 7 === 0 ? 3 : 0));
    const back = nifti.read(nifti.writeLabels(src, labels));
    assert.deepStrictEqual(back.dims, src.dims);
    assert.deepStrictEqual(back.affine, src.affine);
    assert.ok(back.voxels instanceof Uint8Array);
    assert.deepStrictEqual(back.voxels, labels);
    assert.deepStrictEqual([back.sclSlope, back.sclInter], [1, 0]);
    assert.throws(() => nifti.writeLabels(src, new Uint8Array(10)), /60 values/);
  }
});
