//! Safe Rust interface to ffseg's C ABI.
//!
//! ```no_run
//! let voxels = vec![0u8; 64 * 64 * 64];                            // outlives the engine
//! let mut ws = ffseg::Workspace::new(&ffseg::Config::default())?;  // 64-byte aligned, owned
//! let mut engine = ffseg::Engine::new(&mut ws)?;                    // lives inside ws
//! engine.set_volume(&ffseg::Volume::new(&voxels, [64, 64, 64]).with_spacing([1.0, 1.0, 1.0]))?;
//! engine.init_sphere(0, [32.0, 32.0, 32.0], 5.0)?;
//! while !engine.step()?.converged {}
//! let mesh = engine.mesh(0)?;
//! # Ok::<(), ffseg::Error>(())
//! ```
//!
//! The engine borrows its workspace (`'ws`) and every volume it is given
//! (`'vol`) for as long as it lives, so neither can be freed or changed under
//! it: a volume dropped while the engine still exists does not compile (so
//! declare the voxels before the engine).
//!
//! ```compile_fail
//! let mut ws = ffseg::Workspace::new(&ffseg::Config::default()).unwrap();
//! let mut engine = ffseg::Engine::new(&mut ws).unwrap();
//! {
//!     let voxels = vec![0u8; 8 * 8 * 8];
//!     engine.set_volume(&ffseg::Volume::new(&voxels, [8, 8, 8])).unwrap();
//! } // voxels freed here, while the engine still reads them: refused
//! engine.init_sphere(0, [4.0, 4.0, 4.0], 2.0).unwrap();
//! ```
//!
//! ```compile_fail
//! let mut ws = ffseg::Workspace::new(&ffseg::Config::default()).unwrap();
//! let engine = ffseg::Engine::new(&mut ws).unwrap();
//! drop(ws); // the workspace cannot go while the engine lives in it
//! drop(engine);
//! ```
use std::alloc::{self, Layout};
use std::ffi::CStr;
use std::fmt;
use std::marker::PhantomData;
use std::os::raw::c_char;
use std::ptr::{self, NonNull};

pub use ffseg_sys as sys;

/// Sizes the engine (`ffseg_config`); `Config::default()` is the library's default.
pub type Config = sys::ffseg_config;
/// Algorithm parameters (`ffseg_params`); `Params::default()` is the library's default.
pub type Params = sys::ffseg_params;
/// What one step did (`ffseg_step_info`): per object (at most
/// `sys::FFSEG_REPORT_OBJECTS`) `object_flags`, and since 0.5.0 `guard_held`,
/// `far_outward`, `far_inward`, and since 0.8.0 `respaced`.
pub type StepInfo = sys::ffseg_step_info;

/// `StepInfo::object_flags` bits: no vertex ever found a boundary.
pub const OBJECT_NO_BOUNDARY: u32 = sys::FFSEG_OBJECT_NO_BOUNDARY;
/// ... the object fills most of the grid (a leak).
pub const OBJECT_FILLS_GRID: u32 = sys::FFSEG_OBJECT_FILLS_GRID;
/// ... (since 0.5.0) it came to rest short of (or beyond) its boundary: its
/// mesh is a partial result; `far_outward` / `far_inward` give the counts.
pub const OBJECT_STALLED: u32 = sys::FFSEG_OBJECT_STALLED;

/// The library's version, MAJOR*10000 + MINOR*100 + PATCH.
pub fn version() -> u32 {
    unsafe { sys::ffseg_version_number() }
}

fn text(p: *const c_char) -> String {
    if p.is_null() {
        return String::new();
    }
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// A failed call: its status (an `FFSEG_ERR_*` code) and the library's
/// detailed message (`ffseg_last_error`) as it stood right after the call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    status: i32,
    message: String,
}

impl Error {
    pub fn status(&self) -> i32 {
        self.status
    }
    pub fn message(&self) -> &str {
        &self.message
    }
    /// `ffseg_status_string(status)`.
    pub fn status_text(&self) -> String {
        text(unsafe { sys::ffseg_status_string(self.status) })
    }
    fn from_engine(status: i32, e: *const sys::ffseg_engine) -> Error {
        Error { status, message: text(unsafe { sys::ffseg_last_error(e) }) }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ffseg: {} ({})", self.status_text(), self.status)?;
        if !self.message.is_empty() {
            write!(f, ": {}", self.message)?;
        }
        Ok(())
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;

/// Memory for one engine: exactly `ffseg_workspace_size(config)` bytes, 64-byte
/// aligned, owned here and freed on drop.
pub struct Workspace {
    ptr: NonNull<u8>,
    layout: Layout,
    bytes: usize,
    config: Config,
}

impl Workspace {
    pub const ALIGN: usize = 64;

    pub fn new(config: &Config) -> Result<Workspace> {
        let mut bytes = 0usize;
        let st = unsafe { sys::ffseg_workspace_size(config, &mut bytes) };
        if st < 0 {
            return Err(Error::from_engine(st, ptr::null()));
        }
        let layout = Layout::from_size_align(bytes.max(1), Self::ALIGN).map_err(|_| Error {
            status: sys::FFSEG_ERR_CONFIG_TOO_LARGE,
            message: format!("a workspace of {} bytes cannot be allocated", bytes),
        })?;
        let ptr = NonNull::new(unsafe { alloc::alloc(layout) }).unwrap_or_else(|| alloc::handle_alloc_error(layout));
        Ok(Workspace { ptr, layout, bytes, config: *config })
    }

    /// Its size in bytes, as ffseg_workspace_size reported it.
    pub fn len(&self) -> usize {
        self.bytes
    }
    pub fn is_empty(&self) -> bool {
        self.bytes == 0
    }
    pub fn as_ptr(&self) -> *const u8 {
        self.ptr.as_ptr()
    }
    pub fn config(&self) -> &Config {
        &self.config
    }
}

// Owned memory, no thread affinity.
unsafe impl Send for Workspace {}

impl Drop for Workspace {
    fn drop(&mut self) {
        unsafe { alloc::dealloc(self.ptr.as_ptr(), self.layout) }
    }
}

/// A voxel type the engine reads.
pub trait Voxel: Copy + sealed::Sealed {
    const TYPE: u32;
}
mod sealed {
    pub trait Sealed {}
}
macro_rules! voxel {
    ($t:ty, $c:expr) => {
        impl sealed::Sealed for $t {}
        impl Voxel for $t {
            const TYPE: u32 = $c;
        }
    };
}
voxel!(u8, sys::FFSEG_U8);
voxel!(i16, sys::FFSEG_I16);
voxel!(u16, sys::FFSEG_U16);
voxel!(i32, sys::FFSEG_I32);
voxel!(f32, sys::FFSEG_F32);
voxel!(f64, sys::FFSEG_F64);

/// A volume descriptor borrowing its voxels for `'a`. The library checks every
/// field when it is set (dims against the slice's length included), so any
/// value built here is safe to hand over.
#[derive(Clone, Copy, Debug)]
pub struct Volume<'a> {
    raw: sys::ffseg_volume,
    _data: PhantomData<&'a [u8]>,
}

impl<'a> Volume<'a> {
    /// Contiguous voxels, i fastest: `dims[0] * dims[1] * dims[2]` of them;
    /// 1 mm voxels, the index-to-world affine the identity, no rescaling.
    pub fn new<T: Voxel>(voxels: &'a [T], dims: [usize; 3]) -> Volume<'a> {
        let e = std::mem::size_of::<T>() as i64;
        let d = [dims[0] as i64, dims[1] as i64, dims[2] as i64];
        let bytes = unsafe { std::slice::from_raw_parts(voxels.as_ptr() as *const u8, std::mem::size_of_val(voxels)) };
        Volume::from_bytes(bytes, T::TYPE, 0, d, [e, e * d[0], e * d[0] * d[1]])
    }

    /// Any layout: voxel (i, j, k) at `bytes[offset + i*strides[0] + j*strides[1] + k*strides[2]]`
    /// (strides in bytes, may be negative), of type `voxel_type` (`sys::FFSEG_U8` ...).
    pub fn from_bytes(bytes: &'a [u8], voxel_type: u32, offset: i64, dims: [i64; 3], strides: [i64; 3]) -> Volume<'a> {
        let mut a = [0.0; 16];
        a[0] = 1.0;
        a[5] = 1.0;
        a[10] = 1.0;
        a[15] = 1.0;
        Volume {
            raw: sys::ffseg_volume {
                struct_size: std::mem::size_of::<sys::ffseg_volume>() as u32,
                voxel_type,
                data: bytes.as_ptr() as *const std::ffi::c_void,
                data_bytes: bytes.len() as u64,
                offset,
                dims,
                strides,
                index_to_world: a,
                rescale_slope: 1.0,
                rescale_intercept: 0.0,
            },
            _data: PhantomData,
        }
    }

    /// Axis-aligned voxels of this size in mm, the voxel (0,0,0) centre at the origin.
    pub fn with_spacing(mut self, mm: [f64; 3]) -> Self {
        for (a, s) in mm.iter().enumerate() {
            self.raw.index_to_world[5 * a] = *s;
        }
        self
    }
    /// Row-major 4x4 voxel-centre-to-mm matrix, last row 0 0 0 1.
    pub fn with_affine(mut self, index_to_world: [f64; 16]) -> Self {
        self.raw.index_to_world = index_to_world;
        self
    }
    /// value = slope * stored + intercept.
    pub fn with_rescale(mut self, slope: f64, intercept: f64) -> Self {
        self.raw.rescale_slope = slope;
        self.raw.rescale_intercept = intercept;
        self
    }
    pub fn raw(&self) -> &sys::ffseg_volume {
        &self.raw
    }
    /// Voxels along i, j, k.
    pub fn dims(&self) -> [i64; 3] {
        self.raw.dims
    }
}

/// A mesh taken out of the engine: vertices in mm, triangles counter-clockwise
/// seen from outside.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// The outcome of a step that did not fail.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    /// Every object has converged (`FFSEG_CONVERGED`).
    pub converged: bool,
    /// Every object has come to rest but some result is no segmentation, or
    /// only part of one (`FFSEG_DEGENERATE`; which and why: `info.object_flags`,
    /// `OBJECT_*`).
    pub degenerate: bool,
    pub info: StepInfo,
}

impl Step {
    /// Some object stalled short of (or beyond) its boundary
    /// (`OBJECT_STALLED` in `info.flags_all`, which also counts objects past
    /// the report's first `sys::FFSEG_REPORT_OBJECTS`).
    pub fn stalled(&self) -> bool {
        self.info.flags_all & OBJECT_STALLED != 0
    }
}

/// An engine inside a borrowed workspace. Destroyed on drop (the workspace is
/// then free to be reused or dropped). `'vol` covers every volume it is given.
pub struct Engine<'ws, 'vol> {
    raw: NonNull<sys::ffseg_engine>,
    voxels: Option<usize>, // the set volume's voxel count (what rasterize writes)
    _ws: PhantomData<&'ws mut Workspace>,
    _vol: PhantomData<&'vol [u8]>,
}

impl<'ws, 'vol> Engine<'ws, 'vol> {
    pub fn new(ws: &'ws mut Workspace) -> Result<Engine<'ws, 'vol>> {
        let mut e: *mut sys::ffseg_engine = ptr::null_mut();
        let st = unsafe { sys::ffseg_create(&ws.config, ws.ptr.as_ptr() as *mut _, ws.bytes, &mut e) };
        if st < 0 {
            return Err(Error::from_engine(st, ptr::null()));
        }
        let raw = NonNull::new(e).ok_or(Error { status: sys::FFSEG_ERR_NULL_POINTER, message: "create returned no engine".into() })?;
        Ok(Engine { raw, voxels: None, _ws: PhantomData, _vol: PhantomData })
    }

    fn check(&self, st: i32) -> Result<i32> {
        if st < 0 {
            Err(Error::from_engine(st, self.raw.as_ptr()))
        } else {
            Ok(st)
        }
    }

    pub fn set_params(&mut self, p: &Params) -> Result<()> {
        self.check(unsafe { sys::ffseg_set_params(self.raw.as_ptr(), p) }).map(|_| ())
    }

    /// Hands the engine a volume; its voxels stay borrowed for the engine's
    /// whole life. On failure the engine keeps the volume it had.
    pub fn set_volume(&mut self, v: &Volume<'vol>) -> Result<()> {
        self.check(unsafe { sys::ffseg_set_volume(self.raw.as_ptr(), &v.raw) })?;
        let d = v.raw.dims;
        self.voxels = Some((d[0] * d[1] * d[2]) as usize);
        Ok(())
    }

    pub fn init_sphere(&mut self, object: u32, center_mm: [f64; 3], radius_mm: f64) -> Result<()> {
        self.check(unsafe { sys::ffseg_init_sphere(self.raw.as_ptr(), object, center_mm.as_ptr(), radius_mm) })
            .map(|_| ())
    }

    /// Places an object's mesh from another engine's (coarse to fine):
    /// `vertices` as `mesh()` returns them, from an engine of any mesh
    /// resolution n (6 n^2 vertices), resampled onto this engine's. The
    /// grey-level model is learned from the sphere (`center_mm`, `radius_mm`)
    /// as `init_sphere` does: give the sphere the mesh grew from. On failure
    /// the object keeps the mesh it had.
    pub fn init_mesh(&mut self, object: u32, center_mm: [f64; 3], radius_mm: f64, vertices: &[[f32; 3]]) -> Result<()> {
        // [f32; 3] has no padding, so the slice is the 3 n_vertices floats the C call reads.
        self.check(unsafe {
            sys::ffseg_init_mesh(
                self.raw.as_ptr(),
                object,
                center_mm.as_ptr(),
                radius_mm,
                vertices.as_ptr() as *const f32,
                vertices.len(),
            )
        })
        .map(|_| ())
    }

    /// One deformation step of every placed object.
    pub fn step(&mut self) -> Result<Step> {
        let mut info = StepInfo::default();
        let st = self.check(unsafe { sys::ffseg_step(self.raw.as_ptr(), &mut info) })?;
        Ok(Step { converged: st == sys::FFSEG_CONVERGED, degenerate: st == sys::FFSEG_DEGENERATE, info })
    }

    /// Steps until every object has come to rest (converged or degenerate,
    /// a stall included) or `max_steps` steps were taken.
    pub fn run(&mut self, max_steps: u32) -> Result<Step> {
        let mut last = self.step()?;
        while !last.converged && !last.degenerate && last.info.step_index < max_steps {
            last = self.step()?;
        }
        Ok(last)
    }

    /// Intensity (rescaled) at a point in mm: nearest voxel or trilinear.
    pub fn sample(&self, point_mm: [f64; 3], linear: bool) -> Result<f64> {
        let mode = if linear { sys::FFSEG_SAMPLE_LINEAR } else { sys::FFSEG_SAMPLE_NEAREST };
        let mut v = 0.0;
        self.check(unsafe { sys::ffseg_sample(self.raw.as_ptr(), point_mm.as_ptr(), mode, &mut v) })?;
        Ok(v)
    }

    pub fn mesh(&self, object: u32) -> Result<Mesh> {
        let (mut nv, mut nt) = (0usize, 0usize);
        let e = self.raw.as_ptr();
        self.check(unsafe {
            sys::ffseg_extract_mesh(e, object, ptr::null_mut(), 0, ptr::null_mut(), 0, &mut nv, &mut nt)
        })?;
        let mut m = Mesh { vertices: vec![[0.0; 3]; nv], triangles: vec![[0; 3]; nt] };
        self.check(unsafe {
            sys::ffseg_extract_mesh(
                e,
                object,
                m.vertices.as_mut_ptr() as *mut f32,
                nv,
                m.triangles.as_mut_ptr() as *mut u32,
                nt,
                &mut nv,
                &mut nt,
            )
        })?;
        Ok(m)
    }

    /// Writes 1 for every voxel of the volume grid inside the object's mesh and
    /// 0 elsewhere; `mask` is contiguous, i fastest, and must hold every voxel.
    pub fn rasterize(&self, object: u32, mask: &mut [u8]) -> Result<()> {
        self.check_mask("rasterize", mask)?;
        self.check(unsafe { sys::ffseg_rasterize(self.raw.as_ptr(), object, mask.as_mut_ptr(), ptr::null()) })
            .map(|_| ())
    }

    /// Writes 1 for every voxel the object's bounding region owns (thesis 6.2,
    /// fig. 6.4; distinct objects' regions never overlap) and 0 elsewhere;
    /// `mask` as for `rasterize`. Regions exist once `step` has run with two
    /// or more objects placed; before that, and with `max_objects` = 1, the
    /// call fails with `FFSEG_ERR_MISUSE`.
    pub fn region_mask(&self, object: u32, mask: &mut [u8]) -> Result<()> {
        self.check_mask("region_mask", mask)?;
        self.check(unsafe { sys::ffseg_region_mask(self.raw.as_ptr(), object, mask.as_mut_ptr(), ptr::null()) })
            .map(|_| ())
    }

    fn check_mask(&self, what: &str, mask: &[u8]) -> Result<()> {
        let need = self.voxels.ok_or_else(|| Error {
            status: sys::FFSEG_ERR_MISUSE,
            message: format!("{}: no volume set", what),
        })?;
        if mask.len() < need {
            return Err(Error {
                status: sys::FFSEG_ERR_BUFFER_TOO_SMALL,
                message: format!("{}: mask holds {} voxels, the volume has {}", what, mask.len(), need),
            });
        }
        Ok(())
    }

    pub fn as_raw(&self) -> *mut sys::ffseg_engine {
        self.raw.as_ptr()
    }
}

// The header's threading rule: one engine is used by one thread at a time,
// which `&mut self` already enforces; moving it to another thread is fine.
// Not Sync: even the `&self` calls write the engine's message buffer.
unsafe impl Send for Engine<'_, '_> {}

impl Drop for Engine<'_, '_> {
    fn drop(&mut self) {
        unsafe { sys::ffseg_destroy(self.raw.as_ptr()) }
    }
}
