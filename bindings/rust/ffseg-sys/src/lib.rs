//! Raw declarations of ffseg's C ABI, `include/ffseg.h`, one for one: the
//! `#[repr(C)]` structs, the status and mode constants, the functions. Every
//! struct's size and field offsets are checked against the C compiler's by
//! this crate's tests (`tests/layout.rs`). The safe interface is the `ffseg`
//! crate; the contract (units, ownership, what each call writes on failure)
//! is documented in the header.
#![allow(non_camel_case_types)]

use std::ffi::c_void;
use std::os::raw::c_char;

pub type ffseg_status = i32;

pub const FFSEG_VERSION_MAJOR: u32 = 0;
pub const FFSEG_VERSION_MINOR: u32 = 8;
pub const FFSEG_VERSION_PATCH: u32 = 0;
pub const FFSEG_VERSION_NUMBER: u32 =
    FFSEG_VERSION_MAJOR * 10000 + FFSEG_VERSION_MINOR * 100 + FFSEG_VERSION_PATCH;

pub const FFSEG_OK: ffseg_status = 0;
pub const FFSEG_CONVERGED: ffseg_status = 1;
pub const FFSEG_DEGENERATE: ffseg_status = 2;
pub const FFSEG_OBJECT_NO_BOUNDARY: u32 = 1;
pub const FFSEG_OBJECT_FILLS_GRID: u32 = 2;
/// Since 0.5.0: came to rest short of (or beyond) its boundary; the step is DEGENERATE.
pub const FFSEG_OBJECT_STALLED: u32 = 4;
pub const FFSEG_ERR_INVALID_ARGUMENT: ffseg_status = -1;
pub const FFSEG_ERR_NULL_POINTER: ffseg_status = -2;
pub const FFSEG_ERR_WORKSPACE_TOO_SMALL: ffseg_status = -3;
pub const FFSEG_ERR_WORKSPACE_MISALIGNED: ffseg_status = -4;
pub const FFSEG_ERR_INVALID_VOLUME: ffseg_status = -5;
pub const FFSEG_ERR_OBJECT_OUT_OF_RANGE: ffseg_status = -6;
pub const FFSEG_ERR_BUFFER_TOO_SMALL: ffseg_status = -7;
pub const FFSEG_ERR_MISUSE: ffseg_status = -8;
pub const FFSEG_ERR_NUMERIC: ffseg_status = -9;
pub const FFSEG_ERR_ROI_TOO_LARGE: ffseg_status = -10;
pub const FFSEG_ERR_SPHERE_OUTSIDE: ffseg_status = -11;
pub const FFSEG_ERR_STRUCT_SIZE: ffseg_status = -12;
pub const FFSEG_ERR_CONFIG_TOO_LARGE: ffseg_status = -13;
pub const FFSEG_ERR_NOT_IMPLEMENTED: ffseg_status = -14;

pub const FFSEG_TARGET_BINARY: u32 = 0;
pub const FFSEG_TARGET_INTENSITY: u32 = 1;

pub const FFSEG_U8: u32 = 1;
pub const FFSEG_I16: u32 = 2;
pub const FFSEG_U16: u32 = 3;
pub const FFSEG_I32: u32 = 4;
pub const FFSEG_F32: u32 = 5;
pub const FFSEG_F64: u32 = 6;

pub const FFSEG_SAMPLE_NEAREST: u32 = 0;
pub const FFSEG_SAMPLE_LINEAR: u32 = 1;

pub const FFSEG_STAGE_SEARCH: usize = 0;
pub const FFSEG_STAGE_FLIPS: usize = 1;
pub const FFSEG_STAGE_DIFFUSION: usize = 2;
pub const FFSEG_STAGE_INTERSECTION: usize = 3;
pub const FFSEG_STAGE_ASSEMBLY: usize = 4;
pub const FFSEG_STAGE_FACTOR: usize = 5;
pub const FFSEG_STAGE_SOLVE: usize = 6;
pub const FFSEG_STAGE_FEATURES: usize = 7;
pub const FFSEG_STAGE_GUARD: usize = 8;
pub const FFSEG_STAGE_REGIONS: usize = 9;
pub const FFSEG_STAGE_COUNT: usize = 10;
pub const FFSEG_REPORT_OBJECTS: usize = 16;

/// The engine: opaque, it lives inside the caller's workspace.
#[repr(C)]
pub struct ffseg_engine {
    _private: [u8; 0],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ffseg_config {
    pub struct_size: u32,
    pub max_objects: u32,
    pub mesh_resolution: u32,
    pub reserved0: u32,
    pub max_roi_voxels: i64,
    pub target_mode: u32,
    pub reserved1: u32,
    /// Since 0.6.0: several objects, the voxels one bounding region is marched on
    /// (0: max_roi_voxels); a larger box is marched on coarser cells.
    pub max_region_voxels: i64,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ffseg_params {
    pub struct_size: u32,
    pub target_mode: u32,
    pub lambda_laplacian: f64,
    pub lambda_position: f64,
    pub lambda_uniform: f64,
    pub step_size: f64,
    pub flip_tau: f64,
    pub search_range_mm: f64,
    pub search_step_mm: f64,
    pub convergence_mm: f64,
    pub diffusion_iterations: u32,
    pub consecutive_background: u32,
    pub smoothing_iterations: u32,
    pub bin_min_count: u32,
    pub smoothing_kappa: f64,
    pub intensity_gamma: f64,
    pub sigma_floor_fraction: f64,
    pub bin_radius: f64,
    pub bin_separation: f64,
    pub partial_volume_steps: u32,
    pub reserved1: u32,
    pub region_width_mm: f64,
    pub border_weight: f64,
    pub region_interval: u32,
    /// Since 0.7.0 (reserved2 before): grey-level targets re-space their loops until the first rest;
    /// since 0.8.0 0 is automatic (where the boundary is in view), 1 always, 2 never.
    pub grey_respacing: u32,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ffseg_volume {
    pub struct_size: u32,
    pub voxel_type: u32,
    pub data: *const c_void,
    pub data_bytes: u64,
    pub offset: i64,
    pub dims: [i64; 3],
    pub strides: [i64; 3],
    pub index_to_world: [f64; 16],
    pub rescale_slope: f64,
    pub rescale_intercept: f64,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ffseg_step_info {
    pub struct_size: u32,
    pub step_index: u32,
    pub active_objects: u32,
    pub reserved0: u32,
    pub mean_displacement_mm: [f64; FFSEG_REPORT_OBJECTS],
    pub vertices_with_target: [u32; FFSEG_REPORT_OBJECTS],
    pub flips_avoided: [u32; FFSEG_REPORT_OBJECTS],
    pub intersections_avoided: [u32; FFSEG_REPORT_OBJECTS],
    pub border_vertices: [u32; FFSEG_REPORT_OBJECTS],
    pub stage_us: [u64; FFSEG_STAGE_COUNT],
    pub object_flags: [u32; FFSEG_REPORT_OBJECTS],
    pub flags_all: u32,
    pub reserved1: u32,
    // Since 0.5.0 (a 0.4.0 struct_size ends before these).
    pub guard_held: [u32; FFSEG_REPORT_OBJECTS],
    pub far_outward: [u32; FFSEG_REPORT_OBJECTS],
    pub far_inward: [u32; FFSEG_REPORT_OBJECTS],
    // Since 0.8.0 (a 0.5-0.7 struct_size ends before this).
    pub respaced: [u32; FFSEG_REPORT_OBJECTS],
}

impl Default for ffseg_config {
    /// `ffseg_config_init_default`: the library's defaults, struct_size set.
    fn default() -> Self {
        let mut c = std::mem::MaybeUninit::<ffseg_config>::zeroed();
        unsafe {
            ffseg_config_init_default(c.as_mut_ptr());
            c.assume_init()
        }
    }
}

impl Default for ffseg_params {
    /// `ffseg_params_init_default`: the library's defaults, struct_size set.
    fn default() -> Self {
        let mut p = std::mem::MaybeUninit::<ffseg_params>::zeroed();
        unsafe {
            ffseg_params_init_default(p.as_mut_ptr());
            p.assume_init()
        }
    }
}

impl Default for ffseg_step_info {
    /// All zero but struct_size, as ffseg_step wants it.
    fn default() -> Self {
        // Plain integers and floats: all-zero bytes are a valid value.
        let mut s: ffseg_step_info = unsafe { std::mem::zeroed() };
        s.struct_size = std::mem::size_of::<ffseg_step_info>() as u32;
        s
    }
}

extern "C" {
    pub fn ffseg_version_number() -> u32;
    pub fn ffseg_status_string(s: ffseg_status) -> *const c_char;
    pub fn ffseg_last_error(e: *const ffseg_engine) -> *const c_char;

    pub fn ffseg_config_init_default(c: *mut ffseg_config);
    pub fn ffseg_workspace_size(c: *const ffseg_config, bytes: *mut usize) -> ffseg_status;
    pub fn ffseg_create(
        c: *const ffseg_config,
        workspace: *mut c_void,
        bytes: usize,
        out: *mut *mut ffseg_engine,
    ) -> ffseg_status;
    pub fn ffseg_destroy(e: *mut ffseg_engine);

    pub fn ffseg_params_init_default(p: *mut ffseg_params);
    pub fn ffseg_set_params(e: *mut ffseg_engine, p: *const ffseg_params) -> ffseg_status;

    pub fn ffseg_set_volume(e: *mut ffseg_engine, v: *const ffseg_volume) -> ffseg_status;
    pub fn ffseg_sample(
        e: *const ffseg_engine,
        point_mm: *const f64,
        mode: u32,
        value: *mut f64,
    ) -> ffseg_status;

    pub fn ffseg_init_sphere(
        e: *mut ffseg_engine,
        object: u32,
        center_mm: *const f64,
        radius_mm: f64,
    ) -> ffseg_status;
    /// Since 0.5.0. `xyz`: `n_vertices` * 3 floats, a cube-sphere mesh as
    /// `ffseg_extract_mesh` writes it, of any resolution.
    pub fn ffseg_init_mesh(
        e: *mut ffseg_engine,
        object: u32,
        center_mm: *const f64,
        radius_mm: f64,
        xyz: *const f32,
        n_vertices: usize,
    ) -> ffseg_status;
    pub fn ffseg_step(e: *mut ffseg_engine, info: *mut ffseg_step_info) -> ffseg_status;
    pub fn ffseg_extract_mesh(
        e: *const ffseg_engine,
        object: u32,
        xyz: *mut f32,
        xyz_capacity: usize,
        tris: *mut u32,
        tri_capacity: usize,
        n_vertices: *mut usize,
        n_tris: *mut usize,
    ) -> ffseg_status;
    pub fn ffseg_rasterize(
        e: *const ffseg_engine,
        object: u32,
        mask: *mut u8,
        strides: *const i64,
    ) -> ffseg_status;
    pub fn ffseg_region_mask(
        e: *const ffseg_engine,
        object: u32,
        mask: *mut u8,
        strides: *const i64,
    ) -> ffseg_status;
}
