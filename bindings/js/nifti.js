/* NIfTI-1 in and out for the JavaScript binding, the page and its worker.
 *
 * read(bytes) gives what the engine needs in the form the ffseg tool hands it
 * (tools/nifti.cpp): voxels widened to an engine type (int8 -> Int16; uint32,
 * int64, uint64 -> Float64), the index-to-world affine by the same rule
 * (sform when sform_code > 0, else qform when qform_code > 0, else the voxel
 * sizes), scl_slope 0 read as no scaling. So the page and the tool segment the
 * same numbers. gunzip(bytes) inflates a .nii.gz (DecompressionStream: browsers,
 * workers and Node 18+). writeLabels() writes a uint8 label map on the geometry
 * of the header it was read with.
 */
(function (root, make) {
  if (typeof module === "object" && module.exports) module.exports = make();
  else root.ffsegNifti = make();
})(typeof self !== "undefined" ? self : this, function () {
  "use strict";

  class NiftiError extends Error {
    constructor(message) { super(message); this.name = "NiftiError"; }
  }

  // datatype -> [bitpix, file bytes, reader, engine typed array]
  const DATATYPES = {
    2: [8, 1, "getUint8", Uint8Array, "uint8"],
    4: [16, 2, "getInt16", Int16Array, "int16"],
    8: [32, 4, "getInt32", Int32Array, "int32"],
    16: [32, 4, "getFloat32", Float32Array, "float32"],
    64: [64, 8, "getFloat64", Float64Array, "float64"],
    256: [8, 1, "getInt8", Int16Array, "int8"],
    512: [16, 2, "getUint16", Uint16Array, "uint16"],
    768: [32, 4, "getUint32", Float64Array, "uint32"],
    1024: [64, 8, "getBigInt64", Float64Array, "int64"],
    1280: [64, 8, "getBigUint64", Float64Array, "uint64"],
  };

  function isGzip(bytes) { return bytes.length >= 2 && bytes[0] === 0x1f && bytes[1] === 0x8b; }

  async function gunzip(bytes) {
    if (!isGzip(bytes)) return bytes;
    if (typeof DecompressionStream !== "function") throw new NiftiError("this JavaScript runtime cannot inflate gzip (no DecompressionStream)");
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
    try {
      return new Uint8Array(await new Response(stream).arrayBuffer());
    } catch (ex) {
      throw new NiftiError("the gzip stream is damaged: " + ex.message);
    }
  }

  function quaternionAffine(b, c, d, vox, qfac, off) {
    const s = b * b + c * c + d * d;
    let a;
    if (s > 1) { const k = 1 / Math.sqrt(s); b *= k; c *= k; d *= k; a = 0; } else a = Math.sqrt(1 - s);
    const R = [a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),
      2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
      2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b];
    const scale = [vox[0], vox[1], vox[2] * qfac];
    const m = new Array(16).fill(0);
    for (let r = 0; r < 3; ++r) {
      for (let col = 0; col < 3; ++col) m[4 * r + col] = R[3 * r + col] * scale[col];
      m[4 * r + 3] = off[r];
    }
    m[15] = 1;
    return m;
  }

  function det3(m) {
    return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) + m[2] * (m[4] * m[9] - m[5] * m[8]);
  }

  /* Parses an uncompressed single-file NIfTI-1 (.nii) held in a Uint8Array.
   * Returns { dims, voxels, affine (16, row-major), which ("sform", "qform",
   * "pixdim"), spacing, sclSlope, sclInter, datatypeName, header (the 348 bytes) }. */
  function read(bytes) {
    if (!(bytes instanceof Uint8Array)) bytes = new Uint8Array(bytes);
    if (bytes.length < 348) throw new NiftiError(`not a NIfTI file: ${bytes.length} bytes, a NIfTI-1 header alone has 348`);
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.length);
    let le = true;
    if (dv.getInt32(0, true) !== 348) {
      if (dv.getInt32(0, false) === 348) le = false;
      else if (dv.getInt32(0, true) === 540 || dv.getInt32(0, false) === 540) throw new NiftiError("NIfTI-2 files are not supported (NIfTI-1 only)");
      else throw new NiftiError("not a NIfTI-1 file (sizeof_hdr is not 348)");
    }
    const magic = String.fromCharCode(bytes[344], bytes[345], bytes[346]);
    if (magic !== "n+1") throw new NiftiError(magic === "ni1" ? "a two-file NIfTI (.hdr/.img) cannot be read here: use a single .nii or .nii.gz" : "not a NIfTI-1 file (no n+1 magic)");
    const i16 = (o) => dv.getInt16(o, le), f32 = (o) => dv.getFloat32(o, le);
    const ndim = i16(40);
    if (ndim < 1 || ndim > 7) throw new NiftiError(`dim[0] = ${ndim} is outside 1..7`);
    const dim = [];
    for (let i = 1; i <= 7; ++i) dim.push(i <= ndim ? i16(40 + 2 * i) : 1);
    if (dim.some((x) => x < 1)) throw new NiftiError(`a dimension is not positive (dim ${dim.slice(0, ndim).join(" x ")})`);
    if (dim.slice(3).some((x) => x > 1)) throw new NiftiError(`only 3-D volumes are segmented; this one has dims ${dim.slice(0, ndim).join(" x ")}`);
    const dims = dim.slice(0, 3);
    const datatype = i16(70), bitpix = i16(72);
    const dt = DATATYPES[datatype];
    if (!dt) throw new NiftiError(`datatype ${datatype} is not supported (integers, float32 and float64 are)`);
    if (bitpix !== dt[0]) throw new NiftiError(`bitpix ${bitpix} does not match datatype ${datatype} (${dt[4]} needs ${dt[0]})`);
    const vo = f32(108);
    if (!Number.isFinite(vo) || vo < 352 || vo !== Math.floor(vo)) throw new NiftiError(`vox_offset ${vo} is not an integer >= 352`);
    const count = dims[0] * dims[1] * dims[2];
    const need = vo + count * dt[1];
    if (bytes.length < need) throw new NiftiError(`the file is truncated: the voxels need ${need} bytes, it has ${bytes.length}`);
    let sclSlope = f32(112), sclInter = f32(116);
    if (!Number.isFinite(sclSlope) || !Number.isFinite(sclInter)) throw new NiftiError("scl_slope or scl_inter is not finite");
    if (sclSlope === 0) { sclSlope = 1; sclInter = 0; }

    const pixdim = [];
    for (let i = 0; i < 8; ++i) pixdim.push(f32(76 + 4 * i));
    const vox = [1, 2, 3].map((i) => (i > ndim && !(pixdim[i] > 0) ? 1 : pixdim[i]));
    const qcode = i16(252), scode = i16(254);
    let affine, which, spacing;
    if (scode > 0) {
      affine = new Array(16).fill(0);
      for (let r = 0; r < 3; ++r) for (let c = 0; c < 4; ++c) affine[4 * r + c] = f32(280 + 16 * r + 4 * c);
      affine[15] = 1;
      if (!affine.every(Number.isFinite)) throw new NiftiError("the sform is not finite");
      spacing = [0, 1, 2].map((c) => Math.hypot(affine[c], affine[4 + c], affine[8 + c]));
      if (!(Math.abs(det3(affine)) > 1e-6 * spacing[0] * spacing[1] * spacing[2])) throw new NiftiError("the sform is singular");
      which = "sform";
    } else {
      if (!vox.every((x) => x > 0)) throw new NiftiError(`voxel sizes ${vox.join(", ")} must be > 0`);
      spacing = vox;
      if (qcode > 0) {
        const q = [f32(256), f32(260), f32(264)], off = [f32(268), f32(272), f32(276)];
        if (!q.concat(off).every(Number.isFinite)) throw new NiftiError("the qform is not finite");
        if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] > 1 + 1e-5) throw new NiftiError("the qform quaternion is not a unit quaternion");
        affine = quaternionAffine(q[0], q[1], q[2], vox, pixdim[0] < 0 ? -1 : 1, off);
        which = "qform";
      } else {
        affine = [vox[0], 0, 0, 0, 0, vox[1], 0, 0, 0, 0, vox[2], 0, 0, 0, 0, 1];
        which = "pixdim";
      }
    }

    const Out = dt[3];
    let voxels;
    const start = bytes.byteOffset + vo;
    if (le && Out.BYTES_PER_ELEMENT === dt[1] && start % dt[1] === 0 && dt[2] !== "getUint32") {
      voxels = new Out(bytes.buffer.slice(start, start + count * dt[1]));
    } else {
      voxels = new Out(count);
      const get = dv[dt[2]].bind(dv), step = dt[1];
      for (let i = 0, o = vo; i < count; ++i, o += step) voxels[i] = Number(get(o, le));
    }
    return {
      dims, voxels, affine, which, spacing, sclSlope, sclInter, datatypeName: dt[4],
      header: bytes.slice(0, 348), littleEndian: le,
    };
  }

  /* A single-file NIfTI-1 of uint8 labels on the grid and geometry of `source`
   * (what read() returned): its header with the datatype, scaling and offset
   * of a label map. */
  function writeLabels(source, labels, description = "ffseg labels") {
    const [nx, ny, nz] = source.dims;
    if (!(labels instanceof Uint8Array) || labels.length !== nx * ny * nz)
      throw new NiftiError(`the label map must be a Uint8Array of ${nx * ny * nz} values`);
    const out = new Uint8Array(352 + labels.length);
    out.set(source.header, 0);
    const dv = new DataView(out.buffer), le = source.littleEndian;
    dv.setInt16(40, 3, le);
    for (let i = 0; i < 3; ++i) dv.setInt16(42 + 2 * i, source.dims[i], le);
    for (let i = 3; i < 7; ++i) dv.setInt16(42 + 2 * i, 1, le);
    dv.setInt16(70, 2, le);   // uint8
    dv.setInt16(72, 8, le);
    dv.setFloat32(108, 352, le);
    dv.setFloat32(112, 1, le);
    dv.setFloat32(116, 0, le);
    dv.setFloat32(124, 0, le);  // cal_max, cal_min
    dv.setFloat32(128, 0, le);
    for (let i = 0; i < 80; ++i) out[148 + i] = i < description.length ? description.charCodeAt(i) & 0x7f : 0;
    out.set([0x6e, 0x2b, 0x31, 0], 344);  // n+1
    out.set(labels, 352);
    return out;
  }

  return { read, gunzip, isGzip, writeLabels, NiftiError };
});
