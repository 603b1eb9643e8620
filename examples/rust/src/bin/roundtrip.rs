//! The round trip from Rust: workspace, engine, volume, a sphere placed, its
//! mesh and mask read back, and the counts the header promises checked.
use ffseg::{Config, Engine, Volume, Workspace};

fn main() -> Result<(), ffseg::Error> {
    let n = 12;
    let dims = [40usize, 40, 32];
    let voxels = vec![100u16; dims[0] * dims[1] * dims[2]];
    let mut cfg = Config::default();
    cfg.mesh_resolution = n;
    let mut ws = Workspace::new(&cfg)?;
    let ws_bytes = ws.len();
    let mut engine = Engine::new(&mut ws)?;
    engine.set_volume(&Volume::new(&voxels, dims).with_spacing([1.0, 1.0, 1.25]))?;
    engine.init_sphere(0, [20.0, 20.0, 20.0], 8.0)?;
    let mesh = engine.mesh(0)?;
    let mut mask = vec![0u8; voxels.len()];
    engine.rasterize(0, &mut mask)?;
    let inside = mask.iter().filter(|&&m| m == 1).count();
    let (mm3, ball) = (inside as f64 * 1.25, 4.0 / 3.0 * std::f64::consts::PI * 512.0);
    println!(
        "roundtrip (Rust): ffseg {}, workspace {} bytes, {} vertices, {} triangles, {:.0} mm^3 inside (ball {:.0})",
        ffseg::version(), ws_bytes, mesh.vertices.len(), mesh.triangles.len(), mm3, ball
    );
    let ok = mesh.vertices.len() == 6 * (n * n) as usize
        && mesh.triangles.len() == 2 * mesh.vertices.len() - 4
        && (mm3 - ball).abs() < 0.1 * ball;
    std::process::exit(if ok { 0 } else { 1 });
}
