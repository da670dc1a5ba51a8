//! The run of a deposition scene: its independent runs in parallel, each through the engine's
//! driver ([`deposition::driver::run_one`]) from its own random stream, then measured; results
//! in run order, the same at any thread count.

use super::outputs::{ensemble, fmt_mean, write_outputs, RunResult};
use super::schema::{parse_scene, DepositionScene};
use crate::deposition::measure::measure;
use crate::deposition::{self, Deposition};
use crate::driver::Hooks;
use crate::scene::{on_threads, RunOptions};
use crate::Result;
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// `porelab run` entry point for `kind = "deposition"`.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let scene = parse_scene(text, origin)?;
    on_threads(opts.threads, || run_parsed(&scene, origin, out, opts))
}

/// Run `k` of `scene` to its end with `hooks`, and its measures.
pub fn run_one(
    scene: &DepositionScene,
    k: usize,
    hooks: &mut impl Hooks<Deposition>,
) -> Result<RunResult> {
    let t0 = Instant::now();
    let deposit = deposition::driver::run_one(&scene.setup, k, hooks)?;
    let measures = measure(&deposit.layer, scene.setup.species.len(), &scene.measure)?;
    Ok(RunResult {
        deposit,
        measures,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Shows run 0's sweep on the progress bar every 50 sweeps.
struct RunZero<'a> {
    bar: &'a indicatif::ProgressBar,
}

impl Hooks<Deposition> for RunZero<'_> {
    fn progress(&mut self, d: &Deposition, _: Option<f64>, status: &str) {
        if d.outcome().sweeps.is_multiple_of(50) {
            self.bar.set_message(format!("(run 0: {status})"));
        }
    }
}

fn run_parsed(scene: &DepositionScene, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let setup = &scene.setup;
    if !opts.quiet {
        let counts = setup.counts();
        let sp: Vec<String> = setup
            .species
            .iter()
            .zip(&counts)
            .map(|(s, n)| format!("{n} x {} {:?} m", s.name, s.semi_axes_m))
            .collect();
        eprintln!(
            "deposition: {}; box {:.4e} m, {} % solids -> pigment fraction {:.4}, fluid {:.1} \
             kg/m^3; K_max {:e} m^2; {} runs, seed {}",
            sp.join(" + "),
            setup.box_side_m,
            setup.colour.solids_mass_fraction * 100.0,
            scene.phi,
            setup.fluid_density_kg_m3,
            setup.moves.k_max_m2,
            scene.runs,
            setup.seed
        );
        eprintln!("active terms: {}", setup.active_terms().join(", "));
    }
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(scene.runs as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("[{elapsed_precise}] runs {pos}/{len} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    };
    let t0 = Instant::now();
    let results: Vec<Result<RunResult>> = (0..scene.runs)
        .into_par_iter()
        .map(|k| {
            let r = if k == 0 {
                run_one(scene, k, &mut RunZero { bar: &bar })
            } else {
                run_one(scene, k, &mut crate::driver::NoHooks)
            };
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let results: Vec<RunResult> = results.into_iter().collect::<Result<_>>()?;
    write_outputs(scene, origin, out, &results, t0.elapsed().as_secs_f64())?;
    let ens = ensemble(&results);
    let core = ens.iter().find(|r| r.0 == "core_porosity");
    println!(
        "deposition: {} runs in {:.1} s; layer porosity {}; core porosity {}; outputs in {}",
        results.len(),
        t0.elapsed().as_secs_f64(),
        fmt_mean(ens.iter().find(|r| r.0 == "layer_porosity")),
        fmt_mean(core),
        out.display()
    );
    Ok(())
}
