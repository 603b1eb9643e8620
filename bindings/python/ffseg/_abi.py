"""ctypes mirror of include/ffseg.h: constants, structs and call signatures.

The struct layouts are checked against the C compiler's sizes and offsets by
tests/test_abi.py (through the ffseg_abi_layout program CMake builds), so a
field appended to a struct in ffseg.h fails a test until it is added here.
Every struct is passed with struct_size = ctypes.sizeof(it): the library reads
min(struct_size, its own size) and fills the rest with defaults, so an older
mirror is never misread -- it just cannot set the new fields.
"""
import ctypes as C

OK = 0
CONVERGED = 1
DEGENERATE = 2  # at rest, but some object's result is no segmentation (object_flags)
OBJECT_NO_BOUNDARY = 1
OBJECT_FILLS_GRID = 2
OBJECT_STALLED = 4  # since 0.5.0: came to rest short of (or beyond) its boundary

STATUS_NAMES = {
    -1: "INVALID_ARGUMENT", -2: "NULL_POINTER", -3: "WORKSPACE_TOO_SMALL",
    -4: "WORKSPACE_MISALIGNED", -5: "INVALID_VOLUME", -6: "OBJECT_OUT_OF_RANGE",
    -7: "BUFFER_TOO_SMALL", -8: "MISUSE", -9: "NUMERIC", -10: "ROI_TOO_LARGE",
    -11: "SPHERE_OUTSIDE", -12: "STRUCT_SIZE", -13: "CONFIG_TOO_LARGE",
    -14: "NOT_IMPLEMENTED",
}

TARGET_BINARY = 0
TARGET_INTENSITY = 1
TARGET_MODES = {"binary": TARGET_BINARY, "intensity": TARGET_INTENSITY}

U8, I16, U16, I32, F32, F64 = 1, 2, 3, 4, 5, 6

STAGE_NAMES = ("search", "flips", "diffusion", "intersection", "assembly",
               "factor", "solve", "features", "guard", "regions")
STAGE_COUNT = len(STAGE_NAMES)
REPORT_OBJECTS = 16


class Config(C.Structure):
    _fields_ = [
        ("struct_size", C.c_uint32),
        ("max_objects", C.c_uint32),
        ("mesh_resolution", C.c_uint32),
        ("reserved0", C.c_uint32),
        ("max_roi_voxels", C.c_int64),
        ("target_mode", C.c_uint32),
        ("reserved1", C.c_uint32),
        ("max_region_voxels", C.c_int64),  # since 0.6.0
    ]


class Params(C.Structure):
    _fields_ = [
        ("struct_size", C.c_uint32),
        ("target_mode", C.c_uint32),
        ("lambda_laplacian", C.c_double),
        ("lambda_position", C.c_double),
        ("lambda_uniform", C.c_double),
        ("step_size", C.c_double),
        ("flip_tau", C.c_double),
        ("search_range_mm", C.c_double),
        ("search_step_mm", C.c_double),
        ("convergence_mm", C.c_double),
        ("diffusion_iterations", C.c_uint32),
        ("consecutive_background", C.c_uint32),
        ("smoothing_iterations", C.c_uint32),
        ("bin_min_count", C.c_uint32),
        ("smoothing_kappa", C.c_double),
        ("intensity_gamma", C.c_double),
        ("sigma_floor_fraction", C.c_double),
        ("bin_radius", C.c_double),
        ("bin_separation", C.c_double),
        ("partial_volume_steps", C.c_uint32),
        ("reserved1", C.c_uint32),
        ("region_width_mm", C.c_double),
        ("border_weight", C.c_double),
        ("region_interval", C.c_uint32),
        ("grey_respacing", C.c_uint32),  # since 0.7.0 (reserved2 before); 0 automatic since 0.8.0
    ]


class Volume(C.Structure):
    _fields_ = [
        ("struct_size", C.c_uint32),
        ("voxel_type", C.c_uint32),
        ("data", C.c_void_p),
        ("data_bytes", C.c_uint64),
        ("offset", C.c_int64),
        ("dims", C.c_int64 * 3),
        ("strides", C.c_int64 * 3),
        ("index_to_world", C.c_double * 16),
        ("rescale_slope", C.c_double),
        ("rescale_intercept", C.c_double),
    ]


class StepInfo(C.Structure):
    _fields_ = [
        ("struct_size", C.c_uint32),
        ("step_index", C.c_uint32),
        ("active_objects", C.c_uint32),
        ("reserved0", C.c_uint32),
        ("mean_displacement_mm", C.c_double * REPORT_OBJECTS),
        ("vertices_with_target", C.c_uint32 * REPORT_OBJECTS),
        ("flips_avoided", C.c_uint32 * REPORT_OBJECTS),
        ("intersections_avoided", C.c_uint32 * REPORT_OBJECTS),
        ("border_vertices", C.c_uint32 * REPORT_OBJECTS),
        ("stage_us", C.c_uint64 * STAGE_COUNT),
        ("object_flags", C.c_uint32 * REPORT_OBJECTS),
        ("flags_all", C.c_uint32),
        ("reserved1", C.c_uint32),
        ("guard_held", C.c_uint32 * REPORT_OBJECTS),
        ("far_outward", C.c_uint32 * REPORT_OBJECTS),
        ("far_inward", C.c_uint32 * REPORT_OBJECTS),
        ("respaced", C.c_uint32 * REPORT_OBJECTS),  # since 0.8.0
    ]


# The C struct names, for the layout check.
STRUCTS = {"ffseg_config": Config, "ffseg_params": Params,
           "ffseg_volume": Volume, "ffseg_step_info": StepInfo}


def bind(lib):
    """Declares every call's argument and result types on the loaded library."""
    P = C.POINTER
    st = C.c_int32
    sig = {
        "ffseg_version_number": (C.c_uint32, []),
        "ffseg_status_string": (C.c_char_p, [st]),
        "ffseg_last_error": (C.c_char_p, [C.c_void_p]),
        "ffseg_config_init_default": (None, [P(Config)]),
        "ffseg_workspace_size": (st, [P(Config), P(C.c_size_t)]),
        "ffseg_create": (st, [P(Config), C.c_void_p, C.c_size_t, P(C.c_void_p)]),
        "ffseg_destroy": (None, [C.c_void_p]),
        "ffseg_params_init_default": (None, [P(Params)]),
        "ffseg_set_params": (st, [C.c_void_p, P(Params)]),
        "ffseg_set_volume": (st, [C.c_void_p, P(Volume)]),
        "ffseg_sample": (st, [C.c_void_p, P(C.c_double), C.c_uint32, P(C.c_double)]),
        "ffseg_init_sphere": (st, [C.c_void_p, C.c_uint32, P(C.c_double), C.c_double]),
        "ffseg_init_mesh": (st, [C.c_void_p, C.c_uint32, P(C.c_double), C.c_double, P(C.c_float),
                                 C.c_size_t]),
        "ffseg_step": (st, [C.c_void_p, P(StepInfo)]),
        "ffseg_extract_mesh": (st, [C.c_void_p, C.c_uint32, P(C.c_float), C.c_size_t,
                                    P(C.c_uint32), C.c_size_t, P(C.c_size_t), P(C.c_size_t)]),
        "ffseg_rasterize": (st, [C.c_void_p, C.c_uint32, P(C.c_uint8), P(C.c_int64)]),
        "ffseg_region_mask": (st, [C.c_void_p, C.c_uint32, P(C.c_uint8), P(C.c_int64)]),
    }
    for name, (res, args) in sig.items():
        f = getattr(lib, name)
        f.restype = res
        f.argtypes = args
    return lib
