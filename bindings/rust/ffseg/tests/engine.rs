//! The safe interface against the real library: workspace alignment and size,
//! errors carrying status and message, a round trip, a segmentation grown to
//! its target, refusals that leave the engine usable, reuse after drop,
//! coarse to fine through init_mesh, a stall reported as such.
use ffseg::{sys, Config, Engine, Params, Volume, Workspace};

fn small_config(n: u32) -> Config {
    let mut c = Config::default();
    c.mesh_resolution = n;
    c
}

// An ellipsoid of ones (semi-axes in mm) on a grid of the given spacing.
fn ellipsoid(dims: [usize; 3], spacing: [f64; 3], centre: [f64; 3], axes: [f64; 3]) -> Vec<u8> {
    let mut v = vec![0u8; dims[0] * dims[1] * dims[2]];
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = [i as f64 * spacing[0], j as f64 * spacing[1], k as f64 * spacing[2]];
                let r2: f64 = (0..3).map(|a| ((p[a] - centre[a]) / axes[a]).powi(2)).sum();
                v[i + dims[0] * (j + dims[1] * k)] = (r2 <= 1.0) as u8;
            }
        }
    }
    v
}

fn dice(a: &[u8], b: &[u8]) -> f64 {
    let both = a.iter().zip(b).filter(|(x, y)| **x == 1 && **y == 1).count();
    let na = a.iter().filter(|&&x| x == 1).count();
    let nb = b.iter().filter(|&&y| y == 1).count();
    2.0 * both as f64 / (na + nb) as f64
}

fn inside(m: &[u8]) -> usize {
    m.iter().filter(|&&b| b == 1).count()
}

fn binary_params(lambda_position: f64, lambda_laplacian: f64) -> Params {
    let mut p = Params::default();
    p.target_mode = sys::FFSEG_TARGET_BINARY;
    p.lambda_position = lambda_position;
    p.lambda_laplacian = lambda_laplacian;
    p
}

#[test]
fn workspace_is_aligned_and_exactly_sized() {
    let cfg = small_config(10);
    let ws = Workspace::new(&cfg).unwrap();
    assert_eq!(ws.as_ptr() as usize % 64, 0);
    let mut bytes = 0usize;
    assert_eq!(unsafe { sys::ffseg_workspace_size(&cfg, &mut bytes) }, sys::FFSEG_OK);
    assert_eq!(ws.len(), bytes);
    let bigger = Workspace::new(&small_config(20)).unwrap();
    assert!(bigger.len() > ws.len());
}

#[test]
fn errors_carry_status_and_message() {
    let mut cfg = Config::default();
    cfg.max_objects = 0;
    let err = Workspace::new(&cfg).err().expect("max_objects = 0 is refused");
    assert_eq!(err.status(), sys::FFSEG_ERR_INVALID_ARGUMENT);
    assert!(err.message().contains("max_objects"), "message: {}", err.message());
    assert!(err.to_string().contains("invalid argument"), "{}", err);

    let mut ws = Workspace::new(&small_config(8)).unwrap();
    let mut e = Engine::new(&mut ws).unwrap();
    let err = e.init_sphere(0, [1.0, 1.0, 1.0], 1.0).unwrap_err();
    assert_eq!(err.status(), sys::FFSEG_ERR_MISUSE);
    assert!(err.message().contains("set_volume"), "message: {}", err.message());
    let mut p = Params::default();
    p.reserved1 = 7;
    assert_eq!(e.set_params(&p).unwrap_err().status(), sys::FFSEG_ERR_INVALID_ARGUMENT);
    // grey_respacing: 0 automatic (the default since 0.8.0), 1 always, 2
    // never; 3 is refused by name.
    let mut q = Params::default();
    assert_eq!(q.grey_respacing, 0);
    q.grey_respacing = 1;
    e.set_params(&q).unwrap();
    q.grey_respacing = 2;
    e.set_params(&q).unwrap();
    q.grey_respacing = 3;
    let err = e.set_params(&q).unwrap_err();
    assert_eq!(err.status(), sys::FFSEG_ERR_INVALID_ARGUMENT);
    assert!(err.message().contains("grey_respacing"), "message: {}", err.message());
}

#[test]
fn round_trip_places_a_sphere_and_reads_it_back() {
    let n = 12u32;
    // The voxels are declared before the engine: it borrows them until it is dropped.
    let dims = [40usize, 36, 30];
    let voxels = vec![7i16; dims[0] * dims[1] * dims[2]];
    let mut ws = Workspace::new(&small_config(n)).unwrap();
    let mut e = Engine::new(&mut ws).unwrap();
    e.set_volume(&Volume::new(&voxels, dims).with_spacing([1.0, 1.0, 1.5]).with_rescale(2.0, 1.0)).unwrap();
    assert_eq!(e.sample([10.0, 10.0, 15.0], false).unwrap(), 15.0); // 2 * 7 + 1
    let (c, r) = ([20.0, 18.0, 22.0], 8.0);
    e.init_sphere(0, c, r).unwrap();
    let m = e.mesh(0).unwrap();
    assert_eq!(m.vertices.len(), 6 * (n * n) as usize);
    assert_eq!(m.triangles.len(), 2 * m.vertices.len() - 4);
    for v in &m.vertices {
        let d = ((v[0] as f64 - c[0]).powi(2) + (v[1] as f64 - c[1]).powi(2) + (v[2] as f64 - c[2]).powi(2)).sqrt();
        assert!((d - r).abs() < 1e-4, "vertex {:?} is {} mm from the centre", v, d);
    }
    assert!(m.triangles.iter().flatten().all(|&t| (t as usize) < m.vertices.len()));
    let mut mask = vec![9u8; voxels.len()];
    e.rasterize(0, &mut mask).unwrap();
    assert!(mask.iter().all(|&b| b <= 1));
    let inside_mm3 = mask.iter().filter(|&&b| b == 1).count() as f64 * 1.5;
    let ball = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    assert!((inside_mm3 - ball).abs() < 0.1 * ball, "{} mm^3 inside, ball {}", inside_mm3, ball);
}

#[test]
fn a_small_sphere_grows_onto_an_ellipsoid() {
    let (dims, spacing) = ([56usize, 48, 40], [1.0, 1.0, 1.25]);
    let (centre, axes) = ([28.0, 24.0, 25.0], [18.0, 13.0, 11.0]);
    let truth = ellipsoid(dims, spacing, centre, axes);
    let mut ws = Workspace::new(&small_config(16)).unwrap();
    let mut e = Engine::new(&mut ws).unwrap();
    e.set_volume(&Volume::new(&truth, dims).with_spacing(spacing)).unwrap();
    e.init_sphere(0, centre, 4.0).unwrap();
    let before = e.mesh(0).unwrap();
    let last = e.run(300).unwrap();
    assert!(last.converged, "not converged after {} steps", last.info.step_index);
    assert!(last.info.step_index > 1);
    let mut mask = vec![0u8; truth.len()];
    e.rasterize(0, &mut mask).unwrap();
    let both = truth.iter().zip(&mask).filter(|(a, b)| **a == 1 && **b == 1).count();
    let dice = 2.0 * both as f64 / (truth.iter().filter(|&&a| a == 1).count() + mask.iter().filter(|&&b| b == 1).count()) as f64;
    assert!(dice > 0.95, "Dice {}", dice);
    // It moved: no vertex is still on the 4 mm starting sphere.
    let after = e.mesh(0).unwrap();
    assert_eq!(after.vertices.len(), before.vertices.len());
    let r_min = after
        .vertices
        .iter()
        .map(|v| ((v[0] as f64 - centre[0]).powi(2) + (v[1] as f64 - centre[1]).powi(2) + (v[2] as f64 - centre[2]).powi(2)).sqrt())
        .fold(f64::INFINITY, f64::min);
    assert!(r_min > 8.0, "closest vertex {} mm from the centre", r_min);
}

#[test]
fn a_sphere_in_empty_background_comes_to_rest_degenerate() {
    let dims = [24usize, 24, 24];
    let empty = vec![0u8; dims[0] * dims[1] * dims[2]];
    let mut ws = Workspace::new(&small_config(6)).unwrap();
    let mut e = Engine::new(&mut ws).unwrap();
    let mut p = Params::default();
    p.target_mode = sys::FFSEG_TARGET_BINARY;
    e.set_params(&p).unwrap();
    e.set_volume(&Volume::new(&empty, dims)).unwrap();
    e.init_sphere(0, [12.0, 12.0, 12.0], 4.0).unwrap();
    let last = e.run(100).unwrap();
    assert!(last.degenerate && !last.converged, "not at rest as degenerate after {} steps", last.info.step_index);
    assert!(last.info.step_index < 100, "run() did not stop at rest");
    assert_eq!(last.info.object_flags[0], sys::FFSEG_OBJECT_NO_BOUNDARY);
    assert_eq!(last.info.flags_all, sys::FFSEG_OBJECT_NO_BOUNDARY);
}

#[test]
fn refused_calls_leave_the_engine_usable() {
    let voxels = vec![1u8; 20 * 20 * 20];
    let mut ws = Workspace::new(&small_config(8)).unwrap();
    let mut e = Engine::new(&mut ws).unwrap();
    // dims claim more voxels than the slice holds: refused, nothing read.
    let err = e.set_volume(&Volume::new(&voxels, [20, 20, 21])).unwrap_err();
    assert_eq!(err.status(), sys::FFSEG_ERR_INVALID_VOLUME);
    assert!(!err.message().is_empty());
    let mut mask = vec![0u8; voxels.len()];
    assert_eq!(e.rasterize(0, &mut mask).unwrap_err().status(), sys::FFSEG_ERR_MISUSE);
    e.set_volume(&Volume::new(&voxels, [20, 20, 20])).unwrap();
    assert_eq!(e.init_sphere(1, [10.0, 10.0, 10.0], 3.0).unwrap_err().status(), sys::FFSEG_ERR_OBJECT_OUT_OF_RANGE);
    assert_eq!(e.init_sphere(0, [500.0, 10.0, 10.0], 3.0).unwrap_err().status(), sys::FFSEG_ERR_SPHERE_OUTSIDE);
    e.init_sphere(0, [10.0, 10.0, 10.0], 3.0).unwrap();
    let mut short = vec![0u8; voxels.len() - 1];
    assert_eq!(e.rasterize(0, &mut short).unwrap_err().status(), sys::FFSEG_ERR_BUFFER_TOO_SMALL);
    assert!(short.iter().all(|&b| b == 0), "a refused rasterize wrote the mask");
    e.rasterize(0, &mut mask).unwrap();
    assert!(mask.iter().any(|&b| b == 1));
}

#[test]
fn dropping_the_engine_frees_the_workspace_for_another() {
    let mut ws = Workspace::new(&small_config(8)).unwrap();
    let voxels = vec![0.5f32; 16 * 16 * 16];
    for round in 0..3 {
        let mut e = Engine::new(&mut ws).unwrap();
        e.set_volume(&Volume::new(&voxels, [16, 16, 16])).unwrap();
        e.init_sphere(0, [8.0, 8.0, 8.0], 2.0 + round as f64).unwrap();
        assert_eq!(e.mesh(0).unwrap().vertices.len(), 6 * 64);
    }
}

#[test]
fn two_objects_in_a_bar_get_disjoint_bounding_regions() {
    // On voxels, and on cells of 3 voxels when 256 cannot hold a region's box
    // (config.max_region_voxels, 0.6.0).
    for &max_region in &[0i64, 256] {
        disjoint_regions(max_region);
    }
    // The library reads the field: regions of 256 voxels take less workspace
    // than the default (max_roi_voxels), one out of range is refused by name.
    let mut cfg = small_config(6);
    cfg.max_objects = 2;
    let full = Workspace::new(&cfg).unwrap().len();
    cfg.max_region_voxels = 256;
    let small = Workspace::new(&cfg).unwrap().len();
    assert!(small < full, "max_region_voxels 256: {} >= {} bytes", small, full);
    cfg.max_region_voxels = -1;
    let err = Workspace::new(&cfg).err().expect("max_region_voxels = -1 is refused");
    assert_eq!(err.status(), sys::FFSEG_ERR_INVALID_ARGUMENT);
    assert!(err.message().contains("max_region_voxels"), "message: {}", err.message());
}

fn disjoint_regions(max_region: i64) {
    // A bar of ones along i, one sphere near each end, binary targets.
    let dims = [40usize, 12, 12];
    let mut bar = vec![0u8; dims[0] * dims[1] * dims[2]];
    for k in 3..9 {
        for j in 3..9 {
            for i in 4..36 {
                bar[i + dims[0] * (j + dims[1] * k)] = 1;
            }
        }
    }
    let mut cfg = small_config(6);
    cfg.max_objects = 2;
    cfg.max_region_voxels = max_region;
    let mut ws = Workspace::new(&cfg).unwrap();
    let mut e = Engine::new(&mut ws).unwrap();
    let mut p = Params::default();
    p.target_mode = sys::FFSEG_TARGET_BINARY;
    e.set_params(&p).unwrap();
    e.set_volume(&Volume::new(&bar, dims)).unwrap();
    e.init_sphere(0, [10.0, 5.5, 5.5], 2.0).unwrap();
    e.init_sphere(1, [29.0, 5.5, 5.5], 2.0).unwrap();
    let mut r0 = vec![7u8; bar.len()];
    let err = e.region_mask(0, &mut r0).unwrap_err(); // no step yet
    assert_eq!(err.status(), sys::FFSEG_ERR_MISUSE);
    assert!(err.message().contains("no bounding region yet"), "message: {}", err.message());
    for _ in 0..3 {
        e.step().unwrap();
    }
    let mut r1 = vec![7u8; bar.len()];
    e.region_mask(0, &mut r0).unwrap();
    e.region_mask(1, &mut r1).unwrap();
    assert!(r0.iter().chain(&r1).all(|&b| b <= 1));
    assert!(r0.iter().zip(&r1).all(|(a, b)| !(*a == 1 && *b == 1)), "two regions share a voxel");
    assert!(r0.iter().filter(|&&b| b == 1).count() > 100);
    assert!(r1.iter().filter(|&&b| b == 1).count() > 100);
    let mut short = vec![0u8; bar.len() - 1];
    assert_eq!(e.region_mask(0, &mut short).unwrap_err().status(), sys::FFSEG_ERR_BUFFER_TOO_SMALL);
}

#[test]
fn a_mesh_grown_at_12_goes_on_at_24_from_where_it_stopped() {
    // A binary ball, off the voxel grid's centres so that no symmetry helps.
    let dims = [48usize, 48, 48];
    let (centre, r) = ([24.3, 23.8, 24.2], 14.0);
    let truth = ellipsoid(dims, [1.0; 3], centre, [r; 3]);
    let mut ws12 = Workspace::new(&small_config(12)).unwrap();
    let mut coarse = Engine::new(&mut ws12).unwrap();
    coarse.set_params(&binary_params(1.0, 1.0)).unwrap();
    coarse.set_volume(&Volume::new(&truth, dims)).unwrap();
    coarse.init_sphere(0, centre, 5.0).unwrap();
    let c = coarse.run(300).unwrap();
    assert!(c.converged, "n = 12 not converged after {} steps", c.info.step_index);
    let mut m12 = vec![0u8; truth.len()];
    coarse.rasterize(0, &mut m12).unwrap();
    let mesh12 = coarse.mesh(0).unwrap();
    assert_eq!(mesh12.vertices.len(), 6 * 12 * 12);

    let mut ws24 = Workspace::new(&small_config(24)).unwrap();
    let mut fine = Engine::new(&mut ws24).unwrap();
    fine.set_params(&binary_params(1.0, 1.0)).unwrap();
    fine.set_volume(&Volume::new(&truth, dims)).unwrap();
    fine.init_mesh(0, centre, 5.0, &mesh12.vertices).unwrap();
    let start = fine.mesh(0).unwrap();
    assert_eq!(start.vertices.len(), 6 * 24 * 24);
    // Not 6 n^2 vertices: refused, and the object keeps the mesh it had.
    let err = fine.init_mesh(0, centre, 5.0, &mesh12.vertices[1..]).unwrap_err();
    assert_eq!(err.status(), sys::FFSEG_ERR_INVALID_ARGUMENT);
    assert!(err.message().contains("6 n^2"), "message: {}", err.message());
    assert_eq!(fine.mesh(0).unwrap().vertices, start.vertices);
    // It starts on the coarse surface, not on the 5 mm sphere: every vertex
    // near radius r already, and the same voxels inside bar a thin shell.
    let radii: Vec<f64> = start
        .vertices
        .iter()
        .map(|v| (0..3).map(|a| (v[a] as f64 - centre[a]).powi(2)).sum::<f64>().sqrt())
        .collect();
    let r_min = radii.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(r_min > r - 2.0, "a resampled vertex {} mm from the centre", r_min);
    let mut m_start = vec![0u8; truth.len()];
    fine.rasterize(0, &mut m_start).unwrap();
    assert!(dice(&m_start, &m12) > 0.98, "start vs n = 12: Dice {}", dice(&m_start, &m12));

    let f = fine.run(300).unwrap();
    assert!(f.converged && !f.degenerate, "n = 24 not converged after {} steps", f.info.step_index);
    assert_eq!(f.info.object_flags[0], 0);
    let mut m24 = vec![0u8; truth.len()];
    fine.rasterize(0, &mut m24).unwrap();
    let (d12, d24) = (dice(&m12, &truth), dice(&m24, &truth));
    // Not lower: the finer mesh goes on from the coarse one and follows the
    // ball's curvature better (measured Dice 0.9948 -> 0.9998, 11392 -> 11503
    // of 11507 voxels), so neither figure may drop.
    assert!(d24 >= d12, "Dice n = 12 {}, n = 24 {}", d12, d24);
    assert!(inside(&m24) >= inside(&m12), "voxels {} -> {}", inside(&m12), inside(&m24));
    assert!(d24 > 0.99, "Dice n = 24 {}", d24);
}

#[test]
fn a_mesh_held_still_short_of_its_boundary_is_reported_stalled() {
    // A ball of radius 20 around a sphere of 5: a Laplacian weight a million
    // times the positional one lets the solve barely move the mesh, so it
    // comes to rest with every target 15 mm outward. With the default weights
    // the same start converges, so the flag comes from the stall, not the scene.
    let dims = [64usize, 64, 64];
    let centre = [32.0, 32.0, 32.0];
    let ball = ellipsoid(dims, [1.0; 3], centre, [20.0; 3]);
    let nv = 6 * 12 * 12;
    for held in [true, false] {
        let mut ws = Workspace::new(&small_config(12)).unwrap();
        let mut e = Engine::new(&mut ws).unwrap();
        let p = if held { binary_params(1e-6, 1e6) } else { binary_params(1.0, 1.0) };
        e.set_params(&p).unwrap();
        e.set_volume(&Volume::new(&ball, dims)).unwrap();
        e.init_sphere(0, centre, 5.0).unwrap();
        let last = e.run(200).unwrap();
        let mut mask = vec![0u8; ball.len()];
        e.rasterize(0, &mut mask).unwrap();
        let i = &last.info;
        if held {
            assert!(last.degenerate && !last.converged, "held: not DEGENERATE after {} steps", i.step_index);
            assert!(last.stalled());
            assert_eq!(i.object_flags[0], ffseg::OBJECT_STALLED);
            assert_eq!(i.flags_all, ffseg::OBJECT_STALLED);
            assert!(i.far_outward[0] as f64 > 0.9 * nv as f64, "far outward {} of {}", i.far_outward[0], nv);
            assert!(inside(&mask) < inside(&ball) / 10, "{} of {} voxels inside", inside(&mask), inside(&ball));
        } else {
            assert!(last.converged && !last.stalled(), "free: status after {} steps", i.step_index);
            assert_eq!(i.object_flags[0], 0);
            assert!(((i.far_outward[0] + i.far_inward[0]) as f64) < 0.05 * nv as f64);
            assert!(dice(&mask, &ball) > 0.95, "Dice {}", dice(&mask, &ball));
        }
    }
}
