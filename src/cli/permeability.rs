//! `porelab permeability PACKING.xyz`: the permeability of a periodic particle configuration by
//! the pore-resolving lattice Boltzmann solver ([`crate::lbm::pore`]). By default it climbs a
//! ladder of resolutions ([`crate::lbm::ladder`]) until the Richardson-extrapolated k settles
//! within `--rtol`, prints every rung and the answer with its estimated error, and writes
//! `permeability.json`, `ladder.csv`, `convergence.svg` and the finest rung's `fields.vtk` into
//! `--out`. With `--resolution N` it runs N/2 and N cells only, as a quick look.

use super::ladder_checkpoint::LadderCheckpoint;
use crate::error::{invalid, Error, Result};
use crate::io::csv_table::CsvTable;
use crate::io::plot::{write_svg, Plot, Series};
use crate::io::{write_atomic, xyz};
use crate::lbm::ladder::{climb, rung_control, Ladder, LadderOptions, Rung, ORDER, RATIO};
use crate::lbm::pore::{
    darcy_linearity, kozeny_constant, pore_permeability, report, setup_line, write_fields_vtk,
    PoreOptions, DARCY_LINEARITY_TOL, DEFAULT_WALLS,
};
use crate::lbm::voxels::voxelise;
use crate::lbm::{
    CollisionKind, CollisionModel, LatticeKind, SteadyBar, SteadyControl, Tau, WallRule,
};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Debug, Clone, clap::Args)]
pub struct PermeabilityArgs {
    /// Periodic packing: extended XYZ (porelab, OVITO, ASE: `pos` and `radius` columns in any
    /// order) or a LAMMPS/LIGGGHTS dump of spheres; the format is told by the content.
    pub packing: PathBuf,
    /// Frame of a file of several: 0 the first, -1 the last.
    #[arg(long, default_value_t = -1, allow_hyphen_values = true)]
    pub frame: i64,
    /// Deepest particle overlap allowed, as a fraction of the smaller particle's size
    /// (diameter): ten times porelab's own packing tolerance (overlap_tol 1e-4 D); raise it
    /// (e.g. 0.01) for a soft-sphere DEM packing.
    #[arg(long, default_value_t = 1e-3, allow_hyphen_values = true)]
    pub max_overlap: f64,
    /// One resolution only (cells along the box's x edge), with a second run at half of it
    /// for a rough convergence estimate, instead of the ladder.
    #[arg(long, allow_hyphen_values = true)]
    pub resolution: Option<usize>,
    /// Ladder: stop when two successive Richardson extrapolations of k differ by less than
    /// this (relative).
    #[arg(long, default_value_t = 0.01, allow_hyphen_values = true)]
    pub rtol: f64,
    /// Ladder: cells along x of the first rung [about 1.7 cells per smallest particle
    /// diameter, at least 16].
    #[arg(long)]
    pub start: Option<usize>,
    /// Ladder: the finest rung allowed (cells along x).
    #[arg(long, default_value_t = 192)]
    pub max_resolution: usize,
    /// Ladder: exit with status 3 when it did not converge within --max-resolution.
    #[arg(long)]
    pub strict: bool,
    /// Ladder: folder for permeability.json, ladder.csv, convergence.svg and fields.vtk
    /// [target/porelab/permeability/<file stem>]. Given, the ladder keeps its finished rungs
    /// and the running rung's state in OUT/checkpoint.json: a killed ladder run again with
    /// the same arguments, packing and --out resumes there, to the same outputs.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Ladder with --out: seconds between the running rung's checkpoints (0: at every check
    /// of 100 steps); a finished rung is always kept.
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    pub checkpoint_every: f64,
    /// The configuration's length unit in metres (e.g. the particle diameter), for k in m^2.
    #[arg(long, allow_hyphen_values = true)]
    pub unit_m: Option<f64>,
    /// D3Q15 or D3Q19.
    #[arg(long, default_value = "D3Q19")]
    pub lattice: String,
    /// bgk or trt (TRT: k independent of the viscosity).
    #[arg(long, default_value = "trt")]
    pub collision: String,
    /// Relaxation time.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub tau: f64,
    /// How the fluid meets the particles: "interpolated" (curved walls: each lattice link's
    /// wall where the particle surface cuts it, Ginzburg's central linear interpolation) or
    /// "staircase" (halfway bounce-back on the voxels' faces) [staircase].
    #[arg(long)]
    pub walls: Option<String>,
    /// Body force in lattice units (small: Re << 1).
    #[arg(long, default_value_t = 1e-6, allow_hyphen_values = true)]
    pub force: f64,
    /// With --resolution: stop when the mean velocity changes by less than this (relative)
    /// over 100 steps.
    #[arg(long, default_value_t = 1e-7, allow_hyphen_values = true)]
    pub tol: f64,
    /// Steps allowed per run.
    #[arg(long, default_value_t = 500_000)]
    pub max_steps: u64,
    #[arg(long)]
    pub quiet: bool,
}

/// `porelab permeability`: exit 0, or 3 for a ladder that did not converge under `--strict`.
pub fn run_permeability(a: &PermeabilityArgs) -> Result<ExitCode> {
    let lattice = LatticeKind::parse(&a.lattice, "--lattice")?;
    let kind = CollisionKind::parse(&a.collision, "--collision")?;
    let collision = CollisionModel::new(kind, Tau::new(a.tau)?);
    let ctl = match a.resolution {
        Some(_) => SteadyControl {
            check_every: 100,
            tol: a.tol,
            max_steps: a.max_steps,
        },
        None => rung_control(a.max_steps),
    };
    if !(a.tol.is_finite() && a.tol > 0.0) {
        return invalid(format!("--tol {}: must be positive and finite", a.tol));
    }
    if !(a.checkpoint_every.is_finite() && a.checkpoint_every >= 0.0) {
        return invalid(format!(
            "--checkpoint-every {}: must be finite and not negative (seconds)",
            a.checkpoint_every
        ));
    }
    let walls = a
        .walls
        .as_deref()
        .map_or(Ok(DEFAULT_WALLS), |w| WallRule::parse(w, "--walls"))?;
    let o = PoreOptions::new(lattice, collision, (a.force, "--force"), ctl)?.with_walls(walls);
    // the options checked, the file read: the resolution checked against the smallest
    // particle, the one asked for or the ladder's finest (its coarse rungs may leave particles
    // unresolved: the fit uses the last three)
    let (cell, parts) = super::packing_input::read_packing(&super::packing_input::PackingInput {
        path: &a.packing,
        frame: a.frame,
        resolution: a.resolution.unwrap_or(a.max_resolution),
        unit_m: a.unit_m,
        max_overlap: a.max_overlap,
    })?;
    print!("{}", setup_line(&cell, &parts, &o));
    match a.resolution {
        Some(n) => two_resolutions(a, &cell, &parts, &o, n).map(|_| ExitCode::SUCCESS),
        None => ladder(a, &cell, &parts, o),
    }
}

/// `--resolution N`: N/2 and N cells, Darcy's law checked on the coarser.
fn two_resolutions(
    a: &PermeabilityArgs,
    cell: &xyz::Cell,
    parts: &[xyz::XyzParticle],
    o: &PoreOptions,
    n: usize,
) -> Result<()> {
    let bar = || SteadyBar::new(a.quiet);
    let mut results = Vec::new();
    let mut linearity = 0.0;
    for n in [n / 2, n] {
        let v = voxelise(cell, parts, n)?;
        let r = pore_permeability(&v, o, &mut bar())?;
        print!("{}", report(&v, &r, o, a.unit_m));
        if results.is_empty() {
            linearity = darcy_linearity(&v, o, r.k, &mut bar())?;
        }
        results.push(r);
    }
    let (k1, k2) = (results[0].k, results[1].k);
    println!(
        "Darcy's law: k at half the force differs by {:+.2e} (resolution {}){}",
        linearity,
        results[0].n,
        darcy_flag(linearity)
    );
    println!(
        "convergence estimate: k changed by {:+.2} % from resolution {} to {}",
        100.0 * (k2 / k1 - 1.0),
        results[0].n,
        results[1].n
    );
    Ok(())
}

fn darcy_flag(change: f64) -> &'static str {
    if change.abs() > DARCY_LINEARITY_TOL {
        " -- NOT in the Darcy regime: lower --force"
    } else {
        ""
    }
}

/// The first rung's cells: about 1.7 cells per smallest particle diameter (the smallest
/// extent of any particle), at least 16.
fn default_start(cell: &xyz::Cell, parts: &[xyz::XyzParticle]) -> usize {
    let smallest = parts
        .iter()
        .map(|p| {
            let [a, b, c] = p.aspherical_shape;
            if p.cylinder_length > 0.0 {
                p.radius
            } else {
                a.min(b).min(c).min(p.radius)
            }
        })
        .fold(f64::INFINITY, f64::min);
    let per_d = 1.7 * cell.lengths[0] / (2.0 * smallest);
    if per_d.is_finite() {
        (per_d.round() as usize).max(16)
    } else {
        16
    }
}

/// The ladder: rungs, the answer, and its files.
fn ladder(
    a: &PermeabilityArgs,
    cell: &xyz::Cell,
    parts: &[xyz::XyzParticle],
    pore: PoreOptions,
) -> Result<ExitCode> {
    let o = LadderOptions {
        pore,
        start: a.start.unwrap_or_else(|| default_start(cell, parts)),
        max_resolution: a.max_resolution,
        rtol: a.rtol,
    };
    let out = a.out.clone().unwrap_or_else(|| {
        let stem = a
            .packing
            .file_stem()
            .map_or("packing".into(), |s| s.to_string_lossy().into_owned());
        Path::new("target/porelab/permeability").join(stem)
    });
    // the folder is checked before the work
    crate::io::create_dir(&out)?;
    let mut store = match &a.out {
        Some(out) => LadderCheckpoint::open(out, &ladder_key(a)?, a.checkpoint_every, a.quiet)?,
        None => LadderCheckpoint::none(a.quiet),
    };
    if let Some((kept, running)) = store.resumes() {
        println!(
            "resuming from {}: {kept} finished rungs kept{}",
            out.join("checkpoint.json").display(),
            running.map_or(String::new(), |n| format!(
                ", the rung of {n} cells restored"
            ))
        );
    }
    println!(
        "ladder from {} cells, x{RATIO} per rung up to {}, until k_inf of k = k_inf + c n^-{ORDER} \
         fitted to the last three rungs agrees with the previous fit and has a standard error \
         within {:.2} %",
        o.start,
        o.max_resolution,
        100.0 * o.rtol
    );
    let l = climb(cell, parts, &o, &mut store, |r| {
        println!("{}", rung_line(r, a.unit_m))
    })?;
    let finest = &l.rungs[l.rungs.len() - 1];
    let vs = l.finest.v_over_s;
    let phi = l.finest.phi_particles;
    let kozeny = vs.map(|vs| kozeny_constant(l.k, phi, vs));
    println!(
        "k = {:.5e} +- {:.1e} unit^2 (extrapolated, order {ORDER}: the larger of the fit's \
         standard error and its change from the previous fit){}",
        l.k,
        l.k_error,
        a.unit_m
            .map_or(String::new(), |u| format!(" = {:.5e} m^2", l.k * u * u))
    );
    println!(
        "observed order on the last three rungs: {}",
        l.observed_order
            .map_or("none (not monotone)".to_string(), |p| format!("{p:.2}"))
    );
    println!(
        "Darcy's law: k at half the force differs by {:+.2e} (resolution {}){}",
        l.darcy_change,
        l.rungs[1].cells,
        darcy_flag(l.darcy_change)
    );
    if let (Some(c), Some(vs)) = (kozeny, vs) {
        println!(
            "Kozeny constant (thesis eq. 7.4, nu = V/S = {vs:.4}, particle phi {phi:.4}): {c:.3}"
        );
    }
    if !l.converged {
        eprintln!(
            "porelab: the ladder did NOT converge: the extrapolation's error is {:.2} % (> {:.2} %) \
             at {} cells; raise --max-resolution or --rtol",
            100.0 * l.k_error / l.k,
            100.0 * o.rtol,
            finest.cells
        );
    }
    write_outputs(&out, a, cell, &o, &l, kozeny)?;
    // the outputs are complete: the checkpoint is no longer needed
    store.remove()?;
    println!("outputs in {}", out.display());
    Ok(if a.strict && !l.converged {
        ExitCode::from(3)
    } else {
        ExitCode::SUCCESS
    })
}

/// What a ladder's rungs depend on: its arguments but for the output and display options,
/// and the packing file's bytes.
fn ladder_key(a: &PermeabilityArgs) -> Result<Vec<u8>> {
    let packing = std::fs::read(&a.packing).map_err(|e| Error::File {
        path: a.packing.display().to_string(),
        msg: format!("cannot read the packing: {e}"),
    })?;
    let args = PermeabilityArgs {
        packing: PathBuf::new(),
        out: None,
        checkpoint_every: 0.0,
        quiet: false,
        strict: false,
        ..a.clone()
    };
    let mut key = format!("{args:?}\n").into_bytes();
    key.extend(packing);
    Ok(key)
}

/// One printed line per rung.
fn rung_line(r: &Rung, unit_m: Option<f64>) -> String {
    let p = &r.result;
    format!(
        "rung {:>4} cells (dx = {:.4}): k = {:.6e} unit^2{}, porosity {:.4} (voxels), {} steps \
         in {:.1} s{}{}",
        r.cells,
        r.dx,
        p.k,
        unit_m.map_or(String::new(), |u| format!(" ({:.4e} m^2)", p.k * u * u)),
        p.porosity,
        p.run.steps,
        r.seconds,
        r.k_extrapolated.map_or(String::new(), |(e, se)| format!(
            "; extrapolated {e:.6e} +- {se:.1e}"
        )),
        if r.settled { "" } else { " (k NOT settled)" }
    )
}

/// permeability.json, ladder.csv, convergence.svg and the finest rung's fields.vtk.
fn write_outputs(
    out: &Path,
    a: &PermeabilityArgs,
    cell: &xyz::Cell,
    o: &LadderOptions,
    l: &Ladder,
    kozeny: Option<f64>,
) -> Result<()> {
    let mut csv = CsvTable::new(&[
        "cells",
        "dx_unit",
        "porosity_voxels",
        "k_unit2",
        "k_extrapolated_unit2",
        "k_extrapolated_se_unit2",
        "steps",
        "settled",
        "seconds_s",
    ]);
    for r in &l.rungs {
        csv.row([
            r.cells.to_string(),
            r.dx.to_string(),
            r.result.porosity.to_string(),
            r.result.k.to_string(),
            r.k_extrapolated.map_or(String::new(), |e| e.0.to_string()),
            r.k_extrapolated.map_or(String::new(), |e| e.1.to_string()),
            r.result.run.steps.to_string(),
            r.settled.to_string(),
            r.seconds.to_string(),
        ]);
    }
    csv.write(&out.join("ladder.csv"))?;
    let rungs: Vec<serde_json::Value> = l
        .rungs
        .iter()
        .map(|r| {
            serde_json::json!({
                "cells": r.cells, "k_unit2": r.result.k,
                "k_extrapolated_unit2": r.k_extrapolated.map(|e| e.0),
                "k_extrapolated_se_unit2": r.k_extrapolated.map(|e| e.1),
                "porosity_voxels": r.result.porosity, "steps": r.result.run.steps,
                "settled": r.settled, "seconds": r.seconds,
            })
        })
        .collect();
    let summary = serde_json::json!({
        "porelab_version": env!("CARGO_PKG_VERSION"),
        "xyz": a.packing.display().to_string(),
        "lattice": o.pore.lattice.name(), "collision": o.pore.collision.name(),
        "tau": o.pore.collision.tau.get(), "force_lattice": o.pore.force(),
        "rtol": o.rtol, "order_assumed": ORDER, "ratio": RATIO, "fit": "least squares over the last three rungs",
        "k_unit2": l.k, "k_error_unit2": l.k_error,
        "k_m2": a.unit_m.map(|u| l.k * u * u),
        "observed_order": l.observed_order, "converged": l.converged,
        "darcy_change_at_half_force": l.darcy_change,
        "porosity_particles": 1.0 - l.finest.phi_particles,
        "v_over_s_unit": l.finest.v_over_s, "kozeny_constant": kozeny,
        "rungs": rungs,
    });
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("permeability.json"), json.as_bytes())?;
    let h2 = |n: usize| (n as f64).powi(-2);
    let plot = Plot {
        title: "permeability against the lattice spacing".into(),
        x_label: "1 / cells^2 along x (Richardson's abscissa)".into(),
        y_label: "k (unit^2)".into(),
        log_x: false,
        log_y: false,
        series: vec![
            Series {
                label: "rungs".into(),
                points: l.rungs.iter().map(|r| (h2(r.cells), r.result.k)).collect(),
                y_err: None,
            },
            Series {
                label: "k_inf fitted to the three rungs ending here".into(),
                points: l
                    .rungs
                    .iter()
                    .filter_map(|r| r.k_extrapolated.map(|e| (h2(r.cells), e.0)))
                    .collect(),
                y_err: Some(
                    l.rungs
                        .iter()
                        .filter_map(|r| r.k_extrapolated.map(|e| e.1))
                        .collect(),
                ),
            },
        ],
    };
    write_svg(&out.join("convergence.svg"), &plot)?;
    let fields = &l.rungs[l.rungs.len() - 1].result.run.steady.fields;
    write_fields_vtk(
        &out.join("fields.vtk"),
        "porelab permeability, finest rung (lattice units; spacing in m with --unit-m)",
        &l.finest,
        fields,
        cell.origin,
        a.unit_m,
    )
}
