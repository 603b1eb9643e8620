/* ffseg from JavaScript: the C ABI (include/ffseg.h) of the WebAssembly build
 * (`make wasm`: build-wasm/ffseg.js + ffseg.wasm), with typed arrays in and out.
 *
 *     const ffseg = require("./bindings/js/ffseg.js");   // or a <script>/importScripts: self.ffseg
 *     const lib = await ffseg.load();                    // Node: build-wasm/ (or FFSEG_WASM_DIR)
 *     const e = new lib.Engine({ maxObjects: 1, meshResolution: 33 });
 *     e.setParams({ targetMode: "intensity", stepSize: 0.5 });
 *     e.setVolume(voxels, [nx, ny, nz], affine);         // voxels: Uint8Array ... Float64Array, i fastest
 *     e.initSphere(0, [x, y, z], radiusMm);
 *     while (!e.step().atRest) {}
 *     const { vertices, triangles } = e.extractMesh(0); // Float32Array xyz, Uint32Array
 *     const mask = e.rasterize(0);                       // Uint8Array, i fastest
 *     e.close();
 *
 * Every failing call throws ffseg.FfsegError with .status (the C code), .code
 * (its FFSEG_ERR_* name without the prefix), .call and the engine's message.
 * The engine lives in one workspace allocated in the module's memory at
 * construction; the volume, mask and mesh buffers are allocated by
 * setVolume / initSphere, so step, extractMesh and rasterize allocate nothing
 * (bindings/js/test/nomalloc.test.js checks it).
 */
(function (root, make) {
  if (typeof module === "object" && module.exports) module.exports = make();
  else root.ffseg = make();
})(typeof self !== "undefined" ? self : this, function () {
  "use strict";

  const OK = 0, CONVERGED = 1, DEGENERATE = 2;
  const STATUS_CODES = {
    [-1]: "INVALID_ARGUMENT", [-2]: "NULL_POINTER", [-3]: "WORKSPACE_TOO_SMALL",
    [-4]: "WORKSPACE_MISALIGNED", [-5]: "INVALID_VOLUME", [-6]: "OBJECT_OUT_OF_RANGE",
    [-7]: "BUFFER_TOO_SMALL", [-8]: "MISUSE", [-9]: "NUMERIC", [-10]: "ROI_TOO_LARGE",
    [-11]: "SPHERE_OUTSIDE", [-12]: "STRUCT_SIZE", [-13]: "CONFIG_TOO_LARGE",
    [-14]: "NOT_IMPLEMENTED",
  };
  const TARGET_MODES = { binary: 0, intensity: 1 };
  const STAGE_NAMES = ["search", "flips", "diffusion", "intersection", "assembly",
    "factor", "solve", "features", "guard", "regions"];
  const REPORT_OBJECTS = 16;
  const OBJECT_NO_BOUNDARY = 1, OBJECT_FILLS_GRID = 2, OBJECT_STALLED = 4;
  // FFSEG_U8 ... FFSEG_F64 by typed-array class.
  const VOXEL_TYPES = new Map([
    ["Uint8Array", 1], ["Int16Array", 2], ["Uint16Array", 3], ["Int32Array", 4],
    ["Float32Array", 5], ["Float64Array", 6],
  ]);

  class FfsegError extends Error {
    constructor(status, message, call) {
      const code = STATUS_CODES[status] || "UNKNOWN";
      super(`${call ? call + ": " : ""}${message} [${code}, status ${status}]`);
      this.name = "FfsegError";
      this.status = status;
      this.code = code;
      this.call = call || null;
      this.engineMessage = message;
    }
  }

  // ---- the structs, laid out by wasm32's C rules (pointers and size_t are 4
  // bytes, each field aligned to its size, the struct to its widest field).
  // test/abi.test.js compares every offset with the C compiler's (abi_layout.js).
  const SIZES = { u32: 4, i64: 8, f64: 8, ptr: 4 };
  function layout(fields) {
    const out = { fields: {}, size: 0 };
    let off = 0, align = 1;
    for (const [name, type, count = 1] of fields) {
      const s = SIZES[type];
      off = Math.ceil(off / s) * s;
      out.fields[name] = { offset: off, type, count, size: s * count };
      off += s * count;
      align = Math.max(align, s);
    }
    out.size = Math.ceil(off / align) * align;
    return out;
  }
  const CONFIG = layout([["struct_size", "u32"], ["max_objects", "u32"], ["mesh_resolution", "u32"],
    ["reserved0", "u32"], ["max_roi_voxels", "i64"], ["target_mode", "u32"], ["reserved1", "u32"],
    ["max_region_voxels", "i64"]]);  // since 0.6.0
  const PARAMS = layout([["struct_size", "u32"], ["target_mode", "u32"], ["lambda_laplacian", "f64"],
    ["lambda_position", "f64"], ["lambda_uniform", "f64"], ["step_size", "f64"], ["flip_tau", "f64"],
    ["search_range_mm", "f64"], ["search_step_mm", "f64"], ["convergence_mm", "f64"],
    ["diffusion_iterations", "u32"], ["consecutive_background", "u32"], ["smoothing_iterations", "u32"],
    ["bin_min_count", "u32"], ["smoothing_kappa", "f64"], ["intensity_gamma", "f64"],
    ["sigma_floor_fraction", "f64"], ["bin_radius", "f64"], ["bin_separation", "f64"],
    ["partial_volume_steps", "u32"], ["reserved1", "u32"], ["region_width_mm", "f64"],
    ["border_weight", "f64"], ["region_interval", "u32"], ["grey_respacing", "u32"]]);  // since 0.7.0 (reserved2 before)
  const VOLUME = layout([["struct_size", "u32"], ["voxel_type", "u32"], ["data", "ptr"],
    ["data_bytes", "i64"], ["offset", "i64"], ["dims", "i64", 3], ["strides", "i64", 3],
    ["index_to_world", "f64", 16], ["rescale_slope", "f64"], ["rescale_intercept", "f64"]]);
  const STEP_INFO = layout([["struct_size", "u32"], ["step_index", "u32"], ["active_objects", "u32"],
    ["reserved0", "u32"], ["mean_displacement_mm", "f64", REPORT_OBJECTS],
    ["vertices_with_target", "u32", REPORT_OBJECTS], ["flips_avoided", "u32", REPORT_OBJECTS],
    ["intersections_avoided", "u32", REPORT_OBJECTS], ["border_vertices", "u32", REPORT_OBJECTS],
    ["stage_us", "i64", STAGE_NAMES.length], ["object_flags", "u32", REPORT_OBJECTS],
    ["flags_all", "u32"], ["reserved1", "u32"], ["guard_held", "u32", REPORT_OBJECTS],
    ["far_outward", "u32", REPORT_OBJECTS], ["far_inward", "u32", REPORT_OBJECTS],
    ["respaced", "u32", REPORT_OBJECTS]]);  // since 0.8.0
  const LAYOUTS = { ffseg_config: CONFIG, ffseg_params: PARAMS, ffseg_volume: VOLUME, ffseg_step_info: STEP_INFO };

  const camel = (s) => s.replace(/_([a-z])/g, (_, c) => c.toUpperCase());
  // ffseg_params fields a caller sets, by their JavaScript names (lambdaLaplacian ...).
  const PARAM_NAMES = Object.keys(PARAMS.fields).filter((n) => n !== "struct_size" && !n.startsWith("reserved"));
  const PARAM_BY_CAMEL = new Map(PARAM_NAMES.map((n) => [camel(n), n]));

  // Reads and writes one struct in the module's memory. The memory may grow
  // (and its ArrayBuffer be replaced) whenever the JavaScript side allocates,
  // so the view is taken afresh for each use.
  class StructView {
    constructor(mod, ptr, lay) { this.mod = mod; this.ptr = ptr; this.lay = lay; }
    view() { return new DataView(this.mod.HEAPU8.buffer, this.ptr, this.lay.size); }
    clear() { this.mod.HEAPU8.fill(0, this.ptr, this.ptr + this.lay.size); }
    get(name, i = 0) {
      const f = this.lay.fields[name], dv = this.view(), at = f.offset + i * SIZES[f.type];
      switch (f.type) {
        case "u32": case "ptr": return dv.getUint32(at, true);
        case "f64": return dv.getFloat64(at, true);
        case "i64": return Number(dv.getBigInt64(at, true));
      }
      throw new Error("unknown field type " + f.type);
    }
    set(name, value, i = 0) {
      const f = this.lay.fields[name], dv = this.view(), at = f.offset + i * SIZES[f.type];
      switch (f.type) {
        case "u32": case "ptr": dv.setUint32(at, value, true); return;
        case "f64": dv.setFloat64(at, value, true); return;
        case "i64": dv.setBigInt64(at, BigInt(value), true); return;
      }
      throw new Error("unknown field type " + f.type);
    }
    array(name) {
      const f = this.lay.fields[name], out = [];
      for (let i = 0; i < f.count; ++i) out.push(this.get(name, i));
      return out;
    }
  }

  function u32(x, what, call) {
    if (!Number.isInteger(x) || x < 0 || x > 0xffffffff)
      throw new FfsegError(-1, `${what}: ${JSON.stringify(x)} is not an integer in 0..2^32-1`, call);
    return x;
  }
  function finiteVector(v, n, what, call) {
    const a = Array.from(v || [], Number);
    if (a.length !== n || !a.every(Number.isFinite))
      throw new FfsegError(-1, `${what} needs ${n} finite numbers, got ${JSON.stringify(v)}`, call);
    return a;
  }

  // The library over one instantiated module.
  function bind(mod) {
    const C = {};
    for (const k of Object.keys(mod)) if (k.startsWith("_ffseg_")) C[k.slice(1)] = mod[k];
    const text = (p) => (p ? mod.UTF8ToString(p) : "");

    function malloc(bytes, call) {
      // 64 spare bytes: the workspace must start on a 64-byte boundary.
      const p = mod._malloc(bytes + 64);
      if (!p) throw new FfsegError(-3, `cannot allocate ${bytes} bytes in the WebAssembly memory (limit 2 GiB)`, call);
      return p;
    }
    function check(status, call, enginePtr) {
      if (status < 0) {
        const msg = text(C.ffseg_last_error(enginePtr || 0));
        throw new FfsegError(status, msg || text(C.ffseg_status_string(status)), call);
      }
      return status;
    }

    class StepReport {
      constructor(info, status, objects) {
        const n = Math.min(objects, REPORT_OBJECTS);
        this.status = status === CONVERGED ? "converged" : status === DEGENERATE ? "degenerate" : "ok";
        this.atRest = status === CONVERGED || status === DEGENERATE;
        this.stepIndex = info.get("step_index");
        this.activeObjects = info.get("active_objects");
        for (const f of ["mean_displacement_mm", "vertices_with_target", "flips_avoided",
          "intersections_avoided", "border_vertices", "object_flags", "guard_held", "far_outward", "far_inward",
          "respaced"])
          this[camel(f)] = info.array(f).slice(0, n);
        this.flagsAll = info.get("flags_all");
        this.stageUs = {};
        STAGE_NAMES.forEach((s, i) => { this.stageUs[s] = info.get("stage_us", i); });
      }
    }

    class Engine {
      /* maxObjects 1..64, meshResolution n (6 n^2 vertices per mesh),
       * maxRoiVoxels (the library's default when omitted), maxRegionVoxels
       * (since 0.6.0, several objects: the voxels one bounding region is marched
       * on, 0..2^40; omitted or 0: maxRoiVoxels; a larger region's box is
       * marched on cells of several voxels, ffseg.h's max_region_voxels),
       * targetMode "intensity" (default: both modes allowed) or "binary"
       * (smaller workspace). */
      constructor({ maxObjects = 1, meshResolution = 33, maxRoiVoxels, maxRegionVoxels, targetMode = "intensity" } = {}) {
        const call = "Engine";
        this._mod = mod;
        this._blocks = [];
        this._e = 0;
        const scratchBytes = CONFIG.size + PARAMS.size + VOLUME.size + STEP_INFO.size + 128;
        this._scratch = this._alloc(scratchBytes, call);
        let at = this._scratch;
        const next = (lay) => { const v = new StructView(mod, at, lay); at += Math.ceil(lay.size / 8) * 8; return v; };
        const cfg = next(CONFIG);
        this._params = next(PARAMS);
        this._vol = next(VOLUME);
        this._info = next(STEP_INFO);
        this._small = at;  // centre (3 doubles), then two size_t counts, then the strides (3 int64)
        C.ffseg_config_init_default(cfg.ptr);
        cfg.set("struct_size", CONFIG.size);
        cfg.set("max_objects", u32(maxObjects, "maxObjects", call));
        cfg.set("mesh_resolution", u32(meshResolution, "meshResolution", call));
        if (maxRoiVoxels !== undefined) {
          if (!Number.isSafeInteger(maxRoiVoxels)) throw new FfsegError(-1, `maxRoiVoxels: ${maxRoiVoxels} is not an integer`, call);
          cfg.set("max_roi_voxels", maxRoiVoxels);
        }
        if (maxRegionVoxels !== undefined) {
          if (!Number.isSafeInteger(maxRegionVoxels)) throw new FfsegError(-1, `maxRegionVoxels: ${maxRegionVoxels} is not an integer`, call);
          cfg.set("max_region_voxels", maxRegionVoxels);
        }
        if (!(targetMode in TARGET_MODES))
          throw new FfsegError(-1, `targetMode: expected "binary" or "intensity", got ${JSON.stringify(targetMode)}`, call);
        cfg.set("target_mode", TARGET_MODES[targetMode]);
        const sizeAt = this._small + 24;
        check(C.ffseg_workspace_size(cfg.ptr, sizeAt), "ffseg_workspace_size");
        this.workspaceBytes = new DataView(mod.HEAPU8.buffer).getUint32(sizeAt, true);
        const raw = this._alloc(this.workspaceBytes, call);
        this._workspace = raw + ((64 - (raw % 64)) % 64);
        check(C.ffseg_create(cfg.ptr, this._workspace, this.workspaceBytes, sizeAt), "ffseg_create");
        this._e = new DataView(mod.HEAPU8.buffer).getUint32(sizeAt, true);
        this.config = { maxObjects, meshResolution, maxRoiVoxels: cfg.get("max_roi_voxels"),
          maxRegionVoxels: cfg.get("max_region_voxels"), targetMode };
        C.ffseg_params_init_default(this._params.ptr);
        this._params.set("struct_size", PARAMS.size);
        this._dims = null;
        this._volBuf = 0; this._volCap = 0;
        this._maskBuf = 0; this._maskCap = 0;
        this._meshBuf = 0; this._meshCounts = null;
        this._srcBuf = 0; this._srcCap = 0;
        this.lastStep = null;
      }

      _alloc(bytes, call) { const p = malloc(bytes, call); this._blocks.push(p); return p; }
      _handle(call) {
        if (!this._e) throw new FfsegError(-8, "the engine was closed", call);
        return this._e;
      }

      /* Ends the engine and frees its workspace and buffers. Safe to call twice. */
      close() {
        if (this._e) C.ffseg_destroy(this._e);
        this._e = 0;
        for (const p of this._blocks) mod._free(p);
        this._blocks = [];
      }

      /* The current parameters, by their JavaScript names. */
      get params() {
        const out = {};
        for (const n of PARAM_NAMES) out[camel(n)] = this._params.get(n);
        return out;
      }

      /* Sets ffseg_params fields by name (targetMode also "binary" / "intensity");
       * the others keep their values. On an error nothing changes and the
       * message names the field. */
      setParams(fields) {
        const call = "setParams", h = this._handle(call);
        const p = this._params, saved = mod.HEAPU8.slice(p.ptr, p.ptr + PARAMS.size);
        try {
          for (let [name, value] of Object.entries(fields || {})) {
            const c = PARAM_BY_CAMEL.get(name);
            if (!c) throw new FfsegError(-1, `unknown parameter '${name}' (known: ${[...PARAM_BY_CAMEL.keys()].join(", ")})`, call);
            if (c === "target_mode" && typeof value === "string") {
              if (!(value in TARGET_MODES)) throw new FfsegError(-1, `targetMode: expected "binary" or "intensity", got "${value}"`, call);
              value = TARGET_MODES[value];
            }
            if (PARAMS.fields[c].type === "u32") p.set(c, u32(value, name, call));
            else {
              if (typeof value !== "number" || Number.isNaN(value)) throw new FfsegError(-1, `${name}: ${JSON.stringify(value)} is not a number`, call);
              p.set(c, value);
            }
          }
          check(C.ffseg_set_params(h, p.ptr), "ffseg_set_params", h);
        } catch (ex) {
          mod.HEAPU8.set(saved, p.ptr);
          throw ex;
        }
      }

      /* The volume: voxels a typed array (Uint8, Int16, Uint16, Int32, Float32,
       * Float64) of dims[0]*dims[1]*dims[2] values, i fastest (NIfTI order);
       * affine: 16 numbers row-major (or 4 rows), voxel centre -> world mm.
       * The voxels are copied into the module's memory (a buffer kept and reused
       * for volumes no larger). */
      setVolume(voxels, dims, affine, { rescaleSlope = 1, rescaleIntercept = 0 } = {}) {
        const call = "setVolume", h = this._handle(call);
        const type = voxels && VOXEL_TYPES.get(voxels.constructor.name);
        if (!type) throw new FfsegError(-5, `unsupported voxel array ${voxels && voxels.constructor.name} (supported: ${[...VOXEL_TYPES.keys()].join(", ")})`, call);
        const d = finiteVector(dims, 3, "dims", call);
        if (!d.every((x) => Number.isInteger(x) && x >= 1))
          throw new FfsegError(-5, `dims must be 3 positive integers, got ${JSON.stringify(dims)}`, call);
        const count = d[0] * d[1] * d[2];
        if (voxels.length !== count)
          throw new FfsegError(-5, `the voxel array holds ${voxels.length} values, dims ${d.join("x")} need ${count}`, call);
        const A = finiteVector(Array.isArray(affine) && Array.isArray(affine[0]) ? affine.flat() : affine, 16, "affine", call);
        const bytes = voxels.byteLength;
        if (bytes > this._volCap) {
          // The engine borrows the old buffer until set_volume succeeds; it is
          // kept (not freed) so a refused volume leaves the previous one valid.
          this._volBuf = this._alloc(bytes, call);
          this._volCap = bytes;
        }
        mod.HEAPU8.set(new Uint8Array(voxels.buffer, voxels.byteOffset, bytes), this._volBuf);
        const v = this._vol, bpv = voxels.BYTES_PER_ELEMENT;
        v.clear();
        v.set("struct_size", VOLUME.size);
        v.set("voxel_type", type);
        v.set("data", this._volBuf);
        v.set("data_bytes", bytes);
        v.set("offset", 0);
        [bpv, bpv * d[0], bpv * d[0] * d[1]].forEach((s, a) => { v.set("dims", d[a], a); v.set("strides", s, a); });
        A.forEach((x, i) => v.set("index_to_world", x, i));
        v.set("rescale_slope", rescaleSlope);
        v.set("rescale_intercept", rescaleIntercept);
        check(C.ffseg_set_volume(h, v.ptr), "ffseg_set_volume", h);
        if (count > this._maskCap) { this._maskBuf = this._alloc(count, call); this._maskCap = count; }
        this._dims = d;
      }

      /* The rescaled intensity at a world point: trilinear, or the nearest voxel. */
      sample(pointMm, linear = true) {
        const call = "sample", h = this._handle(call);
        const pt = finiteVector(pointMm, 3, "point", call);
        const f64 = new Float64Array(mod.HEAPU8.buffer, this._small, 4);
        f64.set(pt);
        check(C.ffseg_sample(h, this._small, linear ? 1 : 0, this._small + 24), "ffseg_sample", h);
        return new Float64Array(mod.HEAPU8.buffer, this._small, 4)[3];
      }

      /* Places object obj's mesh on a sphere (world mm). */
      initSphere(obj, centerMm, radiusMm) {
        const call = "initSphere", h = this._handle(call);
        const c = finiteVector(centerMm, 3, "centre", call);
        new Float64Array(mod.HEAPU8.buffer, this._small, 3).set(c);
        check(C.ffseg_init_sphere(h, u32(obj, "object", call), this._small, Number(radiusMm)), "ffseg_init_sphere", h);
        this._meshBuffers(h, obj, call);
      }

      /* Places object obj's mesh from another cube-sphere mesh (vertices: a
       * Float32Array of 6 n^2 x, y, z from extractMesh of an engine of any
       * resolution n), resampled onto this engine's; the grey-level model is
       * learned from the sphere (centreMm, radiusMm) the source grew from.
       * Coarse to fine: segment at a small n, then initMesh into a finer engine. */
      initMesh(obj, centerMm, radiusMm, vertices) {
        const call = "initMesh", h = this._handle(call);
        const c = finiteVector(centerMm, 3, "centre", call);
        if (!(vertices instanceof Float32Array) || vertices.length % 3 !== 0)
          throw new FfsegError(-1, "vertices must be a Float32Array of x, y, z triples", call);
        if (vertices.byteLength > this._srcCap) { this._srcBuf = this._alloc(vertices.byteLength, call); this._srcCap = vertices.byteLength; }
        mod.HEAPU8.set(new Uint8Array(vertices.buffer, vertices.byteOffset, vertices.byteLength), this._srcBuf);
        new Float64Array(mod.HEAPU8.buffer, this._small, 3).set(c);
        check(C.ffseg_init_mesh(h, u32(obj, "object", call), this._small, Number(radiusMm), this._srcBuf, vertices.length / 3),
          "ffseg_init_mesh", h);
        this._meshBuffers(h, obj, call);
      }

      // The output buffer for extractMesh, sized by the first placed mesh (every
      // object of an engine has the same counts).
      _meshBuffers(h, obj, call) {
        if (!this._meshCounts) {
          const nv = this._small + 24, nt = this._small + 28;
          check(C.ffseg_extract_mesh(h, obj, 0, 0, 0, 0, nv, nt), "ffseg_extract_mesh", h);
          const dv = new DataView(mod.HEAPU8.buffer);
          const counts = { vertices: dv.getUint32(nv, true), triangles: dv.getUint32(nt, true) };
          this._meshBuf = this._alloc(counts.vertices * 12 + counts.triangles * 12, call);
          this._meshCounts = counts;
        }
      }

      /* One deformation step of every placed object; returns the step's report
       * (StepReport: atRest once every object is at rest, status "ok",
       * "converged" or "degenerate", per-object arrays, stageUs by stage). */
      step() {
        const call = "step", h = this._handle(call);
        this._info.clear();
        this._info.set("struct_size", STEP_INFO.size);
        const st = check(C.ffseg_step(h, this._info.ptr), "ffseg_step", h);
        this.lastStep = new StepReport(this._info, st, this.config.maxObjects);
        return this.lastStep;
      }

      /* { vertices: Float32Array (x, y, z mm per vertex), triangles: Uint32Array
       * (3 indices each, counter-clockwise seen from outside) }: copies. */
      extractMesh(obj) {
        const call = "extractMesh", h = this._handle(call);
        if (!this._meshCounts) throw new FfsegError(-8, "no object placed: call initSphere first", call);
        const { vertices, triangles } = this._meshCounts;
        const xyz = this._meshBuf, tri = xyz + vertices * 12, counts = this._small + 24;
        check(C.ffseg_extract_mesh(h, u32(obj, "object", call), xyz, vertices, tri, triangles, counts, counts + 4),
          "ffseg_extract_mesh", h);
        const buf = mod.HEAPU8.buffer;
        return {
          vertices: new Float32Array(buf, xyz, vertices * 3).slice(),
          triangles: new Uint32Array(buf, tri, triangles * 3).slice(),
        };
      }

      /* Uint8Array over the volume grid (i fastest): 1 where the voxel centre
       * lies inside object obj's mesh. out: a Uint8Array of that length to fill. */
      rasterize(obj, out) { return this._mask("ffseg_rasterize", obj, out); }

      /* Uint8Array: 1 where object obj owns the voxel's bounding region (two or
       * more objects placed, after a step). */
      regionMask(obj, out) { return this._mask("ffseg_region_mask", obj, out); }

      _mask(fn, obj, out) {
        const h = this._handle(fn);
        if (!this._dims) throw new FfsegError(-8, "no volume: call setVolume first", fn);
        const n = this._dims[0] * this._dims[1] * this._dims[2];
        if (out !== undefined && !(out instanceof Uint8Array && out.length === n))
          throw new FfsegError(-1, `out must be a Uint8Array of ${n} values`, fn);
        check(C[fn](h, u32(obj, "object", fn), this._maskBuf, 0), fn, h);
        const src = new Uint8Array(mod.HEAPU8.buffer, this._maskBuf, n);
        if (out) { out.set(src); return out; }
        return src.slice();
      }
    }

    /* The whole run as `ffseg segment --mesh-resolution n` makes it (tools/cli:
     * run_engine), so the same inputs give the tool's masks: n above 12 first
     * runs at n = 12 to rest, then at n from the n = 12 meshes (coarse to
     * fine, initMesh), the larger organs (n = 12 voxels) placed first so that
     * where two resampled meshes overlap the larger keeps its own and the
     * other is tried scaled about its centroid, else from its sphere; an
     * object that stalls at n where its
     * first run did not is put back on its n = 12 surface, and where that is
     * refused the first run goes on at 12 from its meshes instead. One
     * grey-level object placed from its first-run mesh (not grown freely in
     * its first run) re-spaces its loops in the finer run while it encloses
     * no more than its first run's reach, and the finer run is made again
     * without when it leaves it (tools/cli/refinement_reach.h).
     *   volume:  { voxels, dims, affine, sclSlope, sclInter } (nifti.read's)
     *   spheres: [{ centre: [x, y, z] mm, radius mm }]
     *   options: meshResolution (33), maxSteps per run (200), targetMode
     *            ("intensity"), maxRoiVoxels (min(voxels, 2^26)), maxRegionVoxels
     *            (the library's default, maxRoiVoxels), engines (a Map
     *            to keep the engines, and so their workspaces, for the next call;
     *            one object's only: several objects get a new engine each run),
     *            onStep(report, { run, meshResolution, engine }) (awaited),
     *            shouldStop() (checked before each step).
     * Returns { masks, meshes, steps and stepMs (the last run's, as the tool
     * reports them), runs: [{ meshResolution, from: "spheres" | "first run",
     * steps, status, stepMs }], last (the last run's last report), stopped }. */
    async function segment(volume, spheres, { meshResolution = 33, maxSteps = 200, targetMode = "intensity", maxRoiVoxels,
      maxRegionVoxels, engines = new Map(), onStep, shouldStop } = {}) {
      const FIRST = 12, STALLED = 4;
      // A refused first-run mesh is tried again scaled about its centroid
      // (the tool's kFirstRunScales and scaled_about_centroid, to the bit:
      // the mean summed in order in double, each coordinate rounded once).
      const FIRST_RUN_SCALES = [1.0, 0.99, 0.98, 0.95];
      const scaledAboutCentroid = (v, f) => {
        if (f === 1.0) return v;
        const n = v.length / 3, c = [0, 0, 0];
        for (let i = 0; i < n; ++i) for (let a = 0; a < 3; ++a) c[a] += v[3 * i + a];
        for (let a = 0; a < 3; ++a) c[a] /= n;
        const w = new Float32Array(v.length);
        for (let i = 0; i < n; ++i) for (let a = 0; a < 3; ++a) w[3 * i + a] = c[a] + f * (v[3 * i + a] - c[a]);
        return w;
      };
      // Each scale computed only when the one before was refused.
      function* scaledStarts(v) { for (const f of FIRST_RUN_SCALES) yield scaledAboutCentroid(v, f); }
      const count = volume.dims[0] * volume.dims[1] * volume.dims[2];
      const k = spheres.length;
      const roi = maxRoiVoxels === undefined ? Math.min(count, 2 ** 26) : maxRoiVoxels;
      const out = { runs: [], stopped: false };
      // fresh: an engine with no object placed. The engine has no call that
      // takes an object away, and each run of several objects must place its
      // meshes where no earlier run's (this call's or the last one's) stand,
      // as the tool's new engine for each run does: a kept engine would refuse
      // them for overlapping meshes that are no longer meant.
      const engineAt = (n, fresh = false) => {
        const key = JSON.stringify([k, n, roi, maxRegionVoxels ?? null, targetMode]);
        if (fresh && engines.has(key)) { engines.get(key).close(); engines.delete(key); }
        if (!engines.has(key)) {
          for (const [old, e] of engines) if (JSON.parse(old)[1] === n) { e.close(); engines.delete(old); }
          engines.set(key, new Engine({ maxObjects: k, meshResolution: n, maxRoiVoxels: roi, maxRegionVoxels, targetMode }));
        }
        return engines.get(key);
      };
      const voxelsOf = (e) => spheres.map((_, j) => { let c = 0; const m = e.rasterize(j); for (let i = 0; i < m.length; ++i) c += m[i]; return c; });
      const stalledOf = (r) => spheres.map((_, j) => ((r && r.objectFlags[j]) & STALLED) !== 0);
      // The tool's enclosed_volume_mm3 and refinement_reach_mm3, summed in
      // the same order in doubles: the same decisions.
      const enclosedVolume = ({ vertices: x, triangles: t }) => {
        let six = 0;
        for (let i = 0; i + 2 < t.length; i += 3) {
          const a = 3 * t[i], b = 3 * t[i + 1], c = 3 * t[i + 2];
          six += x[a] * (x[b + 1] * x[c + 2] - x[b + 2] * x[c + 1]) +
                 x[a + 1] * (x[b + 2] * x[c] - x[b] * x[c + 2]) +
                 x[a + 2] * (x[b] * x[c + 1] - x[b + 1] * x[c]);
        }
        return six / 6;
      };
      const reachOf = (m) => {
        const x = m.vertices, t = m.triangles;
        let area = 0, sides = 0, ns = 0;
        for (let i = 0; i + 2 < t.length; i += 3) {
          const a = 3 * t[i], b = 3 * t[i + 1], c = 3 * t[i + 2];
          const u = [x[b] - x[a], x[b + 1] - x[a + 1], x[b + 2] - x[a + 2]];
          const v = [x[c] - x[a], x[c + 1] - x[a + 1], x[c + 2] - x[a + 2]];
          const w = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
          area += 0.5 * Math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
          const len = [0, 1, 2].map((e) => {
            const p = 3 * t[i + e], q = 3 * t[i + (e + 1) % 3];
            const d = [x[q] - x[p], x[q + 1] - x[p + 1], x[q + 2] - x[p + 2]];
            return Math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
          }).sort((p, q) => p - q);
          sides += len[0] + len[1];
          ns += 2;
        }
        return enclosedVolume(m) + area * (ns ? sides / ns : 0);
      };
      // starts[j]: the meshes object j tries in turn before its sphere; order:
      // the objects in the order they are placed (the tool's start_engine).
      // reach: the finer run re-spaces, each object held to reach[j]
      // (r.leftReach: the first to enclose more, and the step), unless
      // object 0 is placed from its sphere.
      async function run(n, starts, order, reach = null) {
        const e = engineAt(n, k > 1);
        e.setParams({ targetMode, greyRespacing: reach ? 1 : 0 });
        e.setVolume(volume.voxels, volume.dims, volume.affine, { rescaleSlope: volume.sclSlope ?? 1, rescaleIntercept: volume.sclInter ?? 0 });
        for (const j of order || spheres.map((_, i) => i)) {
          const s = spheres[j];
          let placed = false;
          for (const v of starts ? starts[j] : []) {
            try { e.initMesh(j, s.centre, s.radius, v); placed = true; break; } catch (ex) { if (!(ex instanceof FfsegError)) throw ex; }
          }
          if (placed) continue;
          if (reach) { e.setParams({ greyRespacing: 0 }); reach = null; }  // as the tool: a growth from the sphere is no refinement
          try {
            e.initSphere(j, s.centre, s.radius);
          } catch (ex) {
            if (!(ex instanceof FfsegError)) throw ex;
            const where = `sphere ${j + 1} (${Array.from(s.centre, (x) => Number(x).toFixed(1)).join(", ")}; r ${s.radius} mm)`;
            throw new FfsegError(ex.status, `${where}: ${ex.engineMessage}`, ex.call);
          }
        }
        const r = { meshResolution: n, from: starts ? "first run" : "spheres", steps: 0, status: "ok", engine: e, last: null,
          stepMs: [], respaced: !!reach, leftReach: null, grewFreely: null };
        while (r.steps < maxSteps) {
          if (shouldStop && shouldStop()) { out.stopped = true; break; }
          const t0 = performance.now();
          r.last = e.step();
          r.stepMs.push(performance.now() - t0);
          ++r.steps;
          if (r.steps === 1) r.grewFreely = spheres.map((_, j) => targetMode !== "binary" && r.last.respaced[j] !== 0);
          if (onStep) await onStep(r.last, { run: out.runs.length, meshResolution: n, engine: e });
          if (reach) {
            const j = spheres.findIndex((_, i) => enclosedVolume(e.extractMesh(i)) > reach[i]);
            if (j >= 0) { r.leftReach = { object: j, step: r.steps }; break; }
          }
          if (r.last.atRest) break;
        }
        r.status = r.leftReach ? "left reach" : r.last ? r.last.status : "none";
        out.runs.push(r);
        return r;
      }
      let final;
      if (meshResolution <= FIRST) final = await run(meshResolution, null);
      else {
        const first = await run(FIRST, null);
        const coarse = spheres.map((_, j) => first.engine.extractMesh(j).vertices);
        const coarseStalled = stalledOf(first.last), coarseVoxels = voxelsOf(first.engine);
        if (!out.stopped) {
          const order = spheres.map((_, j) => j).sort((a, b) => coarseVoxels[b] - coarseVoxels[a] || a - b);
          let lost = false;
          // As the tool: one grey-level object that did not grow freely
          // re-spaces its finer run within its first run's reach.
          const respacing = k === 1 && targetMode !== "binary" && !(first.grewFreely && first.grewFreely[0]);
          const reach = respacing ? spheres.map((_, j) => reachOf(first.engine.extractMesh(j))) : null;
          try {
            final = await run(meshResolution, coarse.map(scaledStarts), order, reach);
            if (final.leftReach && !out.stopped) final = await run(meshResolution, coarse.map(scaledStarts), order);
          } catch (ex) {  // an object placed neither from its first-run mesh nor from its sphere
            if (!(ex instanceof FfsegError)) throw ex;
            lost = true;
          }
          if (!lost) {
            const still = stalledOf(final.last);
            spheres.forEach((s, j) => {
              if (!still[j] || coarseStalled[j]) return;
              try { final.engine.initMesh(j, s.centre, s.radius, coarse[j]); } catch (ex) { if (!(ex instanceof FfsegError)) throw ex; lost = true; }
            });
          }
          // One cannot be placed at n, or cannot be put back on its
          // first-run surface there after a stall (resampled it crosses
          // itself, or meets a neighbour's finer mesh): as the tool, the
          // finer run is given up and the first run goes on at its own
          // resolution from its meshes.
          if (lost && !out.stopped) final = await run(FIRST, coarse.map(scaledStarts), order);
          else if (lost) final = first;
        } else final = first;
      }
      out.masks = spheres.map((_, j) => final.engine.rasterize(j));
      out.meshes = spheres.map((_, j) => final.engine.extractMesh(j));
      out.steps = final.steps;
      out.stepMs = final.stepMs;
      out.last = final.last;
      out.runs = out.runs.map(({ meshResolution: n, from, steps, status, stepMs, respaced, leftReach }) =>
        ({ meshResolution: n, from, steps, status, stepMs, respaced, leftReach }));
      return out;
    }

    return {
      Engine,
      segment,
      module: mod,
      version() {
        const v = C.ffseg_version_number();
        return [Math.floor(v / 10000), Math.floor(v / 100) % 100, v % 100];
      },
      statusString: (s) => text(C.ffseg_status_string(s)),
      calls: C,
    };
  }

  /* Instantiates the WebAssembly module and binds it.
   *   factory:    emscripten's createFfsegModule (Node: required from dir)
   *   wasmBinary: the .wasm bytes (Node: read from dir)
   *   dir:        Node only; default FFSEG_WASM_DIR, else build-wasm/ of this tree
   *   name:       "ffseg" (default) or "ffseg_nomalloc" (the malloc-trap build) */
  async function load({ factory, wasmBinary, dir, name = "ffseg" } = {}) {
    const isNode = typeof process === "object" && process.versions && process.versions.node && typeof require === "function";
    if ((!factory || !wasmBinary) && isNode) {
      const path = require("path"), fs = require("fs");
      const d = dir || process.env.FFSEG_WASM_DIR || path.join(__dirname, "..", "..", "build-wasm");
      const js = path.join(d, name + ".js"), wasm = path.join(d, name + ".wasm");
      if (!fs.existsSync(js) || !fs.existsSync(wasm))
        throw new Error(`ffseg: ${js} or ${wasm} is missing; build them with \`make wasm\` (or set FFSEG_WASM_DIR)`);
      factory = factory || require(js);
      wasmBinary = wasmBinary || fs.readFileSync(wasm);
    }
    if (!factory || !wasmBinary) throw new Error("ffseg.load: give factory (createFfsegModule) and wasmBinary");
    // Handing the bytes over keeps emscripten's loader from fetching the file.
    const mod = await factory({ wasmBinary, print: () => {}, printErr: () => {} });
    return bind(mod);
  }

  return {
    load, FfsegError, LAYOUTS, PARAM_NAMES: PARAM_NAMES.map(camel), STAGE_NAMES,
    OK, CONVERGED, DEGENERATE, OBJECT_NO_BOUNDARY, OBJECT_FILLS_GRID, OBJECT_STALLED, STATUS_CODES,
  };
});
