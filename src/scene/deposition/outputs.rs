//! What a deposition scene writes: per run `run-NNN/{final.xyz, porosity_profile.csv,
//! history.csv, summary.json}`, and over the runs `runs.csv`, `ensemble.csv`,
//! `porosity_profile.svg` and `summary.json`.

use super::schema::DepositionScene;
use crate::deposition::driver::Deposited;
use crate::deposition::measure::{posed, DepositMeasures};
use crate::deposition::{run_seed, Setup};
use crate::error::{Error, Result};
use crate::io::csv_table::CsvTable;
use crate::io::plot::CsvPlot;
use crate::io::write_atomic;
use crate::io::xyz::{Cell, XyzParticle};
use serde::Serialize;
use std::fmt::Display;
use std::path::Path;

/// One measured run.
pub struct RunResult {
    pub deposit: Deposited,
    pub measures: DepositMeasures,
    /// Wall time of the whole run (start, deposit, measures), s.
    pub seconds: f64,
}

/// Mean and standard error of a sample (None for an empty one; stderr None below 2 values).
fn mean_se(v: &[f64]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (Some(m), None);
    }
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (Some(m), Some((var / n).sqrt()))
}

/// One ensemble row: (name, mean, standard error, count).
pub(super) type EnsembleRow = (String, Option<f64>, Option<f64>, usize);

/// "mean +- standard error" of an ensemble row, for the line on stdout.
pub(super) fn fmt_mean(r: Option<&EnsembleRow>) -> String {
    match r {
        Some((_, Some(m), Some(se), _)) => format!("{m:.4} +- {se:.4}"),
        Some((_, Some(m), None, _)) => format!("{m:.4}"),
        _ => "n/a (layer too thin)".into(),
    }
}

/// Scalars per run, by name (None where not defined).
fn scalars(r: &RunResult) -> Vec<(String, Option<f64>)> {
    let m = &r.measures;
    let o = &r.deposit.outcome;
    let mut v = vec![
        ("layer_porosity".to_string(), Some(m.layer_porosity)),
        ("core_porosity".to_string(), m.core_porosity),
        ("rms_roughness_m".to_string(), Some(m.rms_roughness_m)),
        (
            "surface_mean_height_m".to_string(),
            Some(m.surface_mean_height_m),
        ),
        (
            "first_layer_coverage".to_string(),
            Some(m.first_layer_coverage),
        ),
        ("supported_fraction".to_string(), m.supported_fraction),
        (
            "contacts_below_per_sphere".to_string(),
            m.contacts_below_per_sphere,
        ),
        ("sweeps".to_string(), Some(o.sweeps as f64)),
        (
            "acceptance".to_string(),
            Some(o.accepted as f64 / o.moves.max(1) as f64),
        ),
        ("seconds".to_string(), Some(r.seconds)),
    ];
    for (k, o) in m.order_by_species.iter().enumerate() {
        v.push((format!("order_species{k}"), *o));
    }
    v
}

/// (name, mean, standard error, count) over the runs (at least one).
pub(super) fn ensemble(results: &[RunResult]) -> Vec<EnsembleRow> {
    let per: Vec<_> = results.iter().map(scalars).collect();
    (0..per.first().map_or(0, Vec::len))
        .map(|i| {
            let vals: Vec<f64> = per.iter().filter_map(|s| s[i].1).collect();
            let (m, se) = mean_se(&vals);
            (per[0][i].0.clone(), m, se, vals.len())
        })
        .collect()
}

/// A number, or nothing for None (a CSV cell).
fn cell(x: &Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

#[derive(Serialize)]
struct RunSummary<'a> {
    run: usize,
    seed: u64,
    particles: usize,
    measures: &'a DepositMeasures,
    sweeps: u64,
    moves: u64,
    accepted: u64,
    converged: bool,
    first_displacement_m: f64,
    prefilters: crate::deposition::overlap::PrefilterCounts,
    start_seconds: f64,
    seconds: f64,
}

/// The files of run `r` in `out/run-NNN/`: `final.xyz`, `porosity_profile.csv`,
/// `history.csv` and `summary.json`.
fn write_run(out: &Path, setup: &Setup, names: &[&str], r: &RunResult) -> Result<()> {
    let (k, layer, o) = (r.deposit.run, &r.deposit.layer, &r.deposit.outcome);
    let dir = out.join(format!("run-{k:03}"));
    let top = layer
        .poses
        .iter()
        .map(|p| p.position.z)
        .fold(layer.film_height_m, f64::max)
        + layer.reach_m();
    let cell_box = Cell {
        lengths: [setup.box_side_m, setup.box_side_m, top],
        origin: [0.0; 3],
        pbc: [true, true, false],
    };
    let parts: Vec<XyzParticle> = posed(layer)
        .iter()
        .zip(&layer.grains)
        .map(|(p, g)| XyzParticle {
            species: names[g.species].to_string(),
            position: p.position,
            orientation: p.orientation,
            aspherical_shape: p.semi_axes,
            radius: g.outer_radius_m,
            cylinder_length: 0.0,
            roundness: [1.0, 1.0],
        })
        .collect();
    crate::io::xyz::write(
        &dir.join("final.xyz"),
        &cell_box,
        &parts,
        &[("units", "m".into())],
    )?;
    let mut prof = CsvTable::new(&["z_low_m", "z_high_m", "porosity"]);
    for b in &r.measures.profile {
        prof.row([b.z_low_m, b.z_high_m, b.porosity]);
    }
    prof.write(&dir.join("porosity_profile.csv"))?;
    let mut hist = CsvTable::new(&[
        "sweep",
        "mean_displacement_m",
        "acceptance",
        "drainage_speed_m_s",
    ]);
    for h in &o.history {
        hist.row([
            &h.sweep as &dyn Display,
            &h.mean_displacement_m,
            &h.acceptance,
            &h.drainage_speed_m_s,
        ]);
    }
    hist.write(&dir.join("history.csv"))?;
    let s = RunSummary {
        run: k,
        seed: run_seed(setup.seed, k),
        particles: layer.grains.len(),
        measures: &r.measures,
        sweeps: o.sweeps,
        moves: o.moves,
        accepted: o.accepted,
        converged: o.converged,
        first_displacement_m: o.first_displacement_m,
        prefilters: o.prefilters,
        start_seconds: r.deposit.start_seconds,
        seconds: r.seconds,
    };
    write_atomic(
        &dir.join("summary.json"),
        serde_json::to_string_pretty(&s)
            .map_err(|e| Error::Validation(e.to_string()))?
            .as_bytes(),
    )?;
    Ok(())
}

/// Writes every file of the finished `results` (in run order) under `out`.
pub(super) fn write_outputs(
    scene: &DepositionScene,
    origin: &str,
    out: &Path,
    results: &[RunResult],
    seconds: f64,
) -> Result<()> {
    let setup = &scene.setup;
    let names: Vec<&str> = setup.species.iter().map(|s| s.name.as_str()).collect();
    let header: Vec<String> = results
        .first()
        .map(|r| scalars(r).into_iter().map(|(n, _)| n).collect())
        .unwrap_or_default();
    let mut runs_csv = CsvTable::new(
        &std::iter::once("run".to_string())
            .chain(header)
            .collect::<Vec<_>>(),
    );
    let mut profiles_csv = CsvTable::new(&["run", "z_mid_m", "porosity"]);
    for r in results {
        write_run(out, setup, &names, r)?;
        let k = r.deposit.run;
        for b in &r.measures.profile {
            let z_mid_m = 0.5 * (b.z_low_m + b.z_high_m);
            profiles_csv.row([&k as &dyn Display, &z_mid_m, &b.porosity]);
        }
        runs_csv.row(std::iter::once(k.to_string()).chain(scalars(r).iter().map(|(_, v)| cell(v))));
    }
    runs_csv.write(&out.join("runs.csv"))?;
    CsvPlot {
        title: "Porosity profile of the deposit (exact slab volumes), one curve per run",
        x: "z_mid_m",
        y: "porosity",
        group_by: &["run"],
        x_label: "height above the substrate (m)",
        y_label: "porosity",
        ..Default::default()
    }
    .write_or_warn(&out.join("porosity_profile.svg"), profiles_csv.as_str());
    let ens = ensemble(results);
    let mut ens_csv = CsvTable::new(&["quantity", "mean", "standard_error", "runs"]);
    for (n, m, se, c) in &ens {
        ens_csv.row([n.clone(), cell(m), cell(se), c.to_string()]);
    }
    ens_csv.write(&out.join("ensemble.csv"))?;
    let summary = serde_json::json!({
        "scene": origin,
        "title": scene.title,
        "porelab_version": env!("CARGO_PKG_VERSION"),
        "threads": rayon::current_num_threads(),
        "runs": results.len(),
        "particles": setup.particles,
        "box_side_m": setup.box_side_m,
        "pigment_volume_fraction_start": scene.phi,
        "fluid_density_kg_m3": setup.fluid_density_kg_m3,
        "species": names,
        "active_terms": setup.active_terms(),
        "converged_runs": results.iter().filter(|r| r.deposit.outcome.converged).count(),
        "ensemble": ens.iter().map(|(n, m, se, c)| serde_json::json!({
            "quantity": n, "mean": m, "standard_error": se, "runs": c})).collect::<Vec<_>>(),
        // The same means by name, as scalars that `porelab sweep collect` averages over jobs.
        "ensemble_mean": ens.iter().map(|(n, m, _, _)| (n.clone(), serde_json::json!(m)))
            .collect::<serde_json::Map<_, _>>(),
        "seconds": seconds,
    });
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .map_err(|e| Error::Validation(e.to_string()))?
            .as_bytes(),
    )?;
    Ok(())
}
