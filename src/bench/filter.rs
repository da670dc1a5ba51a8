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
use crate::magnetics::assembly_fast::{
    BinFar, Cell, Cutoff, FastAssembly, FastSpec, FibreAssembly, TabulatedAssembly,
};
use crate::magnetics::cylinder_table::TableSpec;
use crate::magnetics::Cylinder;
use crate::Result;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Fibres in the periodic cube.
    #[arg(long, default_value_t = 200)]
    pub fibres: usize,
    /// Solid volume fraction of the bed (sets the cube's edge).
    #[arg(long, default_value_t = 0.1)]
    pub solid_fraction: f64,
    /// Relative tolerances of the cylinder table for the tabulated superposition
    /// (comma-separated; none: no tabulated rows).
    #[arg(long, value_delimiter = ',', default_value = "1e-6,1e-8")]
    pub table_tolerances: Vec<f64>,
    /// Chebyshev nodes per axis of the table's rectangles.
    #[arg(long, default_value_t = 10)]
    pub table_nodes: usize,
    /// The table's exact zone: this margin (mm) around the fibre.
    #[arg(long, default_value_t = 0.02)]
    pub exact_margin_mm: f64,
    /// Chebyshev nodes per axis of each bin's far interpolant (comma-separated; 0: no far
    /// part, every counting image from the table).
    #[arg(long, value_delimiter = ',', default_value = "0,8,10")]
    pub far_nodes: Vec<usize>,
    /// With a far part: images whose axis comes within this distance (mm) of a bin are summed
    /// per point, the rest interpolated.
    #[arg(long, default_value_t = 1.0)]
    pub far_near_mm: f64,
    /// Edge (mm) of the bins listing each point's images.
    #[arg(long, default_value_t = 1.0)]
    pub bin_mm: f64,
    /// Far-grid spacings to try (mm, comma-separated; none: no grid rows).
    #[arg(long, value_delimiter = ',', default_value = "0.5")]
    pub spacings_mm: Vec<f64>,
    /// Lagrange points per axis of the far grid (even, comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "6")]
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
        wall_layer_m: 0.0,
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
        "method",
        "knob",
        "order",
        "build_s",
        "images_per_bin",
        "fast_particle_steps_per_s",
        "exact_particle_steps_per_s",
        "speedup",
        "median_rel_force_error",
        "max_rel_force_error",
        "max_force_error_over_rms",
    ]);
    println!(
        "{:>6} {:>10} {:>5} {:>8} {:>6} {:>12} {:>12} {:>8} {:>11} {:>11} {:>11}",
        "method",
        "knob",
        "order",
        "build s",
        "images",
        "fast ps/s",
        "exact ps/s",
        "speedup",
        "median rel",
        "max rel",
        "max/rms"
    );
    let reference = Reference {
        model: &model,
        points: &pts,
        forces: &exact,
        rms,
        pool: &one,
    };
    // the tabulated superposition, with or without the per-bin far interpolant: knob = the
    // table's relative tolerance, order = the far interpolant's nodes per axis (0: none)
    for &tolerance in &args.table_tolerances {
        for &nodes in &args.far_nodes {
            let spec = TableSpec {
                tolerance,
                nodes: args.table_nodes,
                exact_margin_m: args.exact_margin_mm * 1e-3,
                extent_m: 0.0,
            };
            let far = (nodes > 0).then_some(BinFar {
                near_m: args.far_near_mm * 1e-3,
                nodes,
            });
            let tab = TabulatedAssembly::new(model.clone(), spec, args.bin_mm * 1e-3, far)?;
            let st = *tab.stats();
            let (ratios, errors) = reference.front_row(args, &|| Box::new(tab.clone()))?;
            let row = [
                "table".to_string(),
                format!("{tolerance:e}"),
                nodes.to_string(),
            ]
            .into_iter()
            .chain([st.build_seconds, st.images_per_bin].map(|v| format!("{v}")))
            .chain(ratios.iter().chain(&errors).map(|v| format!("{v:e}")))
            .collect::<Vec<_>>();
            print_row(&row);
            csv.row(row);
        }
    }
    // near images exact, far part on a windowed grid: knob = the grid spacing (m)
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
            let st = *fast.stats();
            let (ratios, errors) = reference.front_row(args, &|| Box::new(fast.clone()))?;
            let row = [
                "grid".to_string(),
                format!("{:e}", spacing_mm * 1e-3),
                order.to_string(),
            ]
            .into_iter()
            .chain([st.build_seconds, st.near_images_per_bin].map(|v| format!("{v}")))
            .chain(ratios.iter().chain(&errors).map(|v| format!("{v:e}")))
            .collect::<Vec<_>>();
            print_row(&row);
            csv.row(row);
        }
    }
    let path = std::path::Path::new("target/porelab/bench-filter.csv");
    csv.write(path)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// The exact superposition's forces at the fluid points, and the one-thread pool of the timed
/// runs: what every row of the front is measured against.
struct Reference<'a> {
    model: &'a FibreAssembly,
    points: &'a [Vector3<f64>],
    forces: &'a [Vector3<f64>],
    rms: f64,
    pool: &'a rayon::ThreadPool,
}

impl Reference<'_> {
    /// ([fast particle-steps/s, exact particle-steps/s, ratio], [median rel. force error, max
    /// rel., max abs. over rms]) of the field `make` builds. Exact and fast runs alternate,
    /// twice each, on one thread; each keeps its best.
    fn front_row(
        &self,
        args: &BenchArgs,
        make: &dyn Fn() -> Box<dyn FieldSource>,
    ) -> Result<([f64; 3], [f64; 3])> {
        let field = make();
        let mut rel: Vec<f64> = Vec::with_capacity(self.points.len());
        let mut worst_abs = 0.0f64;
        for (p, fe) in self.points.iter().zip(self.forces) {
            let (h, g) = field.h_and_gradient(p);
            let d = (g * (h / h.norm()) - fe).norm();
            rel.push(d / fe.norm());
            worst_abs = worst_abs.max(d);
        }
        rel.sort_by(f64::total_cmp);
        let (median, max) = (rel[rel.len() / 2], rel[rel.len() - 1]);
        let (mut rate_exact, mut rate_fast) = (0.0f64, 0.0f64);
        for _ in 0..2 {
            let exact = Box::new(self.model.clone());
            rate_exact = rate_exact.max(
                self.pool
                    .install(|| particle_steps_per_s(args, self.model, exact))?,
            );
            let fast = make();
            rate_fast = rate_fast.max(
                self.pool
                    .install(|| particle_steps_per_s(args, self.model, fast))?,
            );
        }
        Ok((
            [rate_fast, rate_exact, rate_fast / rate_exact],
            [median, max, worst_abs / self.rms],
        ))
    }
}

fn print_row(row: &[String]) {
    let w = [6, 10, 5, 8, 6, 12, 12, 8, 11, 11, 11];
    let cells: Vec<String> = row
        .iter()
        .zip(w)
        .map(|(c, w)| {
            // numbers to four significant digits on screen (the CSV keeps them all)
            let c = c
                .parse::<f64>()
                .ok()
                .filter(|_| c.contains('.') || c.contains('e'))
                .map_or(c.clone(), |v| format!("{v:.3e}"));
            format!("{c:>w$}")
        })
        .collect();
    println!("{}", cells.join(" "));
}
