//! `porelab bench coupled`: seconds per simulated second of the built-in coupled scenes and the
//! share of each step spent in the LBM, the DEM and the coupling itself (porosity, fields,
//! force transfer and the momentum ledger), for both porosity variants at one and two threads.
//! The goal (the coupling under 15 % of a step) is checked against these shares.

use crate::coupled::{Coupled, Overlap};
use crate::error::{invalid, Error, Result};
use crate::scene::coupled::{build, parse_scene};
use std::fmt::Write as _;

#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Built-in scenes to measure.
    #[arg(long, value_delimiter = ',', default_values_t = vec!["coupled-quick".to_string(), "coupled-seed-bed".to_string()])]
    pub scenes: Vec<String>,
    /// Thread counts.
    #[arg(long, value_delimiter = ',', default_values_t = vec![1, 2])]
    pub threads: Vec<usize>,
    /// Coupling steps per measurement (from the scene's start).
    #[arg(long, default_value_t = 40)]
    pub steps: u64,
    /// Output CSV (default target/porelab/bench/coupled.csv).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.steps == 0 {
        return invalid("--steps 0: must be at least 1");
    }
    let mut csv = String::from(
        "scene,particles,cells,overlap,threads,steps,seconds_per_simulated_second,lbm_share,dem_share,coupling_share\n",
    );
    println!(
        "{:<18} {:>5} {:>6} {:<18} {:>3} {:>12} {:>6} {:>6} {:>9}",
        "scene", "N", "cells", "porosity", "thr", "s per sim s", "LBM %", "DEM %", "coupling %"
    );
    for name in &args.scenes {
        let b = crate::scene::builtins()
            .into_iter()
            .find(|b| b.name == name.as_str())
            .ok_or_else(|| Error::InvalidInput(format!("--scenes {name}: no such built-in")))?;
        for overlap in [Overlap::Exact, Overlap::SeedLens] {
            for &t in &args.threads {
                let mut scene = parse_scene(b.toml, name)?;
                scene.setup.overlap = overlap;
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| Error::InvalidInput(format!("--threads {t}: {e}")))?;
                let c: Coupled = pool.install(|| -> Result<Coupled> {
                    let mut c = build(&scene)?;
                    for _ in 0..args.steps {
                        c.step()?;
                    }
                    Ok(c)
                })?;
                let tm = c.timing;
                let tot = tm.lbm_s + tm.dem_s + tm.coupling_s;
                let per = tot / c.time_s;
                println!(
                    "{:<18} {:>5} {:>6} {:<18} {:>3} {:>12.3} {:>6.1} {:>6.1} {:>9.1}",
                    name,
                    c.dem.p.len(),
                    c.dims.cells(),
                    match overlap {
                        Overlap::Exact => "exact",
                        Overlap::SeedLens => "seed-lens",
                    },
                    t,
                    per,
                    100.0 * tm.lbm_s / tot,
                    100.0 * tm.dem_s / tot,
                    100.0 * tm.coupling_s / tot
                );
                let _ = writeln!(
                    csv,
                    "{name},{},{},{},{t},{},{per},{},{},{}",
                    c.dem.p.len(),
                    c.dims.cells(),
                    overlap.name(),
                    args.steps,
                    tm.lbm_s / tot,
                    tm.dem_s / tot,
                    tm.coupling_s / tot
                );
            }
        }
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| std::path::PathBuf::from("target/porelab/bench/coupled.csv"));
    crate::io::write_atomic(&out, csv.as_bytes())?;
    println!("table in {}", out.display());
    Ok(())
}
