//! `porelab bench filter`: the work-precision front of the fibre-bed field in the filter
//! engine. A random bed of the thesis' fibres (R = 0.2 mm, 4 mm long, thesis ch. 7) in a
//! periodic cube, magnetized (Stoner–Wohlfarth, saturated) by 1 T along the flow; for each fast
//! representation ([`FastAssembly`]: exact kernel near each fibre, the rest on a periodic grid
//! of Lagrange order p) it measures the force error against the exact superposition
//! ([`FibreAssembly::exact`]) at random fluid points, and times filter particle-steps per
//! CPU second on one thread, alternating exact and fast runs of the same particles (the CPU
//! time of the pool's one worker, so other jobs on a shared core do not count).
//!
//! Force error at a point: F = (grad H) H/|H| (the force on a moment along H, per mu0 m);
//! reported as the median and the largest |F_fast - F_exact| / |F_exact| over the points, and
//! norm-wise as the largest |F_fast - F_exact| over the rms |F_exact| (which does not blow up
//! at the points where F passes through zero). Output: a table on stdout and
//! `target/porelab/bench-filter.csv`.

use crate::brownian::magnetization::{StonerWohlfarth, THESIS_SATURATION};
use crate::brownian::{FieldSource, Fluid, LangevinMoment};
use crate::consts::MU0;
use crate::error::invalid;
use crate::filter::{driver, FibreBed, Filter, Setup, VelocityLattice};
use crate::io::CsvTable;
use crate::magnetics::assembly_fast::{Cell, Cutoff, FastAssembly, FastSpec, FibreAssembly};
use crate::magnetics::Cylinder;
use crate::Result;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Fibres in the periodic cube.
    #[arg(long, default_value_t = 100)]
    pub fibres: usize,
    /// Solid volume fraction of the bed (sets the cube's edge).
    #[arg(long, default_value_t = 0.1)]
    pub solid_fraction: f64,
    /// Far-grid spacings to try (mm, comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.33,0.25")]
    pub spacings_mm: Vec<f64>,
    /// Lagrange points per axis of the far grid (even, comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "6,8")]
    pub orders: Vec<usize>,
    /// Near-window margin (mm) around the fibre and outer ratio of the window.
    #[arg(long, default_value_t = 0.3)]
    pub window_margin_mm: f64,
    #[arg(long, default_value_t = 1.8)]
    pub window_outer: f64,
    /// Fluid points where the force error is measured.
    #[arg(long, default_value_t = 400)]
    pub points: usize,
    /// Particles and steps of each timed filter run.
    #[arg(long, default_value_t = 100)]
    pub particles: usize,
    #[arg(long, default_value_t = 5)]
    pub steps: u64,
}

const FIBRE_R_M: f64 = 2e-4;
const FIBRE_HALF_LENGTH_M: f64 = 2e-3;
const PARTICLE_R_M: f64 = 1e-7;

/// The bed: random centres and isotropic axes (fixed seed), saturated by 1 T along z.
fn bed(args: &BenchArgs) -> Result<FibreAssembly> {
    let cyl = Cylinder::new(FIBRE_R_M, FIBRE_HALF_LENGTH_M)?;
    let volume = std::f64::consts::PI * FIBRE_R_M * FIBRE_R_M * 2.0 * FIBRE_HALF_LENGTH_M;
    let edge = (args.fibres as f64 * volume / args.solid_fraction).cbrt();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261206);
    let centres: Vec<_> = (0..args.fibres)
        .map(|_| Vector3::from_fn(|_, _| rng.gen_range(0.0..edge)))
        .collect();
    let axes: Vec<_> = (0..args.fibres)
        .map(|_| {
            let cos_t: f64 = rng.gen_range(-1.0..1.0);
            let phi: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let sin_t = (1.0 - cos_t * cos_t).sqrt();
            Vector3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
        })
        .collect();
    let h0 = Vector3::new(0.0, 0.0, 1.0 / MU0);
    let sw = StonerWohlfarth::for_cylinder(&cyl, THESIS_SATURATION)?;
    let ms = axes
        .iter()
        .map(|a| sw.magnetization(a, &h0))
        .collect::<Result<Vec<_>>>()?;
    FibreAssembly::new(
        cyl,
        Cell::new([edge; 3], [true; 3])?,
        Some(Cutoff::new(7e-3, 1.5e-3)?),
        centres,
        &axes,
        &ms,
        h0,
    )
}

/// Random points of the cell at least a particle radius outside every fibre image.
fn fluid_points(model: &FibreAssembly, bed: &FibreBed, n: usize) -> Vec<Vector3<f64>> {
    let edge = model.cell().lengths_m[0];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut pts = Vec::with_capacity(n);
    while pts.len() < n {
        let p = Vector3::from_fn(|_, _| rng.gen_range(0.0..edge));
        if bed.touching(&p).is_none() {
            pts.push(p);
        }
    }
    pts
}

/// Particle-steps per CPU second of a filter run with `field`, to be called inside a one-thread
/// pool (its only worker does all the work, so that thread's CPU time is the run's).
fn particle_steps_per_s(
    args: &BenchArgs,
    model: &FibreAssembly,
    field: Box<dyn FieldSource>,
) -> Result<f64> {
    let edge = model.cell().lengths_m[0];
    let setup = Setup {
        bed: solid_bed(model)?,
        flow: VelocityLattice::from_fn([8; 3], edge / 8.0, |_| Vector3::new(0.0, 0.0, 1e-3))?,
        field: Some(field),
        moment: LangevinMoment::fixed(1e-17)?,
        fluid: Fluid::new(298.0, 1e-3)?,
        particles: args.particles,
        cells_deep: 1,
        dt_s: 1e-2,
        max_step_fraction: 0.05,
        seed: 3,
    };
    let mut f = Filter::new(setup)?;
    let mut particle_steps = 0usize;
    let cpu0 = super::dem::thread_cpu_seconds();
    for _ in 0..args.steps {
        particle_steps += f.counts().inside;
        let next = f.steps() + 1;
        if driver::run_to_end(&mut f, next, &mut crate::driver::NoHooks)? == driver::Stop::Empty {
            break;
        }
    }
    Ok(particle_steps as f64 / (super::dem::thread_cpu_seconds() - cpu0))
}

/// The fibres of `model` as the filter engine's contact bed (particles of PARTICLE_R_M).
fn solid_bed(model: &FibreAssembly) -> Result<FibreBed> {
    let edge = model.cell().lengths_m[0];
    let centres: Vec<_> = (0..model.len()).map(|i| model.centre(i)).collect();
    let axes: Vec<_> = (0..model.len()).map(|i| model.axis(i)).collect();
    FibreBed::new(
        [edge; 3],
        FIBRE_R_M,
        FIBRE_HALF_LENGTH_M,
        &centres,
        &axes,
        PARTICLE_R_M,
    )
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.fibres == 0 || args.points == 0 || args.particles == 0 || args.steps == 0 {
        return invalid("bench filter: --fibres, --points, --particles and --steps must be >= 1");
    }
    if !(args.solid_fraction > 0.0 && args.solid_fraction < 1.0) {
        return invalid(format!(
            "bench filter --solid-fraction {}: must be in (0, 1)",
            args.solid_fraction
        ));
    }
    let model = bed(args)?;
    let edge = model.cell().lengths_m[0];
    let solid = solid_bed(&model)?;
    let pts = fluid_points(&model, &solid, args.points);
    let exact: Vec<Vector3<f64>> = {
        use rayon::prelude::*;
        pts.par_iter()
            .map(|p| {
                let (h, g) = model.exact(p);
                g * (h / h.norm())
            })
            .collect()
    };
    let rms = (exact.iter().map(|f| f.norm_squared()).sum::<f64>() / exact.len() as f64).sqrt();
    eprintln!(
        "bed: {} fibres R = {FIBRE_R_M} m, L = {} m in a periodic cube of {edge:.4e} m \
         (solid fraction {}), 1 T along the flow; {} fluid points",
        args.fibres,
        2.0 * FIBRE_HALF_LENGTH_M,
        args.solid_fraction,
        pts.len()
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| crate::Error::Validation(format!("thread pool: {e}")))?;
    let mut csv = CsvTable::new(&[
        "spacing_m",
        "order",
        "build_s",
        "near_images_per_bin",
        "fast_particle_steps_per_s",
        "exact_particle_steps_per_s",
        "speedup",
        "median_rel_force_error",
        "max_rel_force_error",
        "max_force_error_over_rms",
    ]);
    println!(
        "{:>10} {:>5} {:>8} {:>6} {:>12} {:>12} {:>8} {:>11} {:>11} {:>11}",
        "spacing m",
        "order",
        "build s",
        "near",
        "fast ps/s",
        "exact ps/s",
        "speedup",
        "median rel",
        "max rel",
        "max/rms"
    );
    for &spacing_mm in &args.spacings_mm {
        for &order in &args.orders {
            let spec = FastSpec {
                table: None,
                window_margin_m: args.window_margin_mm * 1e-3,
                window_outer: args.window_outer,
                grid_spacing_m: spacing_mm * 1e-3,
                order,
            };
            let fast = FastAssembly::new(model.clone(), spec)?;
            let mut rel: Vec<f64> = Vec::with_capacity(pts.len());
            let mut worst_abs = 0.0f64;
            for (p, fe) in pts.iter().zip(&exact) {
                let (h, g) = fast.h_and_gradient(p);
                let d = (g * (h / h.norm()) - fe).norm();
                rel.push(d / fe.norm());
                worst_abs = worst_abs.max(d);
            }
            rel.sort_by(f64::total_cmp);
            let (median, max) = (rel[rel.len() / 2], rel[rel.len() - 1]);
            // alternate exact and fast runs, twice each, on one thread; keep each one's best
            let (mut rate_exact, mut rate_fast) = (0.0f64, 0.0f64);
            for _ in 0..2 {
                rate_exact = rate_exact.max(
                    one.install(|| particle_steps_per_s(args, &model, Box::new(model.clone())))?,
                );
                rate_fast = rate_fast.max(
                    one.install(|| particle_steps_per_s(args, &model, Box::new(fast.clone())))?,
                );
            }
            let st = fast.stats();
            let row = [
                spacing_mm * 1e-3,
                order as f64,
                st.build_seconds,
                st.near_images_per_bin,
                rate_fast,
                rate_exact,
                rate_fast / rate_exact,
                median,
                max,
                worst_abs / rms,
            ];
            println!(
                "{:>10.3e} {:>5} {:>8.1} {:>6.1} {:>12.4e} {:>12.4e} {:>8.1} {:>11.3e} {:>11.3e} {:>11.3e}",
                row[0], order, row[2], row[3], row[4], row[5], row[6], row[7], row[8], row[9]
            );
            csv.row(row);
        }
    }
    let path = std::path::Path::new("target/porelab/bench-filter.csv");
    csv.write(path)?;
    println!("wrote {}", path.display());
    Ok(())
}
