//! Chain formation cases (thesis 003, section 6.4.6):
//!
//! * 420 the dipolar coupling constant Gamma (eq. 6.25) and the mean chain length of Andreu et
//!   al. (eq. 6.26) against mpmath evaluations of the formulas, and the cluster statistics
//!   (`chain_statistics`, union–find over bonds closer than 1.1 x 2R) on configurations built
//!   here whose answer is known by construction;
//! * 421 the thesis' own numbers: Gamma ~ 825 for its 125 nm particles and ~ 1 for 25 nm
//!   (section 6.4.6), and a head-to-tail dipole energy below kT at the 30 R cut-off (section 6.3).

use super::common::band_rows;
use crate::brownian::experiment::{
    chain_statistics, dipolar_coupling, mean_chain_length, ChainStats, TABLE_6_1,
};
use crate::consts::KB;
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// Particle radius of the constructed configurations (m); the answers do not depend on it.
const R: f64 = 75e-9;

/// A configuration named in case 420's table, built so that its clusters are known: bonds are
/// centre distances below 1.1 x 2R = 2.2 R.
fn configuration(name: &str) -> Option<Vec<Vector3<f64>>> {
    let along = |start: Vector3<f64>, n: usize, spacing: f64| -> Vec<Vector3<f64>> {
        (0..n)
            .map(|k| start + Vector3::x() * (k as f64 * spacing))
            .collect()
    };
    let lattice = |spacing: f64| -> Vec<Vector3<f64>> {
        (0..64)
            .map(|k| Vector3::new((k % 4) as f64, ((k / 4) % 4) as f64, (k / 16) as f64) * spacing)
            .collect()
    };
    Some(match name {
        // A touching line of 10 (spacing 2R) and 5 loners 100 R apart.
        "line10+5loners" => {
            let mut p = along(Vector3::zeros(), 10, 2.0 * R);
            p.extend((0..5).map(|k| Vector3::new(0.0, 100.0 * R * (k + 1) as f64, 0.0)));
            p
        }
        // Chains of 2, 3, 4 and 5 (spacing 2.1 R), 20 R apart side by side, listed interleaved
        // so that the union–find sees bonds out of order.
        "chains2345" => {
            let mut p: Vec<Vector3<f64>> = [2usize, 3, 4, 5]
                .iter()
                .enumerate()
                .flat_map(|(c, &n)| along(Vector3::new(0.0, 20.0 * R * c as f64, 0.0), n, 2.1 * R))
                .collect();
            let n = p.len();
            for i in 0..n / 2 {
                p.swap(i, n - 1 - i);
            }
            p.swap(1, 7);
            p
        }
        // Simple cubic 4 x 4 x 4: nearest neighbours bonded (2.1 R) or not (2.3 R).
        "lattice4x4x4_2.1R" => lattice(2.1 * R),
        "lattice4x4x4_2.3R" => lattice(2.3 * R),
        // A 3-D cross (centre and six touching neighbours, a branched cluster of 7), a pair at
        // 2.19 R (bonded) and a pair at 2.21 R (not bonded), all far apart.
        "cross7+pair2.19R+pair2.21R" => {
            let c = Vector3::new(0.0, 0.0, 0.0);
            let mut p = vec![c];
            for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
                p.push(c + axis * (2.0 * R));
                p.push(c - axis * (2.0 * R));
            }
            p.extend(along(Vector3::new(100.0 * R, 0.0, 0.0), 2, 2.19 * R));
            p.extend(along(Vector3::new(0.0, 100.0 * R, 0.0), 2, 2.21 * R));
            p
        }
        _ => return None,
    })
}

fn stat(s: &ChainStats, kind: &str) -> Option<f64> {
    Some(match kind {
        "chains" => s.chains as f64,
        "mean_length" => s.mean_length,
        "fraction_in_chains" => s.fraction_in_chains,
        "longest" => s.longest as f64,
        _ => return None,
    })
}

register!("420" => case_420);
/// Case 420: eq. 6.25–6.26 against mpmath, chain statistics against constructions.
pub fn case_420(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::with_capacity(t.len());
    for i in 0..t.len() {
        let (kind, name) = (t.str(i, "kind")?, t.str(i, "name")?);
        let expected = t.f64(i, "expected")?;
        let got = match kind {
            // Eq. 6.25.
            "gamma" => dipolar_coupling(
                t.f64(i, "moment_A_m2")?,
                t.f64(i, "diameter_m")?,
                KB * t.f64(i, "temperature_K")?,
            ),
            // Eq. 6.26.
            "mean_chain_length" => mean_chain_length(t.f64(i, "phi0")?, t.f64(i, "gamma")?),
            _ => {
                let pos = configuration(name).ok_or_else(|| {
                    Error::Validation(format!(
                        "{} line {}: unknown configuration `{name}`",
                        t.path().display(),
                        t.line(i)
                    ))
                })?;
                stat(&chain_statistics(&pos, R, 1.1), kind).ok_or_else(|| {
                    Error::Validation(format!(
                        "{} line {}: unknown kind `{kind}`",
                        t.path().display(),
                        t.line(i)
                    ))
                })?
            }
        };
        rows.push(Row::new(
            format!("{kind} {name}"),
            got,
            expected,
            expected.abs().max(1.0),
        ));
    }
    Ok(rows)
}

register!("421" => case_421);
/// Case 421: the thesis' numbers for Gamma (section 6.4.6) and the cut-off (section 6.3).
pub fn case_421(ctx: &CaseContext) -> Result<Vec<Row>> {
    let kt = KB * 298.0; // section 6.3: T = 298 K
    let moment = |r_nm: f64| -> Result<f64> {
        TABLE_6_1
            .iter()
            .find(|(r, _)| *r == r_nm)
            .map(|(_, m)| m * 1e-16)
            .ok_or_else(|| Error::Validation(format!("{r_nm} nm not in Table 6.1")))
    };
    let mut got = BTreeMap::new();
    got.insert("gamma_125nm", dipolar_coupling(moment(125.0)?, 250e-9, kt));
    got.insert("gamma_25nm", dipolar_coupling(moment(25.0)?, 50e-9, kt));
    // Head-to-tail energy of two dipoles at distance r, over kT: mu0 mu^2 / (2 pi r^3 kT), i.e.
    // Gamma of eq. 6.25 with d replaced by r; section 6.3: R = 250 nm, mu = 2.2e-3 A um^2.
    let (r, mu) = (250e-9, 2.2e-3 * 1e-12);
    got.insert(
        "head_to_tail_energy_over_kT_at_30R",
        dipolar_coupling(mu, 30.0 * r, kt),
    );
    band_rows(ctx, &got)
}
