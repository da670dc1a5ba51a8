//! What a Brownian scene writes: `capture.csv` and `positions.csv` (capture), `cascade.csv`
//! (cascade), `capture_volume.csv` and `capture_volume_plane.csv` (capture volume), their
//! plots, and `summary.json` (parameters, active terms, final results, seconds).

use super::schema::{Combo, Scene};
use crate::brownian::experiment::{
    axis_at_angle, dipolar_coupling, mean_and_stderr, mean_chain_length, CaptureExperiment,
    CaptureVolume, Placement, Region, RunResult, Sample,
};
use crate::error::{Error, Result};
use crate::io::csv_table::CsvTable;
use crate::io::plot::CsvPlot;
use crate::io::write_atomic;
use crate::scene::RunOptions;
use std::path::Path;
use std::time::Instant;

/// The three cells naming a sweep point: aspect ratio, particle radius (m), alpha (deg).
fn point_cells(c: &Combo) -> [String; 3] {
    [
        c.aspect_ratio.to_string(),
        format!("{:e}", c.radius_m),
        c.alpha_deg.to_string(),
    ]
}

/// `capture.csv` (captured fraction per region and sample time, mean and standard error over
/// the runs, with the chain statistics) and `positions.csv` (start and end of every particle
/// of every run).
pub(super) struct CaptureTables {
    capture: CsvTable,
    positions: CsvTable,
}

impl CaptureTables {
    pub(super) fn new() -> CaptureTables {
        CaptureTables {
            capture: CsvTable::new(&[
                "aspect_ratio",
                "radius_m",
                "alpha_deg",
                "region",
                "time_s",
                "runs",
                "captured_fraction_mean",
                "captured_fraction_stderr",
                "mean_chain_length",
                "fraction_in_chains",
            ]),
            positions: CsvTable::new(&[
                "aspect_ratio",
                "radius_m",
                "alpha_deg",
                "run",
                "particle",
                "region",
                "x0_m",
                "y0_m",
                "z0_m",
                "x_m",
                "y_m",
                "z_m",
                "captured",
                "capture_time_s",
                "brownian",
            ]),
        }
    }

    /// Adds the rows of sweep point `c` (experiment `exp`, `results` of its `runs` runs, at
    /// least one) and returns its entry of the summary's results.
    pub(super) fn add_point(
        &mut self,
        c: &Combo,
        exp: &CaptureExperiment,
        runs: u64,
        results: &[RunResult],
    ) -> Result<serde_json::Value> {
        let Some(first) = results.first() else {
            return crate::error::invalid("a capture point without runs (internal)");
        };
        let regions = first.regions.clone();
        let volumes = exp.region_volumes(&regions)?;
        let key = point_cells(c);
        self.add_fractions(&key, runs, &regions, &volumes, results);
        self.add_positions(&key, results);
        final_entry(c, exp, &regions, &volumes, results)
    }

    /// capture.csv: per sample time, the captured fraction of each region and of all (TOP and
    /// SIDE weighted by volume), mean and standard error over the runs, and the chains.
    fn add_fractions(
        &mut self,
        key: &[String; 3],
        runs: u64,
        regions: &[Region],
        volumes: &[f64],
        results: &[RunResult],
    ) {
        let n_samples = results.first().map_or(0, |r| r.samples.len());
        for k in 0..n_samples {
            let t = results[0].samples[k].time_s;
            let chain_len: Vec<f64> = results
                .iter()
                .map(|r| r.samples[k].chains.mean_length)
                .collect();
            let chain_frac: Vec<f64> = results
                .iter()
                .map(|r| r.samples[k].chains.fraction_in_chains)
                .collect();
            let (cl, _) = mean_and_stderr(&chain_len);
            let (cf, _) = mean_and_stderr(&chain_frac);
            let mut rows: Vec<(&str, Vec<f64>)> = regions
                .iter()
                .enumerate()
                .map(|(ri, r)| {
                    (
                        r.name(),
                        results.iter().map(|x| x.samples[k].captured[ri]).collect(),
                    )
                })
                .collect();
            if regions.len() > 1 {
                rows.push((
                    "ALL",
                    results
                        .iter()
                        .map(|x| weighted(&x.samples[k], volumes))
                        .collect(),
                ));
            }
            for (name, vals) in rows {
                let (m, se) = mean_and_stderr(&vals);
                self.capture.row(key.iter().cloned().chain([
                    name.to_string(),
                    format!("{t:.6e}"),
                    runs.to_string(),
                    format!("{m:.6}"),
                    format!("{se:.6}"),
                    format!("{cl:.4}"),
                    format!("{cf:.4}"),
                ]));
            }
        }
    }

    /// positions.csv: start and end of every particle of every run.
    fn add_positions(&mut self, key: &[String; 3], results: &[RunResult]) {
        for r in results {
            for i in 0..r.initial.len() {
                let (p0, p1) = (r.initial[i], r.last[i]);
                self.positions.row(key.iter().cloned().chain([
                    r.run.to_string(),
                    i.to_string(),
                    r.region_of[i].name().to_string(),
                    format!("{:e}", p0.x),
                    format!("{:e}", p0.y),
                    format!("{:e}", p0.z),
                    format!("{:e}", p1.x),
                    format!("{:e}", p1.y),
                    format!("{:e}", p1.z),
                    r.capture_time_s[i].is_some().to_string(),
                    r.capture_time_s[i].map_or(String::new(), |t| format!("{t:e}")),
                    r.brownian[i].to_string(),
                ]));
            }
        }
    }

    /// Writes `capture.csv`, `positions.csv` and the plot `capture.svg`.
    pub(super) fn write(&self, out: &Path) -> Result<()> {
        self.capture.write(&out.join("capture.csv"))?;
        self.positions.write(&out.join("positions.csv"))?;
        CsvPlot {
            title: "Captured fraction (mean over runs, one standard error)",
            x: "time_s",
            y: "captured_fraction_mean",
            y_err: Some("captured_fraction_stderr"),
            group_by: &["aspect_ratio", "radius_m", "alpha_deg", "region"],
            x_label: "time (s)",
            y_label: "captured fraction",
            ..Default::default()
        }
        .write_or_warn(&out.join("capture.svg"), self.capture.as_str());
        Ok(())
    }
}

/// The captured fraction of all of a sample's regions, each weighted by its volume.
fn weighted(s: &Sample, volumes: &[f64]) -> f64 {
    let w: f64 = volumes.iter().sum();
    s.captured
        .iter()
        .zip(volumes)
        .map(|(f, v)| f * v)
        .sum::<f64>()
        / w
}

/// The summary's entry of sweep point `c`: the final captured fraction per region and over
/// all, the share of free particles that stayed Brownian (eq. 6.24), the moment, the cylinder's
/// magnetization, the dipolar coupling (eq. 6.25) and, for a block, the chain lengths (eq. 6.26).
fn final_entry(
    c: &Combo,
    exp: &CaptureExperiment,
    regions: &[Region],
    volumes: &[f64],
    results: &[RunResult],
) -> Result<serde_json::Value> {
    let n_samples = results.first().map_or(0, |r| r.samples.len());
    let mut per_region = serde_json::Map::new();
    for (ri, reg) in regions.iter().enumerate() {
        let finals_r: Vec<f64> = results
            .iter()
            .map(|x| x.samples[n_samples - 1].captured[ri])
            .collect();
        let brown: Vec<f64> = results
            .iter()
            .map(|x| {
                let idx: Vec<usize> = (0..x.region_of.len())
                    .filter(|&i| x.region_of[i] == *reg)
                    .collect();
                idx.iter().filter(|&&i| x.brownian[i]).count() as f64 / idx.len().max(1) as f64
            })
            .collect();
        let (m, se) = mean_and_stderr(&finals_r);
        let (bm, bse) = mean_and_stderr(&brown);
        per_region.insert(
            reg.name().into(),
            serde_json::json!({"captured_fraction": m, "stderr": se,
                               "brownian_fraction_eq_6_24": bm, "brownian_stderr": bse,
                               "region_volume_m3": volumes[ri]}),
        );
    }
    if regions.len() > 1 {
        let all: Vec<f64> = results
            .iter()
            .map(|x| weighted(&x.samples[n_samples - 1], volumes))
            .collect();
        let (m, se) = mean_and_stderr(&all);
        per_region.insert(
            "ALL".into(),
            serde_json::json!({"captured_fraction": m, "stderr": se}),
        );
    }
    let mu = exp.moment.saturation();
    let gamma = dipolar_coupling(mu, 2.0 * c.radius_m, exp.fluid.kt());
    let mut entry = serde_json::json!({
        "aspect_ratio": c.aspect_ratio, "radius_m": c.radius_m, "alpha_deg": c.alpha_deg,
        "moment_A_m2": mu,
        "magnetization_A_per_m": exp.magnet(axis_at_angle(exp.alpha))?.magnetization.as_slice(),
        "final": per_region,
        "dipolar_coupling_gamma_eq_6_25": gamma,
    });
    if let Placement::Block { spacing_m, .. } = exp.placement {
        let phi0 = 4.0 / 3.0 * std::f64::consts::PI * c.radius_m.powi(3) / spacing_m.powi(3);
        let chains: Vec<f64> = results
            .iter()
            .map(|r| {
                r.samples
                    .iter()
                    .map(|s| s.chains.mean_length)
                    .fold(0.0, f64::max)
            })
            .collect();
        entry["block"] = serde_json::json!({
            "lattice_spacing_m": spacing_m, "volume_fraction": phi0,
            "mean_chain_length_eq_6_26": mean_chain_length(phi0, gamma),
            "largest_mean_chain_length_observed": mean_and_stderr(&chains).0,
        });
    }
    Ok(entry)
}

/// `cascade.csv`: the cumulative captured fraction against time per cascade mode (mean and
/// standard error over the runs), and the time each mode takes to capture 90 %.
pub(super) struct CascadeTable {
    csv: CsvTable,
    summary: serde_json::Map<String, serde_json::Value>,
}

impl CascadeTable {
    pub(super) fn new() -> CascadeTable {
        CascadeTable {
            csv: CsvTable::new(&[
                "mode",
                "time_s",
                "runs",
                "captured_fraction_mean",
                "captured_fraction_stderr",
            ]),
            summary: serde_json::Map::new(),
        }
    }

    /// Adds the curves (time (s), captured fraction) of the `runs` runs of mode `name`.
    pub(super) fn add_mode(&mut self, name: &str, runs: u64, curves: &[Vec<(f64, f64)>]) {
        // Curves stop early when every particle is captured: extend them at 1.
        let len = curves.iter().map(|c| c.len()).max().unwrap_or(0);
        let times: Vec<f64> = curves
            .iter()
            .find(|c| c.len() == len)
            .map(|c| c.iter().map(|x| x.0).collect())
            .unwrap_or_default();
        let mut t90 = None;
        for (k, t) in times.iter().enumerate() {
            let vals: Vec<f64> = curves
                .iter()
                .map(|c| c.get(k).map_or(1.0, |x| x.1))
                .collect();
            let (m, se) = mean_and_stderr(&vals);
            if t90.is_none() && m >= 0.9 {
                t90 = Some(*t);
            }
            self.csv.row([
                name.to_string(),
                format!("{t:.6e}"),
                runs.to_string(),
                format!("{m:.6}"),
                format!("{se:.6}"),
            ]);
        }
        self.summary.insert(
            name.to_string(),
            serde_json::json!({"time_to_90_percent_s": t90}),
        );
    }

    /// Writes `cascade.csv` and its plot; returns the summary's results.
    pub(super) fn write(self, out: &Path) -> Result<serde_json::Value> {
        self.csv.write(&out.join("cascade.csv"))?;
        CsvPlot {
            title: "Cascade: captured fraction (mean over runs, one standard error)",
            x: "time_s",
            y: "captured_fraction_mean",
            y_err: Some("captured_fraction_stderr"),
            group_by: &["mode"],
            x_label: "time (s)",
            y_label: "captured fraction",
            ..Default::default()
        }
        .write_or_warn(&out.join("cascade.svg"), self.csv.as_str());
        Ok(serde_json::Value::Object(self.summary))
    }
}

/// `capture_volume.csv` (the volume per sweep point) and `capture_volume_plane.csv` (the
/// force map of the plane through the axis).
pub(super) struct VolumeTables {
    volumes: CsvTable,
    plane: CsvTable,
    rows: Vec<serde_json::Value>,
}

impl VolumeTables {
    pub(super) fn new() -> VolumeTables {
        VolumeTables {
            volumes: CsvTable::new(&[
                "aspect_ratio",
                "radius_m",
                "alpha_deg",
                "capture_volume_m3",
                "cylinder_volume_m3",
                "ratio",
                "reaches_box",
            ]),
            plane: CsvTable::new(&[
                "aspect_ratio",
                "radius_m",
                "alpha_deg",
                "x_m",
                "z_m",
                "fx_N",
                "fy_N",
                "fz_N",
                "force_N",
                "captured",
            ]),
            rows: Vec::new(),
        }
    }

    /// Adds the capture volume `cv` of sweep point `c`.
    pub(super) fn add_point(&mut self, c: &Combo, cv: &CaptureVolume) {
        let key = point_cells(c);
        let ratio = cv.volume_m3 / cv.cylinder_volume_m3;
        self.volumes.row(key.iter().cloned().chain([
            format!("{:e}", cv.volume_m3),
            format!("{:e}", cv.cylinder_volume_m3),
            format!("{ratio:.6}"),
            cv.reaches_box.to_string(),
        ]));
        for (x, z, f, cap) in &cv.plane {
            self.plane.row(key.iter().cloned().chain([
                format!("{x:e}"),
                format!("{z:e}"),
                format!("{:e}", f.x),
                format!("{:e}", f.y),
                format!("{:e}", f.z),
                format!("{:e}", f.norm()),
                cap.to_string(),
            ]));
        }
        self.rows.push(serde_json::json!({"aspect_ratio": c.aspect_ratio, "radius_m": c.radius_m,
            "alpha_deg": c.alpha_deg, "capture_volume_m3": cv.volume_m3, "ratio_to_cylinder": ratio, "reaches_box": cv.reaches_box}));
    }

    /// Writes both tables; returns the summary's results.
    pub(super) fn write(self, out: &Path) -> Result<serde_json::Value> {
        self.volumes.write(&out.join("capture_volume.csv"))?;
        self.plane.write(&out.join("capture_volume_plane.csv"))?;
        Ok(serde_json::Value::Array(self.rows))
    }
}

/// Writes `summary.json`: the scene, its parameters and active terms, the `results` and the
/// seconds since `started`.
pub(super) fn write_summary(
    out: &Path,
    origin: &str,
    scene: &Scene,
    opts: &RunOptions,
    terms: &[String],
    results: serde_json::Value,
    started: Instant,
) -> Result<()> {
    let summary = serde_json::json!({
        "scene": origin,
        "title": scene.title,
        "experiment": scene.experiment,
        "porelab_version": env!("CARGO_PKG_VERSION"),
        "seed": scene.run.seed,
        "runs": scene.run.runs,
        "threads": opts.threads.unwrap_or_else(rayon::current_num_threads),
        "active_terms": terms,
        "parameters": {
            "dt_s": scene.run.dt_s, "t_max_s": scene.run.t_max_s,
            "temperature_K": scene.fluid.temperature_K,
            // The summary's key keeps its earlier spelling (files that read it are unchanged).
            "viscosity_Pa_s": scene.fluid.viscosity_pa_s,
            "b_T": scene.field.b_T,
            "cylinder_diameter_m": scene.cylinder.diameter_m,
            "saturation_A_per_m": scene.cylinder.saturation_a_per_m,
            "magnetization": scene.cylinder.magnetization,
            "placement": scene.particles.placement,
            "region_gap_m": scene.particles.region_gap_m,
            "region_thickness_m": scene.particles.region_thickness_m,
        },
        "results": results,
        "seconds": started.elapsed().as_secs_f64(),
    });
    let text =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), text.as_bytes())
}
