//! Case 950 (thesis 003 ch. 7, slow): the magnetic filter end to end. The thesis' 4 mm fibres
//! packed by porelab's MCM (the committed `bed.xyz` of the case folder, made by its
//! `bed-packing.toml`), the filter scene's lattice flow through that bed (its permeability at
//! two resolutions beside the measured k = 2.2e-4 cm^2 of sec. 7.4.4), and magnetite capture at
//! 1 T at two superficial speeds a factor 4 apart (sec. 7.4.2: the faster flow lets particles
//! through). Every run is the case's own filter scene (`filter.toml`) with a few keys changed,
//! run by [`run_scene`] as `porelab run` would; the figures are read from its summary.json.

use super::common::band_rows;
use crate::lbm::pore::kozeny_constant;
use crate::scene::filter::run_scene;
use crate::scene::RunOptions;
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use std::collections::BTreeMap;

/// The permeability of the 4 mm fibre bed measured in thesis sec. 7.4.4 (eq. 7.10):
/// 2.2e-4 cm^2.
const K_THESIS_M2: f64 = 2.2e-8;
/// The fast run's speed over the slow one's (sec. 7.4.2: "approximately a 4x higher flow
/// velocity").
const SPEED_RATIO: f64 = 4.0;
/// Cells per fibre diameter of the coarse lattice over the fine one's (4 against 5).
const COARSE_OVER_FINE: f64 = 0.8;
/// The fibres' length over diameter (the filter's solid cylinders: 4 mm / 0.4 mm).
const FIBRE_L_OVER_D: f64 = 10.0;

/// What one filter run reports (its summary.json).
struct Summary {
    k_m2: f64,
    porosity: f64,
    voxels: String,
    u_m_s: f64,
    reynolds: f64,
    fed: f64,
    captured: f64,
    passed: f64,
    inside: f64,
    depth_m: f64,
    steps: f64,
    seconds: f64,
}

impl Summary {
    /// The captured fraction and its binomial variance.
    fn captured_fraction(&self) -> (f64, f64) {
        let f = self.captured / self.fed;
        (f, f * (1.0 - f) / self.fed)
    }
    /// The filter coefficient lambda = -ln(P) / depth (1/m) of the penetration P = passed /
    /// fed of the one-cell bed, and its delta-method standard error.
    fn filter_coefficient(&self) -> (f64, f64) {
        let p = self.passed / self.fed;
        let se_p = (p * (1.0 - p) / self.fed).sqrt();
        (-p.ln() / self.depth_m, se_p / (p * self.depth_m))
    }
}

/// Runs the case's filter scene with `edits` ((section, key, value)) in a temporary folder.
fn run_edited(
    ctx: &CaseContext,
    base: &toml::Table,
    edits: &[(&str, &str, toml::Value)],
    label: &str,
) -> Result<Summary> {
    let origin = ctx.case_dir.join("filter.toml");
    let mut scene = base.clone();
    for (section, key, value) in edits {
        let table = scene
            .get_mut(*section)
            .and_then(|s| s.as_table_mut())
            .ok_or_else(|| {
                Error::Validation(format!("{}: no [{section}] table", origin.display()))
            })?;
        table.insert((*key).to_string(), value.clone());
    }
    let text = toml::to_string(&scene).map_err(|e| Error::Validation(e.to_string()))?;
    let out = std::env::temp_dir().join(format!("porelab-950-{}-{label}", std::process::id()));
    // a leftover folder of an earlier run would be resumed; start afresh
    let _ = std::fs::remove_dir_all(&out);
    let opts = RunOptions {
        out: Some(out.clone()),
        threads: None,
        quiet: true,
        checkpoint_every_seconds: None,
    };
    run_scene(&text, &origin.display().to_string(), &out, &opts)?;
    let summary_path = out.join("summary.json");
    let json = std::fs::read_to_string(&summary_path).map_err(|e| Error::File {
        path: summary_path.display().to_string(),
        msg: e.to_string(),
    })?;
    let _ = std::fs::remove_dir_all(&out);
    let v: serde_json::Value =
        serde_json::from_str(&json).map_err(|e| Error::Validation(e.to_string()))?;
    let num = |path: &[&str]| -> Result<f64> {
        path.iter()
            .try_fold(&v, |v, k| v.get(k))
            .and_then(|x| x.as_f64())
            .ok_or_else(|| {
                Error::Validation(format!(
                    "950 {label}: summary.json has no {}",
                    path.join(".")
                ))
            })
    };
    Ok(Summary {
        k_m2: num(&["flow", "permeability_m2"])?,
        porosity: num(&["flow", "porosity_voxels"])?,
        voxels: v["flow"]["voxels"].to_string(),
        u_m_s: num(&["flow", "superficial_velocity_m_s"])?,
        reynolds: num(&["flow", "fibre_reynolds"])?,
        fed: num(&["fed"])?,
        captured: num(&["captured"])?,
        passed: num(&["passed"])?,
        inside: num(&["inside"])?,
        depth_m: num(&["bed", "depth_m"])?,
        steps: num(&["steps"])?,
        seconds: num(&["seconds"])?,
    })
}

/// The number at `key` of `section` in the scene.
fn scene_f64(base: &toml::Table, section: &str, key: &str) -> Result<f64> {
    base.get(section)
        .and_then(|s| s.get(key))
        .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        .ok_or_else(|| Error::Validation(format!("950: filter.toml has no number {section}.{key}")))
}

register!("950" => case_950);
/// Case 950: the bed's permeability (fine and coarse lattice) against the thesis' measurement,
/// and capture at 1 T for two speeds a factor [`SPEED_RATIO`] apart; expected.csv holds the
/// bands (`quantity,lower,upper,source`).
pub fn case_950(ctx: &CaseContext) -> Result<Vec<Row>> {
    let path = ctx.case_dir.join("filter.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| Error::File {
        path: path.display().to_string(),
        msg: e.to_string(),
    })?;
    let base: toml::Table = text.parse().map_err(|e: toml::de::Error| Error::File {
        path: path.display().to_string(),
        msg: e.to_string(),
    })?;
    let fine = scene_f64(&base, "bed", "resolution")?;
    let radius = scene_f64(&base, "bed", "fibre_radius_m")?;

    let u_slow = scene_f64(&base, "flow", "superficial_velocity_m_s")?;
    let dt_slow = scene_f64(&base, "run", "dt_s")?;
    let coarse = (COARSE_OVER_FINE * fine).round() as i64;
    // the permeability on the coarse lattice: no field, one particle (the flow is the output)
    let k_coarse = run_edited(
        ctx,
        &base,
        &[
            ("bed", "resolution", toml::Value::Integer(coarse)),
            ("field", "applied_T", toml::Value::Float(0.0)),
            ("particles", "fed", toml::Value::Integer(1)),
        ],
        "coarse",
    )?;
    let slow = run_edited(ctx, &base, &[], "slow")?;
    // the noise step sqrt(2 D dt) scales with the concentration layer, as Pe^(-1/3), so that the
    // capture test's lag behind the absorbing wall is the same fraction of it at both speeds
    // (case 454's numerics): dt ~ U^(-2/3)
    let fast = run_edited(
        ctx,
        &base,
        &[
            (
                "flow",
                "superficial_velocity_m_s",
                toml::Value::Float(SPEED_RATIO * u_slow),
            ),
            (
                "run",
                "dt_s",
                toml::Value::Float(dt_slow * SPEED_RATIO.powf(-2.0 / 3.0)),
            ),
        ],
        "fast",
    )?;
    for (name, s) in [("coarse", &k_coarse), ("slow", &slow), ("fast", &fast)] {
        eprintln!(
            "950 {name}: lattice {} voxels, porosity {:.4}, k = {:.4e} m^2; U = {:.3e} m/s, \
             Re_fibre {:.3}; fed {}, captured {}, passed {}, inside {} after {} steps ({:.0} s)",
            s.voxels,
            s.porosity,
            s.k_m2,
            s.u_m_s,
            s.reynolds,
            s.fed,
            s.captured,
            s.passed,
            s.inside,
            s.steps,
            s.seconds
        );
    }
    for s in [&slow, &fast] {
        if s.inside * 1000.0 > s.fed {
            return Err(Error::Validation(format!(
                "950: U = {:e} m/s: {} of {} particles still inside after {} steps; raise \
                 run.max_steps in filter.toml",
                s.u_m_s, s.inside, s.fed, s.steps
            )));
        }
    }
    let k_change = slow.k_m2 / k_coarse.k_m2 - 1.0;
    let k_ratio = slow.k_m2 / K_THESIS_M2;
    eprintln!(
        "950 permeability: {:.4e} m^2 (fine) vs thesis {K_THESIS_M2:e} m^2: ratio {k_ratio:.3} \
         (log10 {:+.3}); coarse -> fine {:+.2} %",
        slow.k_m2,
        k_ratio.log10(),
        100.0 * k_change
    );
    let ((fs, vs), (ff, vf)) = (slow.captured_fraction(), fast.captured_fraction());
    let z = (fs - ff) / (vs + vf).sqrt();
    let ((ls, ses), (lf, sef)) = (slow.filter_coefficient(), fast.filter_coefficient());
    let ratio = ls / lf;
    let ratio_se = ratio * ((ses / ls).powi(2) + (sef / lf).powi(2)).sqrt();
    eprintln!(
        "950 capture at 1 T, depth {:.3e} m: slow U {:.3e} m/s captures {fs:.4} +- {:.4}, fast \
         {:.3e} captures {ff:.4} +- {:.4}: difference {:.4} = {z:.2} s.e.; lambda {ls:.2} +- \
         {ses:.2} 1/m vs {lf:.2} +- {sef:.2} 1/m: ratio {ratio:.3} +- {ratio_se:.3} (exponent n \
         of lambda ~ U^-n: {:.3})",
        slow.depth_m,
        slow.u_m_s,
        vs.sqrt(),
        fast.u_m_s,
        vf.sqrt(),
        fs - ff,
        ratio.ln() / SPEED_RATIO.ln()
    );
    // eq. 7.4 read as the Kozeny constant, with the voxels' solid fraction and nu = V/S of the
    // flat-ended cylinder, R L / (2 (L + R)) = D (L/D) / (4 (L/D + 1/2))
    let phi = 1.0 - slow.porosity;
    let nu_m = 2.0 * radius * FIBRE_L_OVER_D / (4.0 * (FIBRE_L_OVER_D + 0.5));
    let c_kc = kozeny_constant(slow.k_m2, phi, nu_m);
    eprintln!(
        "950 Kozeny-Carman (eq. 7.4): solid fraction {phi:.4}, nu = V/S = {nu_m:.4e} m: C_KC = \
         {c_kc:.3} (coarse lattice {:.3})",
        kozeny_constant(k_coarse.k_m2, 1.0 - k_coarse.porosity, nu_m)
    );
    let got = BTreeMap::from([
        ("kozeny_constant", c_kc),
        ("log10_k_over_thesis", k_ratio.log10()),
        ("k_change_coarse_to_fine", k_change),
        ("capture_difference_in_se", z),
        ("filter_coefficient_ratio", ratio),
    ]);
    band_rows(ctx, &got)
}
