"""ffseg: flipping-free mesh segmentation of 3D volumes, from Python.

A ctypes binding of the C ABI (include/ffseg.h) with numpy arrays; no compiled
extension. The shared library is the one named by the FFSEG_LIBRARY
environment variable, else build/libffseg.so.0 of the source tree this package
sits in, else the installed one (next to this package or on the loader path).

    import ffseg
    e = ffseg.Engine(max_objects=1, mesh_resolution=33)
    e.set_params(target_mode="intensity", step_size=0.5)
    e.set_volume(array, affine)          # array[i, j, k], affine voxel -> mm
    e.init_sphere(0, (x, y, z), radius_mm)
    while not e.step(): pass
    verts, tris = e.extract_mesh(0)
    mask = e.rasterize(0)

Errors raise ffseg.Error, with .status (the C status code) and the engine's
message.
"""
import ctypes as _C
import ctypes.util as _cutil
import os as _os
import warnings as _warnings

import numpy as _np

from . import _abi
from ._abi import (CONVERGED, DEGENERATE, OBJECT_FILLS_GRID, OBJECT_NO_BOUNDARY, OBJECT_STALLED,  # noqa: F401
                   OK, STAGE_NAMES, TARGET_BINARY, TARGET_INTENSITY)

__all__ = ["Engine", "Error", "VolumeError", "StepInfo", "segment", "workspace_sizing", "library_path", "version",
           "param_names", "TARGET_BINARY", "TARGET_INTENSITY", "STAGE_NAMES", "DEGENERATE",
           "OBJECT_NO_BOUNDARY", "OBJECT_FILLS_GRID", "OBJECT_STALLED"]


class Error(Exception):
    """An ffseg call failed: .status is the C status code (< 0), .name its
    FFSEG_ERR_* name without the prefix, .message the engine's message."""

    def __init__(self, status, message, call=None):
        self.status = int(status)
        self.name = _abi.STATUS_NAMES.get(self.status, "UNKNOWN")
        self.message = message
        self.call = call
        where = f"{call}: " if call else ""
        super().__init__(f"{where}{message} [{self.name}, status {self.status}]")


class VolumeError(Error, ValueError):
    """An array set_volume cannot read as it is (status INVALID_VOLUME): also a
    ValueError, so numpy-style code that catches that sees it too."""

    def __init__(self, message):
        super().__init__(-5, message, "set_volume")


# ---- the library ---------------------------------------------------------------

def _candidates():
    env = _os.environ.get("FFSEG_LIBRARY")
    if env:
        return [env], True
    here = _os.path.dirname(_os.path.abspath(__file__))
    out = []
    # The source tree: bindings/python/ffseg -> the repository root.
    root = _os.path.normpath(_os.path.join(here, "..", "..", ".."))
    out.append(_os.path.join(root, "build", "libffseg.so.0"))
    try:  # written by `make install`: the installed library's path
        from ._install import LIBRARY  # type: ignore
        out.append(LIBRARY)
    except ImportError:
        pass
    found = _cutil.find_library("ffseg")
    out.append(found or "libffseg.so.0")
    return out, False


def _load():
    paths, explicit = _candidates()
    errors = []
    for p in paths:
        if _os.path.sep in p and not _os.path.exists(p):
            errors.append(f"{p}: no such file")
            continue
        try:
            return _abi.bind(_C.CDLL(p)), p
        except OSError as ex:
            errors.append(f"{p}: {ex}")
    how = "FFSEG_LIBRARY" if explicit else "looked for"
    raise ImportError("ffseg: cannot load the shared library (" + how + ": " + "; ".join(errors) +
                      "). Build it with `make` or set FFSEG_LIBRARY to libffseg.so.0")


_lib, library_path = _load()


def version():
    """The library's version as (major, minor, patch)."""
    v = _lib.ffseg_version_number()
    return (v // 10000, v // 100 % 100, v % 100)


def _status_text(status):
    s = _lib.ffseg_status_string(status)
    return s.decode() if s else "unknown status"


def _check(status, call, engine=None):
    if status < 0:
        msg = _lib.ffseg_last_error(engine)
        msg = msg.decode(errors="replace") if msg else ""
        raise Error(status, msg or _status_text(status), call)
    return status


_PARAM_FIELDS = [n for n, _ in _abi.Params._fields_ if n != "struct_size"]


def param_names():
    """Every ffseg_params field settable with Engine.set_params / segment."""
    return list(_PARAM_FIELDS)


def _default_params():
    p = _abi.Params()
    _lib.ffseg_params_init_default(_C.byref(p))
    p.struct_size = _C.sizeof(p)
    return p


# ---- voxel types ----------------------------------------------------------------

_DTYPES = {
    _np.dtype(_np.uint8): _abi.U8, _np.dtype(_np.int16): _abi.I16,
    _np.dtype(_np.uint16): _abi.U16, _np.dtype(_np.int32): _abi.I32,
    _np.dtype(_np.float32): _abi.F32, _np.dtype(_np.float64): _abi.F64,
}


def _volume_descriptor(array, affine, rescale_slope, rescale_intercept):
    """An ffseg_volume viewing `array` in place (no copy): its strides as they
    are (negative, padded or unaligned are all fine), the readable span
    computed from them."""
    if not isinstance(array, _np.ndarray):
        raise VolumeError("the volume must be a numpy.ndarray (got %s)" % type(array).__name__)
    if array.ndim != 3:
        raise VolumeError(f"the volume must be 3-D (array[i, j, k]), got {array.ndim}-D shape {array.shape}")
    dt = array.dtype
    if dt.byteorder not in ("=", "|") and dt != dt.newbyteorder("="):
        raise VolumeError(f"the volume's dtype {dt.str} is not in native byte order; "
                         "use array.astype(array.dtype.newbyteorder('='))")
    code = _DTYPES.get(_np.dtype(dt.type) if dt.isnative else None)
    if code is None or not dt.isnative:
        raise VolumeError(f"unsupported voxel dtype {dt} (supported: uint8, int16, uint16, "
                         "int32, float32, float64; convert with array.astype(...))")
    if array.size == 0:
        raise VolumeError(f"the volume is empty (shape {array.shape})")
    A = _np.asarray(affine, dtype=_np.float64)
    if A.shape != (4, 4):
        raise VolumeError(f"the affine must be 4x4, got shape {A.shape}")
    item = dt.itemsize
    base = array.__array_interface__["data"][0]
    lo = hi = 0
    for n, s in zip(array.shape, array.strides):
        span = (n - 1) * s
        lo += min(0, span)
        hi += max(0, span)
    v = _abi.Volume()
    v.struct_size = _C.sizeof(v)
    v.voxel_type = code
    v.data = base + lo
    v.data_bytes = hi - lo + item
    v.offset = -lo
    for a in range(3):
        v.dims[a] = array.shape[a]
        v.strides[a] = array.strides[a]
    for k, x in enumerate(A.reshape(16)):
        v.index_to_world[k] = float(x)
    v.rescale_slope = float(rescale_slope)
    v.rescale_intercept = float(rescale_intercept)
    return v


# ---- the engine -----------------------------------------------------------------

class StepInfo:
    """What one ffseg_step reported: step_index, active_objects, per-object
    lists (mean_displacement_mm, vertices_with_target, flips_avoided,
    intersections_avoided, border_vertices, object_flags, guard_held, far_outward,
    far_inward, respaced (1: the mesh re-spaced its loops that step; 0.8.0); one entry per object, at most 16), flags_all (every object's OBJECT_* flags or-ed; non-zero: some
    result is no segmentation) and stage_us, a dict of microseconds by stage name."""

    def __init__(self, raw, objects):
        n = min(objects, _abi.REPORT_OBJECTS)
        self.step_index = raw.step_index
        self.active_objects = raw.active_objects
        for f in ("mean_displacement_mm", "vertices_with_target", "flips_avoided",
                  "intersections_avoided", "border_vertices", "object_flags", "guard_held",
                  "far_outward", "far_inward", "respaced"):
            setattr(self, f, list(getattr(raw, f))[:n])
        self.flags_all = int(raw.flags_all)
        self.stage_us = {name: int(raw.stage_us[i]) for i, name in enumerate(STAGE_NAMES)}

    def __repr__(self):
        return (f"StepInfo(step_index={self.step_index}, mean_displacement_mm="
                f"{self.mean_displacement_mm}, stage_us={self.stage_us})")


class Engine:
    """One ffseg engine inside a 64-byte aligned workspace it owns.

    Engine(max_objects=1, mesh_resolution=33, max_roi_voxels=None,
    max_region_voxels=None): the ffseg_config fields (None keeps the
    library's default; workspace_sizing() gives the tool's). Use from one
    thread at a time; distinct engines may run in parallel."""

    def __init__(self, max_objects=1, mesh_resolution=33, max_roi_voxels=None, max_region_voxels=None):
        cfg = _abi.Config()
        _lib.ffseg_config_init_default(_C.byref(cfg))
        cfg.struct_size = _C.sizeof(cfg)
        cfg.max_objects = _u32(max_objects, "max_objects")
        cfg.mesh_resolution = _u32(mesh_resolution, "mesh_resolution")
        if max_roi_voxels is not None:
            cfg.max_roi_voxels = int(max_roi_voxels)
        if max_region_voxels is not None:
            cfg.max_region_voxels = int(max_region_voxels)
        self._e = None
        nbytes = _C.c_size_t(0)
        _check(_lib.ffseg_workspace_size(_C.byref(cfg), _C.byref(nbytes)), "ffseg_workspace_size")
        self.workspace_bytes = nbytes.value
        self._buf = _np.empty(self.workspace_bytes + 64, dtype=_np.uint8)
        addr = self._buf.ctypes.data
        self._ws = addr + (-addr) % 64
        e = _C.c_void_p()
        _check(_lib.ffseg_create(_C.byref(cfg), _C.c_void_p(self._ws), self.workspace_bytes,
                                 _C.byref(e)), "ffseg_create")
        self._e = e
        self.config = {"max_objects": cfg.max_objects, "mesh_resolution": cfg.mesh_resolution,
                       "max_roi_voxels": cfg.max_roi_voxels, "max_region_voxels": cfg.max_region_voxels}
        self._params = _default_params()
        self._volume = None  # the array the engine reads: kept alive here
        self._shape = None
        self.last_step_info = None
        self.last_status = None  # the last step's status: OK, CONVERGED or DEGENERATE

    # lifetime
    def close(self):
        """Ends the engine (its workspace is freed with this object)."""
        if self._e is not None:
            _lib.ffseg_destroy(self._e)
            self._e = None
        self._volume = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def _handle(self):
        if self._e is None:
            raise Error(-8, "the engine was closed", "Engine")
        return self._e

    # parameters
    @property
    def params(self):
        """The current parameters as a dict (field name -> value)."""
        return {n: getattr(self._params, n) for n in _PARAM_FIELDS}

    def set_params(self, **fields):
        """Sets ffseg_params fields by name (target_mode also takes "binary" or
        "intensity"); the others keep their values. On an error nothing
        changes and the message names the field."""
        p = _abi.Params()
        _C.pointer(p)[0] = self._params
        for name, value in fields.items():
            if name not in _PARAM_FIELDS:
                raise Error(-1, f"unknown parameter '{name}' (known: {', '.join(_PARAM_FIELDS)})",
                            "set_params")
            if name == "target_mode" and isinstance(value, str):
                if value not in _abi.TARGET_MODES:
                    raise Error(-1, f"target_mode: expected 'binary' or 'intensity', got '{value}'",
                                "set_params")
                value = _abi.TARGET_MODES[value]
            ctype = dict(_abi.Params._fields_)[name]
            try:
                if ctype is _C.c_uint32:
                    iv = int(value)
                    if iv != value or not 0 <= iv <= 0xFFFFFFFF:
                        raise ValueError
                    setattr(p, name, iv)
                else:
                    setattr(p, name, float(value))
            except (TypeError, ValueError):
                raise Error(-1, f"{name}: {value!r} is not a valid "
                            f"{'integer 0..2^32-1' if ctype is _C.c_uint32 else 'number'}",
                            "set_params") from None
        _check(_lib.ffseg_set_params(self._handle(), _C.byref(p)), "ffseg_set_params", self._e)
        self._params = p

    # the volume
    def set_volume(self, array, affine, rescale_slope=1.0, rescale_intercept=0.0):
        """The volume the objects deform in: array[i, j, k] (nibabel's index
        order) of uint8, int16, uint16, int32, float32 or float64, any strides,
        used in place (the engine keeps a reference, never writes it; do not
        change it while stepping); affine: 4x4 voxel centre -> world mm;
        value = rescale_slope * stored + rescale_intercept."""
        v = _volume_descriptor(array, affine, rescale_slope, rescale_intercept)
        try:
            _check(_lib.ffseg_set_volume(self._handle(), _C.byref(v)), "ffseg_set_volume", self._e)
        except Error as ex:
            if ex.status == -5:
                raise VolumeError(ex.message) from None
            raise
        self._volume = array
        self._shape = tuple(array.shape)

    def sample(self, point_mm, linear=True):
        """The rescaled intensity at a world point (trilinear or nearest)."""
        pt = (_C.c_double * 3)(*map(float, point_mm))
        out = _C.c_double(0)
        _check(_lib.ffseg_sample(self._handle(), pt, 1 if linear else 0, _C.byref(out)),
               "ffseg_sample", self._e)
        return out.value

    # objects
    def init_sphere(self, obj, center_mm, radius_mm):
        """Places object `obj`'s mesh on a sphere (world mm)."""
        c = tuple(map(float, center_mm))
        if len(c) != 3:
            raise Error(-1, f"the centre needs 3 coordinates, got {len(c)}", "init_sphere")
        _check(_lib.ffseg_init_sphere(self._handle(), _u32(obj, "object"), (_C.c_double * 3)(*c),
                                      float(radius_mm)), "ffseg_init_sphere", self._e)

    def init_mesh(self, obj, center_mm, radius_mm, vertices):
        """Places object `obj`'s mesh from another engine's (coarse to fine):
        `vertices` is an (6 n^2, 3) array as extract_mesh returns it, from an
        engine of any mesh resolution n; it is resampled to this engine's.
        The grey-level model comes from the sphere (center_mm, radius_mm), as
        init_sphere's does: give the sphere the mesh grew from."""
        c = tuple(map(float, center_mm))
        if len(c) != 3:
            raise Error(-1, f"the centre needs 3 coordinates, got {len(c)}", "init_mesh")
        v = _np.ascontiguousarray(vertices, dtype=_np.float32)
        if v.ndim != 2 or v.shape[1] != 3:
            raise Error(-1, f"vertices must be an (N, 3) array, got shape {v.shape}", "init_mesh")
        _check(_lib.ffseg_init_mesh(self._handle(), _u32(obj, "object"), (_C.c_double * 3)(*c),
                                    float(radius_mm), v.ctypes.data_as(_C.POINTER(_C.c_float)), v.shape[0]),
               "ffseg_init_mesh", self._e)

    def step(self):
        """One deformation step of every placed object; True once every object
        has come to rest: converged, or DEGENERATE (.last_status), when some
        object's result is no segmentation or only part of one
        (.last_step_info.object_flags: OBJECT_NO_BOUNDARY, OBJECT_FILLS_GRID,
        OBJECT_STALLED). The step's report is in
        .last_step_info (StepInfo)."""
        raw = _abi.StepInfo()
        raw.struct_size = _C.sizeof(raw)
        st = _check(_lib.ffseg_step(self._handle(), _C.byref(raw)), "ffseg_step", self._e)
        self.last_step_info = StepInfo(raw, self.config["max_objects"])
        self.last_status = st
        return st in (CONVERGED, DEGENERATE)

    def extract_mesh(self, obj):
        """(vertices, triangles): (N, 3) float32 world mm and (M, 3) uint32,
        counter-clockwise seen from outside."""
        h = self._handle()
        o = _u32(obj, "object")
        nv, nt = _C.c_size_t(0), _C.c_size_t(0)
        _check(_lib.ffseg_extract_mesh(h, o, None, 0, None, 0, _C.byref(nv), _C.byref(nt)),
               "ffseg_extract_mesh", h)
        xyz = _np.empty((nv.value, 3), dtype=_np.float32)
        tris = _np.empty((nt.value, 3), dtype=_np.uint32)
        _check(_lib.ffseg_extract_mesh(
            h, o, xyz.ctypes.data_as(_C.POINTER(_C.c_float)), nv.value,
            tris.ctypes.data_as(_C.POINTER(_C.c_uint32)), nt.value, _C.byref(nv), _C.byref(nt)),
            "ffseg_extract_mesh", h)
        return xyz, tris

    def rasterize(self, obj, out=None):
        """uint8 mask shaped like the volume: 1 where the voxel centre lies
        inside the object's mesh. `out`: an optional writable uint8 array of
        that shape (any strides) to fill instead."""
        return self._mask("rasterize", obj, out)

    def region_mask(self, obj, out=None):
        """uint8 mask shaped like the volume: 1 where the object owns the
        voxel's bounding region (thesis 6.2, fig. 6.4; the regions of distinct
        objects never overlap). Regions exist once step() has run with two or
        more objects placed; before that, and in a one-object engine, this
        raises Error (FFSEG_ERR_MISUSE). `out` as for rasterize."""
        return self._mask("region_mask", obj, out)

    def _mask(self, what, obj, out):
        h = self._handle()
        if self._shape is None:
            raise Error(-8, "no volume: call set_volume first", what)
        if out is None:
            out = _np.zeros(self._shape, dtype=_np.uint8)
        elif (not isinstance(out, _np.ndarray) or out.dtype != _np.uint8 or
              tuple(out.shape) != self._shape or not out.flags.writeable):
            raise Error(-1, f"out must be a writable uint8 array of shape {self._shape}", what)
        strides = (_C.c_int64 * 3)(*out.strides)
        ptr = _C.cast(_C.c_void_p(out.__array_interface__["data"][0]), _C.POINTER(_C.c_uint8))
        fn = getattr(_lib, "ffseg_" + what)
        _check(fn(h, _u32(obj, "object"), ptr, strides), "ffseg_" + what, h)
        return out


def _u32(x, what):
    try:
        v = int(x)
    except (TypeError, ValueError):
        raise Error(-1, f"{what}: {x!r} is not an integer") from None
    if v != x or not 0 <= v <= 0xFFFFFFFF:
        raise Error(-1, f"{what}: {x!r} is outside 0..2^32-1")
    return v


DEFAULT_MEMORY_BYTES = 400 * 10**6  # the tool's --memory default


# The largest crop the tool sizes to the whole scan (tools/cli: kMaxRoiCap).
ROI_CAP = 1 << 26


def workspace_sizing(max_objects, mesh_resolution, voxels, target_mode="intensity", max_roi_voxels=None,
                     max_region_voxels=None, memory_bytes=DEFAULT_MEMORY_BYTES, roi_cap=ROI_CAP):
    """The `ffseg segment` tool's sizes (tools/cli/workspace_budget.h) for an
    engine of max_objects objects on a scan of `voxels` voxels: crops and
    regions hold the whole scan (at most roi_cap) when that workspace fits
    memory_bytes; else regions get an eighth of a crop's voxels (marched on
    cells); else the crops shrink to the largest that fits. Given values are
    kept. Returns (max_roi_voxels, max_region_voxels, workspace_bytes)."""
    cfg = _abi.Config()
    _lib.ffseg_config_init_default(_C.byref(cfg))
    cfg.struct_size = _C.sizeof(cfg)
    cfg.max_objects = _u32(max_objects, "max_objects")
    cfg.mesh_resolution = _u32(mesh_resolution, "mesh_resolution")
    cfg.target_mode = 0 if target_mode in ("binary", 0) else 1

    def size(roi, region):
        cfg.max_roi_voxels, cfg.max_region_voxels = int(roi), int(region)
        n = _C.c_size_t(0)
        _check(_lib.ffseg_workspace_size(_C.byref(cfg), _C.byref(n)), "ffseg_workspace_size")
        return n.value

    def region_for(roi, coarse):
        if max_region_voxels is not None:
            return int(max_region_voxels)
        return max(roi // 8, 1) if coarse else roi

    crop = int(max_roi_voxels) if max_roi_voxels is not None else min(int(voxels), roi_cap)
    for coarse in (False, True):
        if coarse and max_region_voxels is not None:
            break
        b = size(crop, region_for(crop, coarse))
        if b <= memory_bytes:
            return crop, region_for(crop, coarse), b
    if max_roi_voxels is not None:  # the crops were given: the regions coarse, the excess the caller's
        return crop, region_for(crop, True), size(crop, region_for(crop, True))
    lo, hi = 0, crop
    while hi - lo > 1:
        mid = lo + (hi - lo) // 2
        if size(mid, region_for(mid, True)) <= memory_bytes:
            lo = mid
        else:
            hi = mid
    lo = max(lo, 1)
    return lo, region_for(lo, True), size(lo, region_for(lo, True))


def segment(array, affine, spheres, target_mode="intensity", mesh_resolution=33, max_steps=200,
            max_roi_voxels=None, rescale_slope=1.0, rescale_intercept=0.0, return_meshes=False,
            max_region_voxels=None, memory_bytes=DEFAULT_MEMORY_BYTES, **params):
    """One call: every sphere ((x, y, z), radius_mm) grows into an object.

    The defaults are the `ffseg segment` tool's (grey-level target, n = 33,
    200 steps, crop and region budgets from memory_bytes as its --memory,
    workspace_sizing()), and it makes the tool's runs for --mesh-resolution n
    (above 12: a first run at 12, then n from its meshes, coarse to fine;
    _segment_once), so the same inputs give the tool's masks
    voxel for voxel. memory_bytes is where the workspace starts: an object that outgrows
    the crop or region it gives makes the run start again with twice it (a
    RuntimeWarning says so); max_roi_voxels / max_region_voxels given are
    fixed sizes (Error ROI_TOO_LARGE). **params: any ffseg_params field.
    Returns one uint8 mask per sphere (and the meshes with return_meshes)."""
    spheres = list(spheres)
    if not spheres:
        raise Error(-1, "no sphere given", "segment")
    # As the tool: memory_bytes is where the workspace starts; an object that
    # outgrows the sizes it gave makes the run start again with twice it.
    # Sizes given here are fixed (ROI_TOO_LARGE is raised).
    voxels = int(_np.prod(_np.shape(array)))
    given = max_roi_voxels is not None or max_region_voxels is not None
    while True:
        roi, region, _ = workspace_sizing(len(spheres), mesh_resolution, voxels, target_mode, max_roi_voxels,
                                          max_region_voxels, memory_bytes)

        def sizes(n, budget=memory_bytes):  # each run's engine sized as the tool sizes it, by its own n
            return workspace_sizing(len(spheres), n, voxels, target_mode, max_roi_voxels, max_region_voxels,
                                    budget)[:2]
        try:
            return _segment_once(array, affine, spheres, target_mode, mesh_resolution, max_steps, sizes,
                                 rescale_slope, rescale_intercept, return_meshes, params)
        except Error as ex:
            whole = min(voxels, ROI_CAP)
            if ex.name != "ROI_TOO_LARGE" or given or (roi >= whole and region >= whole):
                raise
            memory_bytes *= 2
            _warnings.warn(f"ffseg.segment: an object outgrew the memory budget ({ex.message}); starting again "
                           f"with memory_bytes = {memory_bytes}", RuntimeWarning, stacklevel=2)


# The tool's coarse to fine (tools/cli/cmd_segment.cpp, run_engine_once): a
# resolution above FIRST_RESOLUTION first runs at it, and the finer run
# starts from its meshes, a refused one tried again scaled about its centroid
# by FIRST_RUN_SCALES before its sphere.
FIRST_RESOLUTION = 12
FIRST_RUN_SCALES = (1.0, 0.99, 0.98, 0.95)


def _scaled_about_centroid(xyz, f):
    """The tool's scaled_about_centroid(), to the bit: the vertices' mean
    summed in order in double, each coordinate rounded to float32 once."""
    v = _np.asarray(xyz, _np.float32).reshape(-1, 3)
    if f == 1.0:
        return v
    c = [0.0, 0.0, 0.0]
    for x, y, z in v.tolist():
        c[0] += x
        c[1] += y
        c[2] += z
    c = _np.array(c) / len(v)
    return (c + f * (v.astype(_np.float64) - c)).astype(_np.float32)


def _refinement_reach_mm3(xyz, tris):
    """The tool's refinement_reach_mm3() (tools/cli/refinement_reach.h): the
    volume a first-run mesh encloses plus its area times its mean quad side,
    the most a finer run from it may enclose and still refine it."""
    return _enclosed_volume_mm3(xyz, tris) + _area_times_mean_side(xyz, tris)


def _enclosed_volume_mm3(xyz, tris):
    v = _np.asarray(xyz, _np.float64)[_np.asarray(tris, _np.int64)]
    a, b, c = v[:, 0], v[:, 1], v[:, 2]
    return float(_np.sum(_np.einsum("ij,ij->i", a, _np.cross(b, c)))) / 6.0


def _area_times_mean_side(xyz, tris):
    v = _np.asarray(xyz, _np.float64)[_np.asarray(tris, _np.int64)]
    area = 0.5 * float(_np.sum(_np.linalg.norm(_np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)))
    edges = _np.sort(_np.linalg.norm(v[:, [1, 2, 0]] - v, axis=2), axis=1)[:, :2]  # the quad sides
    return area * float(edges.mean()) if len(edges) else 0.0


def _segment_once(array, affine, spheres, target_mode, mesh_resolution, max_steps, sizes,
                  rescale_slope, rescale_intercept, return_meshes, params):
    """The runs `ffseg segment --mesh-resolution n` makes: at n = 12 and below
    one run from the spheres; above it a first run at n = 12, then n from its
    meshes (a refused one scaled about its centroid, else from its sphere,
    the larger organs placed first); an
    object that stalls at n where its first run did not is put back on its
    n = 12 surface, and where that is refused the first run goes on at 12
    from its meshes instead. One object's finer run re-spaces its loops while
    it encloses no more than its first run's reach, and is made again without
    when it leaves it (tools/cli/refinement_reach.h). Each run in an engine of its own, sized by sizes(n) ->
    (max_roi_voxels, max_region_voxels)."""
    k = len(spheres)

    def engine(n, respacing=False):
        roi, region = sizes(n)
        e = Engine(max_objects=k, mesh_resolution=n, max_roi_voxels=roi, max_region_voxels=region)
        e.set_params(target_mode=target_mode, **dict(params, **({"grey_respacing": 1} if respacing else {})))
        e.set_volume(array, affine, rescale_slope, rescale_intercept)
        return e

    grew_freely = []  # the first run's first step re-spaced each object: its boundary in view

    def to_rest(e, reach=None):
        """Steps e to rest; with reach, None as soon as some object encloses
        more than its reach (e closed)."""
        for s in range(int(max_steps)):
            rested = e.step()
            if s == 0 and not grew_freely:
                grew_freely.extend(bool(r) for r in e.last_step_info.respaced[:k])
            if reach is not None and any(_enclosed_volume_mm3(*e.extract_mesh(j)) > reach[j] for j in range(k)):
                e.close()
                return None
            if rested:
                break
        return e

    def stalled(e):
        info = e.last_step_info
        flags = info.object_flags if info is not None else []
        return [j < len(flags) and bool(flags[j] & OBJECT_STALLED) for j in range(k)]

    def voxels(e):
        return [int(_np.count_nonzero(e.rasterize(j))) for j in range(k)]

    def from_spheres(n):
        e = engine(n)
        for j, (centre, radius) in enumerate(spheres):
            e.init_sphere(j, centre, radius)
        return to_rest(e)

    def placed(n, starts, order, respacing=False):
        """An engine at n with object j placed from the first of starts[j] it
        takes, else its sphere, in `order`; None when a sphere is refused."""
        e = engine(n, respacing)
        for j in order:
            centre, radius = spheres[j]
            for v in starts[j]:
                try:
                    e.init_mesh(j, centre, radius, v)
                    break
                except Error:
                    pass
            else:
                try:
                    e.init_sphere(j, centre, radius)
                except Error:
                    e.close()
                    return None
                if respacing:  # as the tool: the reach bounds a refinement, not a growth from the sphere
                    e.set_params(**dict(params, grey_respacing=0))  # (the others keep their values)
                    respacing = False
                    from_sphere.append(j)
        return e

    if int(mesh_resolution) <= FIRST_RESOLUTION:
        final = from_spheres(mesh_resolution)
    else:
        first = from_spheres(FIRST_RESOLUTION)
        coarse_meshes = [first.extract_mesh(j) for j in range(k)]
        coarse = [m[0] for m in coarse_meshes]
        # As the tool: one object's finer run re-spaces within its first
        # run's reach, and is made again without when it leaves it.
        respacing = (k == 1 and not grew_freely[0] and int(params.get("grey_respacing", 0)) == 0
                     and target_mode not in ("binary", TARGET_BINARY))
        reach = [_refinement_reach_mm3(*m) for m in coarse_meshes]
        coarse_stalled, coarse_voxels = stalled(first), voxels(first)
        first.close()
        order = sorted(range(k), key=lambda j: -coarse_voxels[j])  # stable: ties in index order
        def scaled(v):  # each scale computed only when the one before was refused
            return (_scaled_about_centroid(v, f) for f in FIRST_RUN_SCALES)
        from_sphere = []
        e = placed(mesh_resolution, [scaled(coarse[j]) for j in range(k)], order, respacing)
        rested = None
        if e is not None and respacing and not from_sphere:
            rested = to_rest(e, reach)
            if rested is None:  # it left its reach: the finer run again without re-spacing
                e = placed(mesh_resolution, [scaled(coarse[j]) for j in range(k)], order)
        lost = None
        if e is None:  # some object: neither its first-run mesh nor its sphere beside the others' meshes
            lost = f"some object cannot be placed at mesh resolution {mesh_resolution} beside the others' meshes"
        else:
            final = rested if rested is not None else to_rest(e)
            still = stalled(final)
            for j, (centre, radius) in enumerate(spheres):
                if still[j] and not coarse_stalled[j]:
                    try:
                        final.init_mesh(j, centre, radius, coarse[j])
                    except Error as ex:
                        if lost is None:
                            lost = (f"object {j} stalled at mesh resolution {mesh_resolution} and cannot be put "
                                    f"back on its first-run surface there ({ex.message})")
            if lost is not None:
                final.close()
        if lost is not None:
            # As the tool: the finer run is given up and the first run goes
            # on at its own resolution from its meshes.
            _warnings.warn(f"ffseg.segment: {lost}; the first run goes on at resolution {FIRST_RESOLUTION} instead",
                           RuntimeWarning, stacklevel=3)
            e = placed(FIRST_RESOLUTION, [scaled(coarse[j]) for j in range(k)], order)
            if e is None:
                raise Error(-1, "no start for some object beside the others' first-run meshes", "segment")
            final = to_rest(e)
    with final as e:
        flags = getattr(e, "last_step_info", None)
        if flags is not None and flags.flags_all:
            _warnings.warn("ffseg.segment: some result is no segmentation (object_flags "
                           f"{flags.object_flags}: 1 = no vertex ever found a boundary, "
                           "2 = the object fills most of the grid, 4 = it stalled short of its "
                           "boundary)", RuntimeWarning, stacklevel=3)
        masks = [e.rasterize(j) for j in range(k)]
        if return_meshes:
            return masks, [e.extract_mesh(j) for j in range(k)]
        return masks
