//! `porelab bench dem`: particle-steps per second per core of a settling bed (Hertz–Mindlin with
//! friction, walls, gravity) against N, on one and two threads, with the share of time spent
//! rebuilding the neighbour list; side by side with LAMMPS (GRANULAR package) on the same
//! particles, contact model, time step and skin (`benches/peer_lammps_dem.in`), measured in the
//! same run.
//!
//! The bed: about N spheres d = 400 um, 2500 kg/m^3, every one in contact from the start (see
//! `bed`), E = 1e7 Pa, nu = 0.3, e = 0.5, mu = 0.3, gravity 9.81 m/s^2; both codes start from
//! the same positions at rest and run the same number of steps with the same dt and skin.

use crate::dem::{
    ContactModel, DampingModel, Dem, ImpactSpeed, Material, NormalModel, Particles, Setup, Start,
    TangentialModel,
};
use crate::error::{invalid, Error};
use crate::Result;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Numbers of spheres, comma-separated.
    #[arg(long, default_value = "1000,8000,27000")]
    pub sizes: String,
    /// Steps per run.
    #[arg(long, default_value_t = 2000)]
    pub steps: u64,
    /// The LAMMPS binary (Debian's package installs `lmp`).
    #[arg(long, default_value = "lmp")]
    pub lammps: String,
    /// Skip the LAMMPS runs.
    #[arg(long)]
    pub no_peer: bool,
    /// Rounds per size, each running porelab on one thread, on two, and LAMMPS, in turn; every
    /// figure is the best of the rounds (as STREAM reports), so that a round slowed by other
    /// work on a shared machine does not count against either code.
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Output folder for the table and the peer's files.
    #[arg(long, default_value = "target/porelab/bench-dem")]
    pub out: PathBuf,
}

const D: f64 = 4e-4;
const RHO: f64 = 2500.0;
const E_PA: f64 = 1e7;
const NU: f64 = 0.3;
const RESTITUTION: f64 = 0.5;
const MU: f64 = 0.3;

/// The bed for about `n` spheres: a simple cubic lattice m x m x nz (m = round(n^(1/3))) of
/// spacing d (1 - 1e-3), jittered by up to 1e-3 d: every sphere starts in contact with its six
/// neighbours (overlap ~ 1e-3 d, that of a bed under its weight), so the pair forces, the
/// tangential history and the walls are all exercised from the first step. The impact speed of
/// the time-step rule is 0.1 m/s.
fn bed(n: usize) -> Result<Setup> {
    let m = ((n as f64).cbrt().round() as usize).max(3);
    let nz = ((n as f64 / (m * m) as f64).round() as usize).max(1);
    let a = D * (1.0 - 1e-3);
    let l = m as f64 * a;
    let h = nz as f64 * a + D;
    let mat = Material::new(E_PA, NU)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(24);
    let mut pos = Vec::with_capacity(m * m * nz);
    for k in 0..nz {
        for j in 0..m {
            for i in 0..m {
                let jit = Vector3::new(
                    rng.gen::<f64>() - 0.5,
                    rng.gen::<f64>() - 0.5,
                    rng.gen::<f64>() - 0.5,
                ) * (1e-3 * D);
                pos.push(
                    Vector3::new(
                        (i as f64 + 0.5) * a,
                        (j as f64 + 0.5) * a,
                        (k as f64 + 0.5) * a,
                    ) + jit,
                );
            }
        }
    }
    let radius = vec![0.5 * D; pos.len()];
    let contact = ContactModel::new(
        NormalModel::Hertz,
        DampingModel::restitution(RESTITUTION)?,
        TangentialModel::mindlin(MU, 1.0)?,
    )?;
    let start = Start::Given(Particles::at_rest(pos, radius, RHO));
    let mut setup = Setup::in_box([l, l, h], contact, mat, RHO, start);
    setup.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
    setup.impact_speed = ImpactSpeed::Given { m_s: 0.1 };
    setup.skin_m = Some(0.3 * D);
    Ok(setup)
}

/// (seconds, neighbour seconds, final positions) of `steps` steps on `threads` threads.
/// CPU seconds of the calling thread (Linux `/proc/thread-self/schedstat`; NaN elsewhere).
/// On a shared machine the CPU time of a one-thread run measures its cost per core where the
/// wall time also counts the time other processes held the core.
pub(super) fn thread_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(f64::NAN, |ns| ns * 1e-9)
}

/// Wall seconds, CPU seconds (one thread only, else NaN), neighbour seconds, dt, positions.
type Timing = (f64, f64, f64, f64, Vec<Vector3<f64>>);

fn time_porelab(n: usize, steps: u64, threads: usize) -> Result<Timing> {
    let setup = bed(n)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::InvalidInput(format!("thread pool: {e}")))?;
    pool.install(|| {
        let mut dem = Dem::new(setup)?;
        let dt = dem.dt_s();
        dem.neighbour_seconds = 0.0;
        let cpu0 = thread_cpu_seconds();
        let t = Instant::now();
        dem.run(steps)?;
        let wall = t.elapsed().as_secs_f64();
        // one thread: the pool's only worker does all the work, so its CPU time is the run's
        let cpu = if threads == 1 {
            thread_cpu_seconds() - cpu0
        } else {
            f64::NAN
        };
        Ok((wall, cpu, dem.neighbour_seconds, dt, dem.p.pos.clone()))
    })
}

/// LAMMPS loop seconds (wall), its CPU seconds (wall times its reported "% CPU use") and
/// neighbour share for the same bed; an error message when it cannot run.
fn time_lammps(
    args: &BenchArgs,
    n: usize,
    dt: f64,
) -> Result<std::result::Result<(f64, f64, f64), String>> {
    let setup = bed(n)?;
    let pos = match &setup.start {
        Start::Given(p) => &p.pos,
        Start::Dispersed { .. } => return invalid("bench dem: the bed's particles are given"),
    };
    let dir = &args.out;
    std::fs::create_dir_all(dir)?;
    let data = dir.join(format!("bed_{n}.data"));
    let mut s = String::new();
    let _ = writeln!(
        s,
        "porelab bench dem bed, {n} spheres\n\n{n} atoms\n1 atom types\n"
    );
    let top = setup.top.z0_m();
    let _ = writeln!(
        s,
        "0 {} xlo xhi\n0 {} ylo yhi\n0 {} zlo zhi\n",
        setup.lx_m, setup.ly_m, top
    );
    let _ = writeln!(s, "Atoms # sphere\n");
    for (i, x) in pos.iter().enumerate() {
        let _ = writeln!(s, "{} 1 {} {} {} {} {}", i + 1, D, RHO, x.x, x.y, x.z);
    }
    crate::io::write_atomic(&data, s.as_bytes())?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/peer_lammps_dem.in");
    let out = std::process::Command::new(&args.lammps)
        .arg("-in")
        .arg(&script)
        .args(["-log", "none", "-nocite"])
        .args(["-var", "data"])
        .arg(&data)
        .args(["-var", "dt", &format!("{dt:e}")])
        .args(["-var", "skin", &format!("{:e}", 0.3 * D)])
        .args(["-var", "steps", &args.steps.to_string()])
        .args(["-var", "E", &format!("{E_PA:e}")])
        .args(["-var", "nu", &NU.to_string()])
        .args(["-var", "e", &RESTITUTION.to_string()])
        .args(["-var", "mu", &MU.to_string()])
        .args(["-var", "top", &format!("{top:e}")])
        .env("OMP_NUM_THREADS", "1")
        .output();
    let out = match out {
        Ok(o) => o,
        Err(e) => return Ok(Err(format!("cannot start `{}`: {e}", args.lammps))),
    };
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    std::fs::write(dir.join(format!("lammps_{n}.out")), &text)?;
    let loop_s = text
        .lines()
        .find(|l| l.starts_with("Loop time of"))
        .and_then(|l| l.split_whitespace().nth(3))
        .and_then(|x| x.parse::<f64>().ok());
    let neigh = text
        .lines()
        .find(|l| l.starts_with("Neigh "))
        .and_then(|l| l.split('|').nth(5))
        .and_then(|x| x.trim().parse::<f64>().ok());
    let cpu_share = text
        .lines()
        .find(|l| l.contains("% CPU use"))
        .and_then(|l| l.split('%').next())
        .and_then(|x| x.trim().parse::<f64>().ok())
        .map_or(f64::NAN, |p| p / 100.0);
    match loop_s {
        Some(t) => Ok(Ok((t, t * cpu_share, neigh.unwrap_or(f64::NAN) / 100.0))),
        None => Ok(Err(format!(
            "LAMMPS gave no loop time (status {}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ))),
    }
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let sizes: Vec<usize> = args
        .sizes
        .split(',')
        .map(|s| s.trim().parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::InvalidInput(format!("--sizes '{}': {e}", args.sizes)))?;
    if sizes.iter().any(|&n| n < 10) || args.steps == 0 || args.rounds == 0 {
        return invalid("--sizes: each at least 10; --steps and --rounds: at least 1");
    }
    // the lattice beds hold m^2 nz spheres, close to the requested sizes
    let mut csv = String::from(
        "n,steps,rounds,dt_s,porelab_1t_us_per_particle_step,porelab_2t_us_per_particle_step,speedup_2t,\
         porelab_neighbour_share,lammps_1core_us_per_particle_step,lammps_neighbour_share,\
         lammps_over_porelab_1t,porelab_1t_cpu_us_per_particle_step,\
         lammps_cpu_us_per_particle_step,lammps_over_porelab_cpu,identical_1t_2t\n",
    );
    println!(
        "{:>7} {:>10} {:>12} {:>12} {:>7} {:>7} {:>12} {:>7} {:>8} {:>10} {:>10} {:>8} {:>6}",
        "N",
        "dt (s)",
        "1t us/p-s",
        "2t us/p-s",
        "2t x",
        "neigh",
        "LAMMPS us",
        "neigh",
        "ratio",
        "1t cpu us",
        "LAMMPS cpu",
        "cpu ratio",
        "same"
    );
    for &n_req in &sizes {
        let n = bed(n_req)?.start.radii().len();
        let ps = (n as u64 * args.steps) as f64;
        // best of the rounds for every figure; a neighbour share is that of its code's fastest
        // round
        let (mut t1, mut c1, mut nb1, mut t2) = (f64::INFINITY, f64::INFINITY, 0.0, f64::INFINITY);
        let mut dt = f64::NAN;
        let mut same = true;
        let mut peer: std::result::Result<(f64, f64, f64), String> =
            Err("skipped (--no-peer)".to_string());
        for _ in 0..args.rounds {
            let (t, c, nb, dt1, p1) = time_porelab(n, args.steps, 1)?;
            if t < t1 {
                (t1, nb1) = (t, nb);
            }
            c1 = c1.min(c);
            dt = dt1;
            let (t, _, _, _, p2) = time_porelab(n, args.steps, 2)?;
            t2 = t2.min(t);
            same &= p1 == p2;
            if !args.no_peer {
                peer = match (time_lammps(args, n, dt)?, peer) {
                    // the neighbour share of LAMMPS's fastest round, as for porelab's
                    (Ok(a), Ok(b)) => Ok((
                        a.0.min(b.0),
                        a.1.min(b.1),
                        if a.0 < b.0 { a.2 } else { b.2 },
                    )),
                    (Ok(a), Err(_)) => Ok(a),
                    (Err(e), _) => Err(e),
                };
            }
        }
        let (lus, lcpu, lnb, ratio) = match &peer {
            Ok((t, c, nb)) => (t / ps * 1e6, c / ps * 1e6, *nb, t / t1),
            Err(_) => (f64::NAN, f64::NAN, f64::NAN, f64::NAN),
        };
        let cpu_us = c1 / ps * 1e6;
        let cpu_ratio = lcpu / cpu_us;
        // a peer figure that was not measured prints as "-" (empty in the CSV), never as NaN
        let shown = |x: f64, prec: usize| {
            if x.is_finite() {
                format!("{x:.prec$}")
            } else {
                "-".to_string()
            }
        };
        let csv_cell = |x: f64| {
            if x.is_finite() {
                format!("{x}")
            } else {
                String::new()
            }
        };
        println!(
            "{n:>7} {dt:>10.3e} {:>12.4} {:>12.4} {:>7.2} {:>7.3} {:>12} {:>7} {:>8} {:>10.4} \
             {:>10} {:>8} {:>6}",
            t1 / ps * 1e6,
            t2 / ps * 1e6,
            t1 / t2,
            nb1 / t1,
            shown(lus, 4),
            shown(lnb, 3),
            shown(ratio, 2),
            cpu_us,
            shown(lcpu, 4),
            shown(cpu_ratio, 2),
            same
        );
        if let Err(msg) = &peer {
            println!("        peer: {msg}");
        }
        let _ = writeln!(
            csv,
            "{n},{},{},{dt},{},{},{},{},{},{},{},{cpu_us},{},{},{same}",
            args.steps,
            args.rounds,
            t1 / ps * 1e6,
            t2 / ps * 1e6,
            t1 / t2,
            nb1 / t1,
            csv_cell(lus),
            csv_cell(lnb),
            csv_cell(ratio),
            csv_cell(lcpu),
            csv_cell(cpu_ratio)
        );
    }
    crate::io::write_atomic(&args.out.join("bench_dem.csv"), csv.as_bytes())?;
    println!("table: {}", args.out.join("bench_dem.csv").display());
    Ok(())
}
