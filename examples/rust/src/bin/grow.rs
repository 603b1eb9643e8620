//! A real segmentation from Rust: a noisy synthetic CT-like scan (a bright
//! ellipsoidal organ in darker tissue), the grey-level target of thesis
//! chapter 5, a small sphere grown until it converges, Dice against the organ.
use ffseg::{sys, Config, Engine, Params, Volume, Workspace};

// A small deterministic generator (no crates): xorshift64*, Box-Muller for noise.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

fn main() -> Result<(), ffseg::Error> {
    let (dims, spacing) = ([64usize, 60, 44], [1.0, 1.0, 1.25]);
    let (centre, axes) = ([30.0, 31.0, 27.0], [17.0, 12.0, 10.0]);
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut scan = vec![0i16; dims[0] * dims[1] * dims[2]];
    let mut organ = vec![false; scan.len()];
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = [i as f64 * spacing[0], j as f64 * spacing[1], k as f64 * spacing[2]];
                let r2: f64 = (0..3).map(|a| ((p[a] - centre[a]) / axes[a]).powi(2)).sum();
                let idx = i + dims[0] * (j + dims[1] * k);
                organ[idx] = r2 <= 1.0;
                let level = if organ[idx] { 160.0 } else { 40.0 };
                scan[idx] = (level + 12.0 * rng.normal()).round() as i16;
            }
        }
    }

    let mut cfg = Config::default();
    cfg.mesh_resolution = 16;
    let mut ws = Workspace::new(&cfg)?;
    let mut engine = Engine::new(&mut ws)?;
    let mut params = Params::default();
    params.target_mode = sys::FFSEG_TARGET_INTENSITY;
    engine.set_params(&params)?;
    engine.set_volume(&Volume::new(&scan, dims).with_spacing(spacing))?;
    engine.init_sphere(0, centre, 5.0)?;
    let last = engine.run(300)?;

    let mut mask = vec![0u8; scan.len()];
    engine.rasterize(0, &mut mask)?;
    let found = mask.iter().filter(|&&m| m == 1).count();
    let truth = organ.iter().filter(|&&o| o).count();
    let both = organ.iter().zip(&mask).filter(|(o, m)| **o && **m == 1).count();
    let dice = 2.0 * both as f64 / (truth + found) as f64;
    println!(
        "grow (Rust, grey levels): {} after {} steps, {} voxels found, {} in the organ, Dice {:.3}",
        if last.converged { "converged" } else { "not converged" },
        last.info.step_index, found, truth, dice
    );
    std::process::exit(if last.converged && dice >= 0.85 { 0 } else { 1 });
}
