//! Case 715: gravity packing of monodisperse spheres under the contact law of Zhou et al.
//! (2002) against the bands of the literature: frictionless deposition near random close
//! packing, frictional deposition between the close and loose random packing porosities of
//! seed 002 (36 % and 44 %), and porosity rising with the friction coefficient (Spearman).

use super::deposition_figures::{spearman, spearman_critical_5_percent};
use crate::dem::{settle, Stop};
use crate::scene::dem::{build, parse_scene, summarize};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};

/// The bed of case 715: `n` spheres d = 400 um, 2500 kg/m^3, dispersed at 75 % porosity in a
/// periodic box of side `side_m`, settling under gravity with the Zhou law (E = 1e7 Pa,
/// nu = 0.3, c_n = c_t = 0.3) and Coulomb coefficient `mu`; default stop rule.
fn gravity_scene(n: usize, side_m: f64, mu: f64, seed: u64) -> String {
    format!(
        "kind = \"dem\"\ntitle = \"gravity packing mu = {mu}\"\nseed = {seed}\n\
         [particles]\nn = {n}\ndensity_kg_m3 = 2500.0\nsize = \"mono\"\ndiameter_m = 4e-4\n\
         [box]\nlx_m = {side_m}\nly_m = {side_m}\nporosity = 0.75\n\
         [contact]\nmodel = \"zhou2002\"\nyoung_pa = 1e7\npoisson = 0.3\nc_n = 0.3\nfriction = {mu}\n\
         [drivers]\ngravity_m_s2 = 9.81\n[run]\nmax_time_s = 1.5\ncheck_every_s = 0.01\n"
    )
}

register!("715" => case_715);
/// Case 715. expected.csv rows `mu,seeds,lower,upper,source`: one gravity bed per (mu, seed),
/// seeds 1..=seeds (a bed not settled at the 1.5 s limit is marked `*` in the row's label);
/// row: the mean bulk porosity (the region 2 <d> above the floor to 2 <d>
/// below the bed top) in [lower, upper]. Last row: Spearman's rank correlation of the mean
/// porosity with mu at least the one-sided 5 % critical value for the number of mu values
/// (band [c, 1 + c] since rho <= 1).
pub fn case_715(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let (n, side) = (500, 2.4e-3);
    let mut rows = Vec::new();
    let (mut mus, mut means) = (Vec::new(), Vec::new());
    for i in 0..t.len() {
        let mu = t.f64(i, "mu")?;
        let seeds = t.f64(i, "seeds")? as u64;
        let (lo, hi) = (t.f64(i, "lower")?, t.f64(i, "upper")?);
        let mut eps = Vec::new();
        for seed in 1..=seeds {
            let origin = format!("case 715 mu={mu} seed={seed}");
            let scene = parse_scene(&gravity_scene(n, side, mu, seed), &origin)?;
            let mut dem = build(&scene)?;
            let clock = std::time::Instant::now();
            let stop = settle(&mut dem, &scene.rule)?;
            let secs = clock.elapsed().as_secs_f64();
            let s = summarize(&scene, &dem, stop.reason(&scene.rule), secs);
            let e = s.porosity_bulk.ok_or_else(|| {
                Error::Validation(format!("{origin}: bed too thin for a bulk region"))
            })?;
            // a bed still moving at the time limit is measured where it stands, and marked
            let mark = if stop == Stop::AtRest { "" } else { "*" };
            eps.push((e, mark));
        }
        let mean = eps.iter().map(|e| e.0).sum::<f64>() / eps.len() as f64;
        let listing: Vec<String> = eps.iter().map(|(e, m)| format!("{e:.4}{m}")).collect();
        rows.push(Row::new(
            format!(
                "mu={mu}: mean bulk porosity in [{lo}, {hi}] (seeds: {})",
                listing.join(" ")
            ),
            mean,
            0.5 * (lo + hi),
            0.5 * (hi - lo),
        ));
        mus.push(mu);
        means.push(mean);
    }
    let rho = spearman(&mus, &means);
    let c = spearman_critical_5_percent(mus.len())?;
    rows.push(Row::new(
        "Spearman rank correlation of bulk porosity with mu",
        rho,
        c + 0.5,
        0.5,
    ));
    Ok(rows)
}
