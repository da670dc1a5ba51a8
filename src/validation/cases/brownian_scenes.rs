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
use crate::brownian::experiment::{
    CaptureExperiment, CylinderSetup, MagnetizationLaw, Placement, Region, RegionShape, RunResult,
    TABLE_6_1,
};
use crate::brownian::{Hydrodynamics, LangevinMoment, NoiseMethod, Params, StepGuard};
use crate::consts::MU0;
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
        params: Params::new(298.0, 1e-3, dt_s)?,
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
    crate::brownian::experiment::run_ensemble(n, None, |r| exp.run(seed, r, &|_| {}))
}

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
