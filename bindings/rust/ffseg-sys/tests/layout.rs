//! Every public struct's size and every field's offset and size, in Rust,
//! against what the C compiler makes of the installed header: abi/layout.c is
//! compiled and run here, and its lines compared with the Rust declarations.
use ffseg_sys::*;
use std::collections::BTreeMap;
use std::mem::{size_of, MaybeUninit};
use std::path::PathBuf;
use std::process::Command;

fn pointee_size<T>(_: *const T) -> usize {
    size_of::<T>()
}

// (offset, size) of a field, without offset_of! (Rust 1.77): the address of the
// field in an uninitialised value, taken without reading or referencing it.
macro_rules! field {
    ($map:ident, $t:ident, $f:ident) => {{
        let u = MaybeUninit::<$t>::uninit();
        let base = u.as_ptr();
        let f = unsafe { std::ptr::addr_of!((*base).$f) };
        let off = f as usize - base as usize;
        $map.insert(format!("field {} {}", stringify!($t), stringify!($f)), (off, pointee_size(f)));
    }};
}
macro_rules! strukt {
    ($map:ident, $t:ident, [$($f:ident),*]) => {{
        $( field!($map, $t, $f); )*
        $map.insert(format!("struct {}", stringify!($t)), (size_of::<$t>(), 0));
    }};
}

fn rust_layout() -> BTreeMap<String, (usize, usize)> {
    let mut m = BTreeMap::new();
    strukt!(m, ffseg_config, [struct_size, max_objects, mesh_resolution, reserved0, max_roi_voxels, target_mode, reserved1, max_region_voxels]);
    strukt!(m, ffseg_params, [struct_size, target_mode, lambda_laplacian, lambda_position,
        lambda_uniform, step_size, flip_tau, search_range_mm, search_step_mm, convergence_mm,
        diffusion_iterations, consecutive_background, smoothing_iterations, bin_min_count,
        smoothing_kappa, intensity_gamma, sigma_floor_fraction, bin_radius, bin_separation,
        partial_volume_steps, reserved1, region_width_mm, border_weight, region_interval, grey_respacing]);
    strukt!(m, ffseg_volume, [struct_size, voxel_type, data, data_bytes, offset, dims, strides,
        index_to_world, rescale_slope, rescale_intercept]);
    strukt!(m, ffseg_step_info, [struct_size, step_index, active_objects, reserved0,
        mean_displacement_mm, vertices_with_target, flips_avoided, intersections_avoided,
        border_vertices, stage_us, object_flags, flags_all, reserved1, guard_held, far_outward,
        far_inward, respaced]);
    m
}

fn c_layout() -> BTreeMap<String, (usize, usize)> {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let abi = manifest.join("../../../abi");
    // The header the library was found with (pkg-config / FFSEG_LIB_DIR), else the repository's.
    let include = option_env!("FFSEG_SYS_INCLUDE_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest.join("../../../include"));
    let exe = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("ffseg_layout");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_string());
    let st = Command::new(&cc)
        .arg("-std=c99")
        .arg("-I")
        .arg(&include)
        .arg("-I")
        .arg(&abi)
        .arg(abi.join("layout.c"))
        .arg("-o")
        .arg(&exe)
        .status()
        .expect("running the C compiler");
    assert!(st.success(), "{} failed on abi/layout.c", cc);
    let out = Command::new(&exe).output().expect("running ffseg_layout");
    assert!(
        out.status.success(),
        "abi/layout.c reports implicit padding: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut m = BTreeMap::new();
    for line in String::from_utf8(out.stdout).unwrap().lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["struct", s, size] => m.insert(format!("struct {}", s), (size.parse().unwrap(), 0)),
            ["field", s, f, off, size] => {
                m.insert(format!("field {} {}", s, f), (off.parse().unwrap(), size.parse().unwrap()))
            }
            _ => panic!("unexpected line from ffseg_layout: {}", line),
        };
    }
    m
}

#[test]
fn struct_sizes_and_field_offsets_match_the_c_compiler() {
    let c = c_layout();
    let r = rust_layout();
    assert!(c.len() >= 4 + 40, "layout.c printed only {} lines", c.len());
    let mut wrong = Vec::new();
    for (k, v) in &c {
        match r.get(k) {
            Some(rv) if rv == v => {}
            Some(rv) => wrong.push(format!("{}: C (offset/size) {:?}, Rust {:?}", k, v, rv)),
            None => wrong.push(format!("{}: in the header, not in ffseg-sys", k)),
        }
    }
    for k in r.keys().filter(|k| !c.contains_key(*k)) {
        wrong.push(format!("{}: in ffseg-sys, not in the header", k));
    }
    assert!(wrong.is_empty(), "layout mismatches:\n{}", wrong.join("\n"));
}

#[test]
fn header_and_library_versions_agree() {
    assert_eq!(unsafe { ffseg_version_number() }, FFSEG_VERSION_NUMBER);
}

#[test]
fn defaults_come_from_the_library() {
    let c = ffseg_config::default();
    assert_eq!(c.struct_size as usize, size_of::<ffseg_config>());
    assert!(c.max_objects >= 1 && c.mesh_resolution >= 2);
    let p = ffseg_params::default();
    assert_eq!(p.struct_size as usize, size_of::<ffseg_params>());
    assert_eq!(p.reserved1, 0);
    assert!(p.step_size > 0.0 && p.step_size <= 1.0);
}
