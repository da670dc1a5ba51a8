//! End-to-end capture cases (thesis 003, section 6.4): the thesis' findings must hold in
//! porelab's capture runs. Each case runs [`CaptureExperiment`]s with the section 6.3 physics
//! (Table 6.1 moments, Mie(30,15) at 100 kT, dipole pairs cut at 30 R, Stoner–Wohlfarth
//! magnetization of a D = 600 um cylinder in 1 T along x, T = 298 K, eta = 1 mPa s; free-draining
//! because the particles are dilute) and turns a finding into statistics with bands in
//! expected.csv (`quantity,lower,upper,source`; see [`super::common::band_rows`]).
//!
//! A finding "A captures more than B" is the one-sided two-proportion z statistic
//! z = (p_A - p_B) / sqrt(p (1 - p) (1/n_A + 1/n_B)) (p pooled) over all particles of all runs
//! (independent: dilute particles, separate random streams), and the band is z >= 3.09 (one
//! sided alpha = 1e-3).

use super::common::{band_rows, required_seed};
use crate::brownian::driver::run_ensemble;
use crate::brownian::experiment::{
    CaptureExperiment, CylinderSetup, MagnetizationLaw, Placement, Region, RegionShape, RunResult,
    TABLE_6_1,
};
use crate::brownian::{Fluid, Hydrodynamics, LangevinMoment, NoiseMethod, StepGuard};
use crate::consts::MU0;
use crate::driver::NoHooks;
use crate::validation::{CaseContext, Row};
use crate::Result;
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// The section 6.3 setup with the given particle radius (Table 6.1), cylinder angle, aspect
/// ratio, particles per region, duration and time step.
fn experiment(
    radius_nm: f64,
    alpha_deg: f64,
    aspect_ratio: f64,
    per_region: usize,
    t_max_s: f64,
    dt_s: f64,
) -> Result<CaptureExperiment> {
    let mu = TABLE_6_1
        .iter()
        .find(|(r, _)| *r == radius_nm)
        .map(|(_, m)| m * 1e-16)
        .ok_or_else(|| crate::Error::Validation(format!("{radius_nm} nm not in Table 6.1")))?;
    Ok(CaptureExperiment {
        fluid: Fluid::new(298.0, 1e-3)?,
        dt_s,
        particle_radius_m: radius_nm * 1e-9,
        moment: LangevinMoment::fixed(mu)?,
        placement: Placement::TopSide {
            n_top: per_region,
            n_side: per_region,
            shape: RegionShape::new(1e-6, 300e-6)?,
        },
        cylinder: CylinderSetup {
            diameter_m: 600e-6,
            aspect_ratio,
            saturation_a_per_m: 985e3,
            law: MagnetizationLaw::StonerWohlfarth,
        },
        alpha: alpha_deg.to_radians(),
        h0: Vector3::new(1.0 / MU0, 0.0, 0.0),
        hydrodynamics: Hydrodynamics::FreeDraining,
        noise: NoiseMethod::TeaHi,
        mie: Some((30, 15, 100.0)),
        dipole_cutoff_m: Some(30.0 * radius_nm * 1e-9),
        guard: StepGuard::Substep {
            max_fraction: 0.5,
            max_halvings: 20,
        },
        t_max_s,
        sample_every_s: t_max_s,
        bond_factor: 1.1,
    })
}

/// (captured, total) in `region` (None: all particles) at the end, over all runs.
struct Tally {
    captured: usize,
    total: usize,
}

impl Tally {
    fn of(results: &[RunResult], region: Option<Region>) -> Tally {
        let mut t = Tally {
            captured: 0,
            total: 0,
        };
        for r in results {
            for i in 0..r.region_of.len() {
                if region.is_none_or(|g| r.region_of[i] == g) {
                    t.total += 1;
                    t.captured += usize::from(r.capture_time_s[i].is_some());
                }
            }
        }
        t
    }
    fn fraction(&self) -> f64 {
        self.captured as f64 / self.total.max(1) as f64
    }
}

/// Two-proportion z statistic (pooled variance) of "a captures more than b"; 0 when the pooled
/// variance is zero (all or none captured in both), where no difference can be shown.
fn z_more(a: &Tally, b: &Tally) -> f64 {
    let p = (a.captured + b.captured) as f64 / (a.total + b.total) as f64;
    let se = (p * (1.0 - p) * (1.0 / a.total as f64 + 1.0 / b.total as f64)).sqrt();
    if se == 0.0 {
        return 0.0;
    }
    (a.fraction() - b.fraction()) / se
}

fn runs(exp: &CaptureExperiment, seed: u64, n: u64) -> Result<Vec<RunResult>> {
    run_ensemble(n, None, |r| exp.run(seed, r, &mut NoHooks))
}

register!("415" => case_415);
/// Case 415: Fig. 6.4 — a transverse cylinder (alpha = 90 deg) captures more SIDE particles
/// than a longitudinal one (alpha = 0), and the longitudinal one more TOP particles.
pub fn case_415(ctx: &CaseContext) -> Result<Vec<Row>> {
    let seed = required_seed(ctx, "case 415 needs a seed")?;
    let long = runs(&experiment(75.0, 0.0, 20.0, 20, 5.0, 5e-4)?, seed, 2)?;
    let trans = runs(&experiment(75.0, 90.0, 20.0, 20, 5.0, 5e-4)?, seed, 2)?;
    let (lt, ls) = (
        Tally::of(&long, Some(Region::Top)),
        Tally::of(&long, Some(Region::Side)),
    );
    let (tt, ts) = (
        Tally::of(&trans, Some(Region::Top)),
        Tally::of(&trans, Some(Region::Side)),
    );
    let mut got = BTreeMap::new();
    got.insert("z_side_transverse_over_longitudinal", z_more(&ts, &ls));
    got.insert("z_top_longitudinal_over_transverse", z_more(&lt, &tt));
    got.insert("top_longitudinal", lt.fraction());
    got.insert("side_longitudinal", ls.fraction());
    got.insert("top_transverse", tt.fraction());
    got.insert("side_transverse", ts.fraction());
    band_rows(ctx, &got)
}

register!("416" => case_416);
/// Case 416: Fig. 6.6 — the capture fraction rises with particle size (25 < 75 < 212 nm,
/// transverse cylinder, TOP and SIDE together).
pub fn case_416(ctx: &CaseContext) -> Result<Vec<Row>> {
    let seed = required_seed(ctx, "case 416 needs a seed")?;
    let tally = |r: f64| -> Result<Tally> {
        Ok(Tally::of(
            &runs(&experiment(r, 90.0, 20.0, 40, 5.0, 5e-4)?, seed, 2)?,
            None,
        ))
    };
    let (small, mid, large) = (tally(25.0)?, tally(75.0)?, tally(212.0)?);
    let mut got = BTreeMap::new();
    got.insert("z_75nm_over_25nm", z_more(&mid, &small));
    got.insert("z_212nm_over_75nm", z_more(&large, &mid));
    got.insert("captured_25nm", small.fraction());
    got.insert("captured_75nm", mid.fraction());
    got.insert("captured_212nm", large.fraction());
    band_rows(ctx, &got)
}

register!("417" => case_417);
/// Case 417 (slow): section 6.4.4 — short cylinders (L/D = 5/3 and 6) perpendicular to the
/// field capture nearly all particles with R >= 50 nm within 50 s. The captured fraction is the
/// thesis' TOP-and-SIDE average weighted by region volume (Fig. 6.6, 6.8b: "averaged with a
/// weight proportional to the volume of the respective region"), the average the section's
/// conclusion rests on; the plain pooled count (TOP and SIDE equally) is reported beside it.
pub fn case_417(ctx: &CaseContext) -> Result<Vec<Row>> {
    let seed = required_seed(ctx, "case 417 needs a seed")?;
    let mut got = BTreeMap::new();
    for (key, pooled_key, ar, r) in [
        (
            "captured_ld_1.67_50nm_50s",
            "pooled_ld_1.67_50nm_50s",
            5.0 / 3.0,
            50.0,
        ),
        (
            "captured_ld_1.67_125nm_50s",
            "pooled_ld_1.67_125nm_50s",
            5.0 / 3.0,
            125.0,
        ),
        ("captured_ld_6_50nm_50s", "pooled_ld_6_50nm_50s", 6.0, 50.0),
        (
            "captured_ld_6_125nm_50s",
            "pooled_ld_6_125nm_50s",
            6.0,
            125.0,
        ),
    ] {
        let exp = experiment(r, 90.0, ar, 25, 50.0, 5e-4)?;
        let results = runs(&exp, seed, 2)?;
        let (top, side) = (
            Tally::of(&results, Some(Region::Top)),
            Tally::of(&results, Some(Region::Side)),
        );
        let v = exp.region_volumes(&[Region::Top, Region::Side])?;
        got.insert(
            key,
            (v[0] * top.fraction() + v[1] * side.fraction()) / (v[0] + v[1]),
        );
        got.insert(pooled_key, Tally::of(&results, None).fraction());
    }
    band_rows(ctx, &got)
}

register!("418" => case_418);
/// Case 418 (slow): the capture fraction after 5 s does not depend on the time step (1e-3,
/// 5e-4, 2.5e-4 s; R = 125 nm, alpha = 45 deg): two-sided two-proportion z within 3.29 (alpha =
/// 1e-3) against the smallest step.
pub fn case_418(ctx: &CaseContext) -> Result<Vec<Row>> {
    let seed = required_seed(ctx, "case 418 needs a seed")?;
    let tally = |dt: f64| -> Result<Tally> {
        Ok(Tally::of(
            &runs(&experiment(125.0, 45.0, 20.0, 50, 5.0, dt)?, seed, 4)?,
            None,
        ))
    };
    let fine = tally(2.5e-4)?;
    let mut got = BTreeMap::new();
    got.insert("captured_dt_2.5e-4", fine.fraction());
    got.insert("z_dt_1e-3_vs_2.5e-4", z_more(&tally(1e-3)?, &fine));
    got.insert("z_dt_5e-4_vs_2.5e-4", z_more(&tally(5e-4)?, &fine));
    band_rows(ctx, &got)
}

/// The cumulative captured fraction of a cascade curve at time `t` (s): the last sample at or
/// before `t`; a curve that stopped early (every particle captured) stays at its last value.
fn cascade_at(curve: &[(f64, f64)], t: f64) -> f64 {
    curve
        .iter()
        .take_while(|(ti, _)| *ti <= t * (1.0 + 1e-9))
        .last()
        .map_or(0.0, |p| p.1)
}

/// Mean, variance of the mean, and count of `v`.
fn mean_var_of_mean(v: &[f64]) -> (f64, f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s2 = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, s2 / n, n)
}

/// Welch–Satterthwaite degrees of freedom of a sum of variances of means `(var, n)`.
fn welch_dof(parts: &[(f64, f64)]) -> f64 {
    let num = parts.iter().map(|(v, _)| v).sum::<f64>().powi(2);
    let den = parts.iter().map(|(v, n)| v * v / (n - 1.0)).sum::<f64>();
    num / den
}

register!("419" => case_419);
/// Case 419 (section 6.4.5, Fig. 6.11a): the cascade with optimally oriented cylinders
/// (perpendicular to the field, parallel to each other) captures more than the cascade with
/// randomly oriented ones, and both cascades are sequences of independent stages.
///
/// R = 125 nm, 0.5 s per stage (the thesis' Delta t_run for this size), L/D = 20, N = 100
/// particles placed uniformly over TOP and SIDE at every stage.
/// - Finding: at t = 5.5 s (where the thesis' optimal cascade reaches 90 %) the mean captured
///   fraction of the optimal cascade exceeds the random one: Welch's t over the per-run
///   fractions (runs are the independent units: in a random cascade the particles of a run share
///   the cylinder orientations), one-sided p <= 1e-3.
/// - Closed form: a free particle is placed afresh at every stage, independently of its past,
///   so after k stages the expected captured fraction is 1 - (1 - p)^k, with p the single-stage
///   capture probability averaged over the stage's orientation (fixed for the optimal cascade,
///   uniform on the sphere for the random one). p is measured by independent single-stage runs
///   (another seed); the cascade after k = 5 stages must agree within two-sided alpha = 1e-3
///   (optimal: binomial variances, the particles being independent; random: per-run variances,
///   Welch's t, the variance of 1 - (1 - p)^k by the delta method, k (1 - p)^(k-1)).
pub fn case_419(ctx: &CaseContext) -> Result<Vec<Row>> {
    use crate::brownian::experiment::{run_cascade, CascadeMode};
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let seed = required_seed(ctx, "case 419 needs a seed")?;
    let (n, stage_s, cascade_runs, single_runs, k) = (100usize, 0.5, 20u64, 20u64, 5usize);
    let exp = {
        let e = experiment(125.0, 90.0, 20.0, 0, 0.5, 1e-3)?;
        CaptureExperiment {
            placement: Placement::Uniform {
                n,
                shape: RegionShape::new(1e-6, 300e-6)?,
            },
            sample_every_s: stage_s,
            ..e
        }
    };
    let t_star = 5.5; // thesis: optimal cascade at 90 % after ~5.5 s (section 6.4.5)
    let stages = (t_star / stage_s).round() as usize;
    let cascade = |mode, seed, runs, stages| -> Result<Vec<Vec<(f64, f64)>>> {
        run_ensemble(runs, None, |r| {
            run_cascade(&exp, mode, stages, stage_s, seed, r, &mut NoHooks)
        })
    };
    let at = |curves: &[Vec<(f64, f64)>], t: f64| -> Vec<f64> {
        curves.iter().map(|c| cascade_at(c, t)).collect()
    };
    let opt = cascade(CascadeMode::Optimal, seed, cascade_runs, stages)?;
    let rnd = cascade(CascadeMode::Random, seed, cascade_runs, stages)?;
    // Independent single-stage runs (seed + 1) for the stage capture probability.
    let opt1 = at(
        &cascade(CascadeMode::Optimal, seed + 1, single_runs, 1)?,
        stage_s,
    );
    let rnd1 = at(
        &cascade(CascadeMode::Random, seed + 1, single_runs, 1)?,
        stage_s,
    );

    let mut got = BTreeMap::new();
    // Finding: optimal > random at t_star, Welch's t on per-run fractions.
    let (mo, vo, no) = mean_var_of_mean(&at(&opt, t_star));
    let (mr, vr, nr) = mean_var_of_mean(&at(&rnd, t_star));
    let t = (mo - mr) / (vo + vr).sqrt();
    let dof = welch_dof(&[(vo, no), (vr, nr)]);
    let p_finding = 1.0 - StudentsT::new(0.0, 1.0, dof).expect("dof > 0").cdf(t);
    got.insert("p_one_sided_optimal_over_random_at_5.5s", p_finding);
    got.insert("captured_optimal_at_5.5s", mo);
    got.insert("captured_random_at_5.5s", mr);
    let tk = k as f64 * stage_s;
    let kf = k as f64;
    // Closed form, optimal: particles independent, binomial variances.
    let (n_c, n_1) = (
        (cascade_runs as usize * n) as f64,
        (single_runs as usize * n) as f64,
    );
    let fo = at(&opt, tk).iter().sum::<f64>() / cascade_runs as f64;
    let po = opt1.iter().sum::<f64>() / single_runs as f64;
    let pred_o = 1.0 - (1.0 - po).powi(k as i32);
    let slope_o = kf * (1.0 - po).powi(k as i32 - 1);
    let var_o = fo * (1.0 - fo) / n_c + slope_o * slope_o * po * (1.0 - po) / n_1;
    got.insert(
        "z_optimal_cascade_vs_1-(1-p)^k_at_k=5",
        (fo - pred_o) / var_o.sqrt(),
    );
    // Closed form, random: per-run variances (the orientation is shared within a run).
    let (fr, vfr, nfr) = mean_var_of_mean(&at(&rnd, tk));
    let (pr, vpr, npr) = mean_var_of_mean(&rnd1);
    let pred_r = 1.0 - (1.0 - pr).powi(k as i32);
    let slope_r = kf * (1.0 - pr).powi(k as i32 - 1);
    let t_r = (fr - pred_r) / (vfr + slope_r * slope_r * vpr).sqrt();
    let dof_r = welch_dof(&[(vfr, nfr), (slope_r * slope_r * vpr, npr)]);
    let p_r = 2.0
        * (1.0
            - StudentsT::new(0.0, 1.0, dof_r)
                .expect("dof > 0")
                .cdf(t_r.abs()));
    got.insert("p_two_sided_random_cascade_vs_1-(1-p)^k_at_k=5", p_r);
    got.insert("stage_capture_optimal", po);
    got.insert("stage_capture_random", pr);
    band_rows(ctx, &got)
}
