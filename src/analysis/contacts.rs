//! Contact numbers from the pair gaps: per particle, the mean at a cut-off with rattlers
//! removed, and the linear extrapolation to zero cut-off (thesis sec. 2.2.5).

use super::PairGap;
use crate::error::invalid;
use crate::Result;

/// Per-particle contact counts: pairs with gap < `delta` (overlaps included).
pub fn contact_counts(n: usize, gaps: &[PairGap], delta: f64) -> Vec<usize> {
    let mut z = vec![0usize; n];
    for g in gaps {
        if g.gap < delta {
            z[g.i] += 1;
            z[g.j] += 1;
        }
    }
    z
}

/// Mean contact number at gap cut-off `delta` (thesis sec. 2.2.5): 2 (number of pairs with
/// gap < delta) / N, optionally with rattlers removed: particles with fewer than
/// `min_contacts` contacts are removed repeatedly (their contacts no longer count for their
/// neighbours) until every remaining particle has at least `min_contacts`. Returns
/// (mean contacts of the remaining particles, number of rattlers).
pub fn mean_contacts(
    n: usize,
    gaps: &[PairGap],
    delta: f64,
    min_contacts: Option<usize>,
) -> (f64, usize) {
    let mut alive = vec![true; n];
    let contacts: Vec<&PairGap> = gaps.iter().filter(|g| g.gap < delta).collect();
    if let Some(m) = min_contacts {
        loop {
            let mut z = vec![0usize; n];
            for g in &contacts {
                if alive[g.i] && alive[g.j] {
                    z[g.i] += 1;
                    z[g.j] += 1;
                }
            }
            let mut changed = false;
            for i in 0..n {
                if alive[i] && z[i] < m {
                    alive[i] = false;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
    }
    let kept = alive.iter().filter(|a| **a).count();
    let pairs = contacts.iter().filter(|g| alive[g.i] && alive[g.j]).count();
    let mean = if kept == 0 {
        0.0
    } else {
        2.0 * pairs as f64 / kept as f64
    };
    (mean, n - kept)
}

/// The first of the cut-offs at which removing rattlers (fewer than `min_contacts` contacts,
/// repeatedly) leaves no particle, if any: there the rattler-free mean is undefined.
pub fn cutoff_where_all_rattle(
    n: usize,
    gaps: &[PairGap],
    deltas: &[f64],
    min_contacts: usize,
) -> Option<f64> {
    deltas
        .iter()
        .copied()
        .find(|&d| mean_contacts(n, gaps, d, Some(min_contacts)).1 == n)
}

/// Mean contact number extrapolated linearly to zero cut-off (thesis sec. 2.2.5): a
/// least-squares line through (delta_k, `<C>`(delta_k)) evaluated at delta = 0. Rattlers are
/// removed at each cut-off when `min_contacts` is given; if that removes every particle at
/// some cut-off the result is an error (there is no mean to extrapolate). Returns
/// (intercept, slope).
pub fn extrapolated_contacts(
    n: usize,
    gaps: &[PairGap],
    deltas: &[f64],
    min_contacts: Option<usize>,
) -> Result<(f64, f64)> {
    if deltas.len() < 2 {
        return invalid(format!(
            "{} cut-offs: need at least 2 for a linear extrapolation",
            deltas.len()
        ));
    }
    if let Some(d) = deltas.iter().find(|d| !(d.is_finite() && **d > 0.0)) {
        return invalid(format!("cut-off {d}: must be positive and finite"));
    }
    if let Some(m) = min_contacts {
        if let Some(d) = cutoff_where_all_rattle(n, gaps, deltas, m) {
            // The mean over no particles is undefined: refuse rather than report 0.
            return invalid(format!(
                "every one of the {n} particles is a rattler (fewer than {m} contacts after \
                 repeated removal) at cut-off {d}: the mean contact number without rattlers is \
                 undefined; lower the rattler threshold"
            ));
        }
    }
    let ys: Vec<f64> = deltas
        .iter()
        .map(|&d| mean_contacts(n, gaps, d, min_contacts).0)
        .collect();
    let m = deltas.len() as f64;
    let mx = deltas.iter().sum::<f64>() / m;
    let my = ys.iter().sum::<f64>() / m;
    let sxx: f64 = deltas.iter().map(|x| (x - mx).powi(2)).sum();
    if sxx == 0.0 {
        return invalid("cut-offs are all equal: need distinct values");
    }
    let sxy: f64 = deltas
        .iter()
        .zip(&ys)
        .map(|(x, y)| (x - mx) * (y - my))
        .sum();
    let slope = sxy / sxx;
    Ok((my - slope * mx, slope))
}
