//! `porelab bench brownian`: the cost of an Ermak–McCammon step (thesis 003, eq. 6.11) and the
//! accuracy bought with the time step, plus the harmonic-trap driver shared with validation
//! case 413.
//!
//! Sections (all on ONE thread: a one-thread rayon pool, and the engine itself is serial, so
//! the rates are per core):
//! 1. throughput: particle-steps per second against N (10 ... 1000, `--max-n`) for
//!    free-draining, RPY with Cholesky noise (eq. 6.16) and RPY with TEA-HI noise, thesis
//!    parameters (section 6.3: R = 75 nm, T = 298 K, eta = 1 mPa s, Mie(30, 15) with
//!    eps = 100 kB T), except dt = 1e-6 s instead of 5e-5 s (at 5e-5 s the noise moves a
//!    particle 0.23 R rms per coordinate and step, pairs land deep in the Mie core and the step
//!    guard refuses even after 20 halvings), on random dilute configurations (volume fraction
//!    0.01, no pair closer than 2.2 R); the crossover N from which TEA-HI beats Cholesky;
//! 2. field share: the same particles next to a transversely magnetized cylinder (D = 600 um,
//!    L = 3 mm, Ms = 985 kA/m, Stoner–Wohlfarth in 1 T along x, Table 6.1 moment
//!    0.870e-16 A m^2, dipole pairs within 30 R): the time of the field source alone on the
//!    same positions, times the number of field evaluations per particle and step (counted:
//!    sub-steps evaluate the field again), against the time of a whole step;
//! 3. work-precision against the time step: the MSD of free particles against 6 D t and the
//!    drift under a constant force against mu F t (both exact in distribution for the
//!    Ermak–McCammon update, so their errors are purely statistical and are printed with their
//!    standard errors), and the stationary variance in a harmonic trap against kB T / k, where
//!    the update has the real O(dt) bias 1 / (1 - a/2) - 1, a = mu k dt.
//!
//! Output: tables on stdout and `target/porelab/bench-brownian-{throughput,field,
//! work-precision}.csv` (units in the headers).
//!
//! Harmonic trap: an isotropic external force F = -k r about the origin, put into the engine
//! through its position-dependent external-force hook, the field source of
//! [`Magnetic`]: a closure returning a uniform H0 (so that a
//! [`LangevinMoment::Fixed`] moment m0 points along x) together with the "gradient"
//! G(r) = -(k / (mu0 m0)) r e_x^T, so that the force of eq. 6.20 as implemented,
//! mu0 G m = -k r. This is not a Maxwell field (a moment along H cannot be trapped by a real
//! field: |H| has no maximum in free space), it is only the engine's generic hook for an
//! external force; the whole force path (field source -> moment law -> mu0 G m -> update
//! eq. 6.11) is exercised.

use crate::brownian::driver::{run_sampled, run_steps};
use crate::brownian::forces::{FieldSource, LangevinMoment, Mie, WithUniform};
use crate::brownian::magnetization::stoner_wohlfarth_magnet;
use crate::brownian::{
    cubic_lattice, run_rng, stokes_mobility, Fluid, Hydrodynamics, Magnetic, NoiseMethod,
    Particles, Setup, Simulation, StepGuard,
};
use crate::consts::{KB, MU0};
use crate::driver::{Hooks, NoHooks};
use crate::error::{invalid, Result};
use crate::magnetics::kernel::Regime;
use crate::magnetics::Cylinder;
use nalgebra::{Matrix3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Largest N of the sweep over N = 10, 20, 50, 100, 200, 500, 1000.
    #[arg(long, default_value_t = 1000)]
    pub max_n: usize,
    /// Short run: N up to 200 (or --max-n if smaller), shorter timing budgets, fewer samples.
    #[arg(long)]
    pub quick: bool,
}

const SIZES: [usize; 7] = [10, 20, 50, 100, 200, 500, 1000];
/// Thesis section 6.3 parameters, except the time step: at the thesis dt = 5e-5 s the noise
/// moves a 75 nm particle by 0.23 R rms per coordinate and step, so pairs of the dilute cloud
/// land deep inside the Mie(30, 15) core (where the force reaches 1e-6 N) and the step guard
/// refuses even after 20 halvings; dt = 1e-6 s (0.033 R rms) keeps overlaps shallow.
const RADIUS: f64 = 75e-9;
const TEMPERATURE: f64 = 298.0;
const VISCOSITY: f64 = 1.0e-3;
const DT: f64 = 1e-6;
/// Table 6.1 moment of the R_h = 75 nm particles (A m^2).
const MOMENT: f64 = 0.870e-16;
const VOLUME_FRACTION: f64 = 0.01;
const SEED: u64 = 20261124;
/// Lower corner (m) of the dilute cloud of the field-share scene: 20 um from the cylinder
/// surface on the +x side, at mid-length (the thesis SIDE region, largest field gradient).
const FIELD_CLOUD_CORNER: Vector3<f64> = Vector3::new(320e-6, -2e-6, -2e-6);

#[derive(Debug, Clone, Copy, PartialEq)]
enum Method {
    Free,
    RpyCholesky,
    RpyTeaHi,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Free => "free-draining",
            Method::RpyCholesky => "RPY+Cholesky",
            Method::RpyTeaHi => "RPY+TEA-HI",
        }
    }
    fn apply(self, setup: &mut Setup) {
        (setup.hydrodynamics, setup.noise) = match self {
            Method::Free => (Hydrodynamics::FreeDraining, NoiseMethod::Cholesky),
            Method::RpyCholesky => (Hydrodynamics::Rpy, NoiseMethod::Cholesky),
            Method::RpyTeaHi => (Hydrodynamics::Rpy, NoiseMethod::TeaHi),
        };
    }
}

/// `n` centres uniform in a cube (lower corner `corner`, m) sized for the volume fraction
/// [`VOLUME_FRACTION`], no two closer than 2.2 R (beyond the Mie cut-off 2 R 2^(1/15)).
fn dilute_positions(n: usize, corner: Vector3<f64>, rng: &mut ChaCha8Rng) -> Vec<Vector3<f64>> {
    let side = (n as f64 * 4.0 / 3.0 * PI * RADIUS.powi(3) / VOLUME_FRACTION).cbrt();
    let dmin2 = (2.2 * RADIUS).powi(2);
    let mut p: Vec<Vector3<f64>> = Vec::with_capacity(n);
    while p.len() < n {
        let q = corner + Vector3::new(rng.gen(), rng.gen(), rng.gen()) * side;
        if p.iter().all(|x| (x - q).norm_squared() >= dmin2) {
            p.push(q);
        }
    }
    p
}

/// A thesis-parameter setup of the given particles: Mie(30, 15) repulsion, the given
/// mobility/noise, and a sub-stepping guard (fresh forces and noise on each half step).
fn thesis_setup(positions: Vec<Vector3<f64>>, method: Method) -> Result<Setup> {
    let fluid = Fluid::new(TEMPERATURE, VISCOSITY)?;
    let mut setup = Setup::new(Particles::new(positions, RADIUS)?, fluid, DT)?;
    method.apply(&mut setup);
    setup.repulsion = Some(Mie::thesis_default(fluid.kt(), RADIUS)?);
    setup.guard = StepGuard::Substep {
        max_fraction: 0.1,
        max_halvings: 30,
    };
    Ok(setup)
}

/// Counts the steps and stops the run once `budget` seconds have passed.
struct Budget {
    t0: Instant,
    budget: f64,
    steps: u64,
}

impl Hooks<Simulation> for Budget {
    fn progress(&mut self, _: &Simulation, _: Option<f64>, _: &str) {
        self.steps += 1;
    }
    fn stop_requested(&mut self, _: &Simulation) -> bool {
        self.t0.elapsed().as_secs_f64() >= self.budget
    }
}

/// Steps until `budget` seconds have passed (at least one step): (steps, seconds).
fn timed_steps(sim: &mut Simulation, budget: f64) -> Result<(u64, f64)> {
    let mut b = Budget {
        t0: Instant::now(),
        budget,
        steps: 0,
    };
    run_steps(sim, u64::MAX, &mut b)?;
    Ok((b.steps, b.t0.elapsed().as_secs_f64()))
}

/// A field source that counts its evaluations (to see sub-steps in the field share).
struct Counted<S> {
    inner: S,
    calls: Arc<AtomicU64>,
}

impl<S: FieldSource> FieldSource for Counted<S> {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        self.calls.fetch_add(1, Ordering::Relaxed);
        self.inner.h_and_gradient(p)
    }
}

/// The thesis capture scene's field: a cylinder D = 600 um, L = 3 mm along z at the origin,
/// magnetized by Stoner–Wohlfarth (Ms = 985 kA/m) in the applied 1 T along x, plus that
/// applied field.
fn cylinder_field() -> Result<WithUniform<crate::magnetics::Magnet>> {
    let h0 = Vector3::new(1.0 / MU0, 0.0, 0.0);
    let magnet = stoner_wohlfarth_magnet(
        Cylinder::new(300e-6, 1.5e-3)?,
        Vector3::zeros(),
        Vector3::new(0.0, 0.0, 1.0),
        &h0,
        985e3,
    )?;
    Ok(WithUniform { h0, source: magnet })
}

struct ThroughputRow {
    n: usize,
    method: Method,
    steps: u64,
    seconds: f64,
}

impl ThroughputRow {
    fn rate(&self) -> f64 {
        (self.n as u64 * self.steps) as f64 / self.seconds
    }
}

struct FieldRow {
    n: usize,
    method: Method,
    step_time: f64,
    field_time: f64,
    evals_per_particle_step: f64,
}

/// One point of a work-precision sweep: relative error of a measured quantity against its
/// continuous-time value, with its standard error and the exact error of the discrete process.
struct PrecisionRow {
    quantity: &'static str,
    dt: f64,
    steps: u64,
    seconds: f64,
    rel_error: f64,
    std_error: f64,
    exact_discrete: f64,
    /// Cost in wall-clock seconds (one thread) per particle per unit of the quantity's time scale.
    cost: f64,
}

fn sizes(args: &BenchArgs) -> Vec<usize> {
    let max = if args.quick {
        args.max_n.min(200)
    } else {
        args.max_n
    };
    SIZES.iter().copied().filter(|&n| n <= max).collect()
}

fn throughput(sizes: &[usize], budget: f64) -> Result<Vec<ThroughputRow>> {
    let mut rows = Vec::new();
    for &n in sizes {
        let pos = dilute_positions(n, Vector3::zeros(), &mut run_rng(SEED, n as u64));
        for method in [Method::Free, Method::RpyCholesky, Method::RpyTeaHi] {
            let setup = thesis_setup(pos.clone(), method)?;
            let mut sim = Simulation::new(setup, run_rng(SEED, 1000 + n as u64))?;
            let (steps, seconds) = timed_steps(&mut sim, budget)?;
            rows.push(ThroughputRow {
                n,
                method,
                steps,
                seconds,
            });
        }
    }
    Ok(rows)
}

/// The smallest N of the sweep from which TEA-HI is faster than Cholesky at every larger N.
fn crossover(rows: &[ThroughputRow]) -> Option<usize> {
    let rate = |n: usize, m: Method| {
        rows.iter()
            .find(|r| r.n == n && r.method == m)
            .map(ThroughputRow::rate)
    };
    let ns: Vec<usize> = rows
        .iter()
        .filter(|r| r.method == Method::Free)
        .map(|r| r.n)
        .collect();
    let faster = |n: usize| rate(n, Method::RpyTeaHi) > rate(n, Method::RpyCholesky);
    // Walk down from the largest N while TEA-HI stays faster.
    let k = ns.len() - ns.iter().rev().take_while(|&&n| faster(n)).count();
    ns.get(k).copied()
}

fn field_share(sizes: &[usize], budget: f64) -> Result<Vec<FieldRow>> {
    let mut rows = Vec::new();
    let corner = FIELD_CLOUD_CORNER;
    for &n in sizes {
        let pos = dilute_positions(n, corner, &mut run_rng(SEED, 2000 + n as u64));
        for method in [Method::Free, Method::RpyTeaHi] {
            let calls = Arc::new(AtomicU64::new(0));
            let mut setup = thesis_setup(pos.clone(), method)?;
            setup.magnetic = Some(Magnetic {
                source: Box::new(Counted {
                    inner: cylinder_field()?,
                    calls: calls.clone(),
                }),
                moment: LangevinMoment::fixed(MOMENT)?,
                dipole_pairs: true,
                cutoff: 30.0 * RADIUS,
            });
            let mut sim = Simulation::new(setup, run_rng(SEED, 3000 + n as u64))?;
            let (steps, seconds) = timed_steps(&mut sim, budget)?;
            let evals = calls.load(Ordering::Relaxed) as f64 / (n as f64 * steps as f64);
            // The field source alone on the same (final) positions, same object.
            let source = match sim.magnetic() {
                Some(m) => &m.source,
                None => return invalid("field-share scene lost its field source"),
            };
            let t0 = Instant::now();
            let mut reps = 0u64;
            let mut sink = 0.0;
            while reps == 0 || t0.elapsed().as_secs_f64() < 0.25 * budget {
                for p in &sim.particles().positions {
                    sink += source.h_and_gradient(p).1[(0, 0)];
                }
                reps += 1;
            }
            std::hint::black_box(sink);
            rows.push(FieldRow {
                n,
                method,
                step_time: seconds / steps as f64,
                field_time: t0.elapsed().as_secs_f64() / reps as f64,
                evals_per_particle_step: evals,
            });
        }
    }
    Ok(rows)
}

/// Free particles (no forces, free-draining) on a cubic lattice, moved for `t_end` in steps of
/// t_end / 2^k: MSD against 6 D t and, with the constant force `force` (N, along x), the mean
/// x displacement against mu F t. Both are exact in distribution for the Ermak–McCammon
/// update (eq. 6.11 with constant D and F), so the error is statistical: the standard errors
/// are sqrt(2 / (3 N)) (the MSD sum is (2 D t) chi-square(3N)) and sqrt(2 D t / N) / (mu F t).
fn free_sweeps(n: usize, levels: u32, t_end: f64, force: f64) -> Result<Vec<PrecisionRow>> {
    let mu = stokes_mobility(VISCOSITY, RADIUS)?;
    let d = KB * TEMPERATURE * mu;
    let p0 = cubic_lattice(n, 4.0 * RADIUS);
    let mut rows = Vec::new();
    for k in 0..=levels {
        let steps = 1u64 << k;
        let dt = t_end / steps as f64;
        for (quantity, f) in [("MSD / (6 D t)", 0.0), ("drift / (mu F t)", force)] {
            let mut setup = Setup::new(
                Particles::new(p0.clone(), RADIUS)?,
                Fluid::new(TEMPERATURE, VISCOSITY)?,
                dt,
            )?;
            setup.constant_force = Vector3::new(f, 0.0, 0.0);
            // No repulsion here: the guard protects nothing and must not refuse the drift.
            setup.guard = StepGuard::Refuse {
                max_fraction: f64::INFINITY,
            };
            let rng = run_rng(SEED, 4000 + 2 * k as u64 + (f != 0.0) as u64);
            let mut sim = Simulation::new(setup, rng)?;
            let t0 = Instant::now();
            run_steps(&mut sim, steps, &mut NoHooks)?;
            let seconds = t0.elapsed().as_secs_f64();
            let disp = sim
                .particles()
                .positions
                .iter()
                .zip(&p0)
                .map(|(p, q)| p - q);
            let (rel_error, std_error) = if f == 0.0 {
                let msd = disp.map(|v| v.norm_squared()).sum::<f64>() / n as f64;
                (
                    msd / (6.0 * d * t_end) - 1.0,
                    (2.0 / (3.0 * n as f64)).sqrt(),
                )
            } else {
                let drift = mu * f * t_end;
                let mean = disp.map(|v| v.x).sum::<f64>() / n as f64;
                (
                    mean / drift - 1.0,
                    (2.0 * d * t_end / n as f64).sqrt() / drift,
                )
            };
            rows.push(PrecisionRow {
                quantity,
                dt,
                steps,
                seconds,
                rel_error,
                std_error,
                exact_discrete: 0.0,
                cost: seconds / (n as f64 * t_end),
            });
        }
    }
    Ok(rows)
}

/// Stationary variance in the trap k = kB T / R^2 against kB T / k for a = mu k dt in `a_list`:
/// n particles (independent, free-draining), burn-in 25/a steps, then the mean of x^2 over all
/// coordinates and `sample_steps` consecutive steps. The exact discrete-time value is
/// 1 / (1 - a/2) (see case 413); the samples form 3n stationary Gaussian AR(1) chains with
/// lag-one correlation rho = 1 - a, so the standard error of the mean of x^2 is
/// s^2 sqrt(2 (1 + rho^2) / ((1 - rho^2) M)), M = 3 n sample_steps. Cost: wall-clock seconds
/// per particle per relaxation time 1/(mu k).
fn trap_sweep(n: usize, a_list: &[f64], sample_steps: u64) -> Result<Vec<PrecisionRow>> {
    let mu = stokes_mobility(VISCOSITY, RADIUS)?;
    let kt = KB * TEMPERATURE;
    let k = kt / (RADIUS * RADIUS);
    let lattice = cubic_lattice(n, 2.002 * RADIUS);
    let c = lattice.iter().sum::<Vector3<f64>>() / n as f64;
    let p0: Vec<Vector3<f64>> = lattice.iter().map(|q| q - c).collect();
    let mut rows = Vec::new();
    for (i, &a) in a_list.iter().enumerate() {
        let dt = a / (mu * k);
        let mut setup = Setup::new(
            Particles::new(p0.clone(), RADIUS)?,
            Fluid::new(TEMPERATURE, VISCOSITY)?,
            dt,
        )?;
        setup.magnetic = Some(Magnetic::harmonic_trap(k)?);
        // No repulsion: the guard protects nothing (the recursion is stable for a < 2).
        setup.guard = StepGuard::Refuse {
            max_fraction: f64::INFINITY,
        };
        let mut sim = Simulation::new(setup, run_rng(SEED, 5000 + i as u64))?;
        run_steps(&mut sim, (25.0 / a).ceil() as u64, &mut NoHooks)?;
        let t0 = Instant::now();
        let mut sum = 0.0;
        run_sampled(&mut sim, sample_steps, 1, &mut NoHooks, |sim| {
            sum += sim
                .particles()
                .positions
                .iter()
                .map(|p| p.norm_squared())
                .sum::<f64>();
            Ok(())
        })?;
        let seconds = t0.elapsed().as_secs_f64();
        let m = 3.0 * n as f64 * sample_steps as f64;
        let ratio = sum / m / (kt / k);
        let exact = 1.0 / (1.0 - 0.5 * a);
        let rho2 = (1.0 - a) * (1.0 - a);
        rows.push(PrecisionRow {
            quantity: "trap variance / (kB T / k)",
            dt,
            steps: sample_steps,
            seconds,
            rel_error: ratio - 1.0,
            std_error: exact * (2.0 * (1.0 + rho2) / ((1.0 - rho2) * m)).sqrt(),
            exact_discrete: exact - 1.0,
            cost: seconds / (n as f64 * sample_steps as f64 * a),
        });
    }
    Ok(rows)
}

/// A table cell.
enum V {
    T(String),
    I(u64),
    F(f64),
}

/// How a column is shown on stdout: scientific or fixed with this many digits.
#[derive(Clone, Copy)]
enum Fmt {
    Sci(usize),
    Fix(usize),
}

/// A column: title on stdout, name in the CSV header (with units), width and format on stdout.
struct Col(&'static str, &'static str, usize, Fmt);

/// Prints `rows` as a right-aligned table (if `print`) and writes them to `path` as CSV
/// (numbers in full `{:.6e}`).
fn emit(cols: &[Col], rows: &[Vec<V>], path: &std::path::Path, print: bool) -> Result<()> {
    let mut csv = cols.iter().map(|c| c.1).collect::<Vec<_>>().join(",") + "\n";
    if print {
        let head: Vec<String> = cols
            .iter()
            .map(|c| format!("{:>w$}", c.0, w = c.2))
            .collect();
        println!("{}", head.join(" "));
    }
    for row in rows {
        let mut shown = Vec::new();
        let mut cells = Vec::new();
        for (c, v) in cols.iter().zip(row) {
            let (s, f) = match (v, c.3) {
                (V::T(t), _) => (t.clone(), t.clone()),
                (V::I(i), _) => (i.to_string(), i.to_string()),
                (V::F(x), Fmt::Sci(d)) => (format!("{x:.d$e}"), format!("{x:.6e}")),
                (V::F(x), Fmt::Fix(d)) => (format!("{x:.d$}"), format!("{x:.6e}")),
            };
            shown.push(format!("{s:>w$}", w = c.2));
            cells.push(f);
        }
        if print {
            println!("{}", shown.join(" "));
        }
        csv.push_str(&cells.join(","));
        csv.push('\n');
    }
    crate::io::write_atomic(path, csv.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// `porelab bench brownian`.
pub fn run(args: &BenchArgs) -> Result<()> {
    let sizes = sizes(args);
    if sizes.is_empty() {
        return invalid(format!(
            "--max-n {}: must be at least {} (the smallest N of the sweep)",
            args.max_n, SIZES[0]
        ));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| crate::Error::InvalidInput(format!("thread pool: {e}")))?;
    pool.install(|| run_single_thread(args, &sizes))
}

fn run_single_thread(args: &BenchArgs, sizes: &[usize]) -> Result<()> {
    let budget = if args.quick { 0.1 } else { 0.5 };
    println!(
        "porelab bench brownian: one thread; thesis parameters R = {RADIUS:e} m, T = {TEMPERATURE} K, \
         eta = {VISCOSITY} Pa s, dt = {DT:e} s, Mie(30,15) eps = 100 kB T, volume fraction \
         {VOLUME_FRACTION}; timing budget {budget} s (wall clock) per point"
    );
    // Under the working folder, like every other output (not the build's source path).
    let dir = std::path::Path::new("target/porelab");
    std::fs::create_dir_all(dir)?;

    // 1. Throughput.
    let tp = throughput(sizes, budget)?;
    println!("\n1. throughput (particle-steps per second, one thread)");
    println!(
        "{:>6} {:>16} {:>16} {:>16} {:>12}",
        "N", "free-draining", "RPY+Cholesky", "RPY+TEA-HI", "TEA/Chol"
    );
    for &n in sizes {
        let rate = |m: Method| {
            tp.iter()
                .find(|r| r.n == n && r.method == m)
                .map_or(f64::NAN, ThroughputRow::rate)
        };
        let (f, c, t) = (
            rate(Method::Free),
            rate(Method::RpyCholesky),
            rate(Method::RpyTeaHi),
        );
        println!("{n:>6} {f:>16.4e} {c:>16.4e} {t:>16.4e} {:>12.3}", t / c);
    }
    match crossover(&tp) {
        Some(n) => println!("TEA-HI faster than Cholesky from N = {n} on (within this sweep)"),
        None => println!("TEA-HI not faster than Cholesky at the largest N of this sweep"),
    }
    let rows: Vec<Vec<V>> = tp
        .iter()
        .map(|r| {
            vec![
                V::I(r.n as u64),
                V::T(r.method.name().into()),
                V::I(r.steps),
                V::F(r.seconds),
                V::F(r.rate()),
            ]
        })
        .collect();
    let cols = [
        Col("N", "n_particles", 6, Fmt::Sci(0)),
        Col("method", "method", 14, Fmt::Sci(0)),
        Col("steps", "steps", 8, Fmt::Sci(0)),
        Col("wall [s]", "seconds_s", 11, Fmt::Sci(3)),
        Col("p-steps/s", "particle_steps_per_s", 11, Fmt::Sci(3)),
    ];
    emit(
        &cols,
        &rows,
        &dir.join("bench-brownian-throughput.csv"),
        false,
    )?;

    // 2. Field-evaluation share.
    let fr = field_share(sizes, budget)?;
    println!("\n2. field-evaluation share (magnetized cylinder, dipole pairs, one thread)");
    let rows: Vec<Vec<V>> = fr
        .iter()
        .map(|r| {
            // Sub-steps evaluate the field more than once per step: count every evaluation.
            let share = r.evals_per_particle_step * r.field_time / r.step_time;
            vec![
                V::I(r.n as u64),
                V::T(r.method.name().into()),
                V::F(r.step_time),
                V::F(r.field_time),
                V::F(r.evals_per_particle_step),
                V::F(share),
            ]
        })
        .collect();
    let cols = [
        Col("N", "n_particles", 6, Fmt::Sci(0)),
        Col("method", "method", 14, Fmt::Sci(0)),
        Col("step [s]", "step_time_s", 11, Fmt::Sci(3)),
        Col("field pass [s]", "field_time_one_pass_s", 14, Fmt::Sci(3)),
        Col(
            "evals/p-step",
            "field_evals_per_particle_step",
            12,
            Fmt::Fix(3),
        ),
        Col("share", "field_share", 7, Fmt::Fix(3)),
    ];
    emit(&cols, &rows, &dir.join("bench-brownian-field.csv"), true)?;
    let cloud = dilute_positions(
        sizes[sizes.len() - 1],
        FIELD_CLOUD_CORNER,
        &mut run_rng(SEED, 2000 + sizes[sizes.len() - 1] as u64),
    );
    let cyl = cylinder_field()?.source.cylinder;
    let mut regimes = [0usize; 3];
    for p in &cloud {
        // The cylinder sits at the origin along z, so world and cylinder frames coincide.
        regimes[cyl.field_tensor_with_regime(p).1 as usize] += 1;
    }
    println!(
        "field kernel regimes at the cloud (N = {}): multipole {}, slab quadrature {}, closed form {}",
        cloud.len(),
        regimes[Regime::Multipole as usize],
        regimes[Regime::SlabQuadrature as usize],
        regimes[Regime::ClosedForm as usize]
    );

    // 3. Work-precision.
    let (n_free, levels, n_trap, trap_steps) = if args.quick {
        (2000, 5, 300, 1000)
    } else {
        (10000, 8, 1000, 4000)
    };
    let a_list: &[f64] = if args.quick {
        &[0.8, 0.4, 0.2, 0.1]
    } else {
        &[0.8, 0.4, 0.2, 0.1, 0.05, 0.025]
    };
    let mut wp = free_sweeps(n_free, levels, 0.01, 1e-13)?;
    wp.extend(trap_sweep(n_trap, a_list, trap_steps)?);
    println!(
        "\n3. work-precision (one thread): relative error against the continuous-time value, \
         its standard error, the exact error of the discrete process, and z = (error - exact) / \
         standard error"
    );
    let rows: Vec<Vec<V>> = wp
        .iter()
        .map(|r| {
            vec![
                V::T(r.quantity.into()),
                V::F(r.dt),
                V::I(r.steps),
                V::F(r.seconds),
                V::F(r.rel_error),
                V::F(r.std_error),
                V::F(r.exact_discrete),
                V::F((r.rel_error - r.exact_discrete) / r.std_error),
                V::F(r.cost),
            ]
        })
        .collect();
    let cols = [
        Col("quantity", "quantity", 26, Fmt::Sci(0)),
        Col("dt [s]", "dt_s", 10, Fmt::Sci(3)),
        Col("steps", "steps", 6, Fmt::Sci(0)),
        Col("wall [s]", "seconds_s", 10, Fmt::Sci(3)),
        Col("rel error", "rel_error", 10, Fmt::Sci(3)),
        Col("std error", "std_error", 9, Fmt::Sci(2)),
        Col("exact", "exact_discrete_rel_error", 10, Fmt::Sci(3)),
        Col("z", "z", 6, Fmt::Fix(2)),
        Col("cost", "cost_s_per_particle_per_time_unit", 10, Fmt::Sci(3)),
    ];
    emit(
        &cols,
        &rows,
        &dir.join("bench-brownian-work-precision.csv"),
        true,
    )?;
    println!(
        "MSD and drift: the update is exact in distribution for free particles and constant \
         forces, so their errors are statistical (compare with the standard error). Trap: the \
         bias 1/(1 - a/2) - 1 ~ a/2 = mu k dt / 2 is the real O(dt) error. Cost: wall-clock s \
         per particle per simulated second (MSD, drift) or per relaxation time 1/(mu k) (trap)."
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dilute_cloud_has_no_close_pairs() {
        let p = dilute_positions(200, FIELD_CLOUD_CORNER, &mut run_rng(1, 0));
        assert_eq!(p.len(), 200);
        for i in 0..p.len() {
            for j in (i + 1)..p.len() {
                assert!((p[i] - p[j]).norm() >= 2.2 * RADIUS);
            }
        }
    }

    #[test]
    fn crossover_needs_every_larger_n() {
        let row = |n, method, seconds| ThroughputRow {
            n,
            method,
            steps: 1,
            seconds,
        };
        let mut rows = Vec::new();
        // TEA-HI faster at 20, slower at 50, faster from 100 on: the crossover is 100.
        for (n, chol, tea) in [
            (10, 1.0, 2.0),
            (20, 2.0, 1.0),
            (50, 1.0, 2.0),
            (100, 4.0, 1.0),
        ] {
            rows.push(row(n, Method::Free, 1.0));
            rows.push(row(n, Method::RpyCholesky, chol));
            rows.push(row(n, Method::RpyTeaHi, tea));
        }
        assert_eq!(crossover(&rows), Some(100));
        rows.truncate(9);
        assert_eq!(crossover(&rows), None);
    }
}
