//! Observables of particle configurations: packing fraction, contact numbers (raw, at a gap
//! cut-off, extrapolated to zero cut-off, with rattlers removed), nematic order S, and an
//! independent brute-force overlap check.
//!
//! The functions take plain data ([`Rods`]: monodisperse spherocylinders or spheres in a
//! periodic cubic box), so they depend on no engine. Pair gaps are computed over **all pairs
//! and all 27 periodic images** (no cell list, no minimum image), so they check an engine's
//! neighbour search rather than repeat it.

use crate::contact::closest_points_segments;
use crate::error::invalid;
use crate::Result;
use nalgebra::{Matrix3, SymmetricEigen, UnitQuaternion, Vector3};

/// Monodisperse spherocylinders (length 0: spheres) in the periodic box [0, L)^3.
#[derive(Debug, Clone, Copy)]
pub struct Rods<'a> {
    pub box_length: f64,
    pub radius: f64,
    /// Cylinder length between hemisphere centres (0 = spheres).
    pub length: f64,
    pub positions: &'a [Vector3<f64>],
    /// Body -> world; the particle axis is the body z axis.
    pub orientations: &'a [UnitQuaternion<f64>],
}

impl Rods<'_> {
    pub fn n(&self) -> usize {
        self.positions.len()
    }
    /// Particle volume pi R^2 (4R/3 + L) (thesis eq. 2.2).
    pub fn particle_volume(&self) -> f64 {
        std::f64::consts::PI * self.radius * self.radius * (4.0 / 3.0 * self.radius + self.length)
    }
    fn check(&self) -> Result<()> {
        if !(self.box_length.is_finite() && self.box_length > 0.0) {
            return invalid(format!(
                "box_length = {}: must be positive and finite",
                self.box_length
            ));
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return invalid(format!(
                "radius = {}: must be positive and finite",
                self.radius
            ));
        }
        if !(self.length.is_finite() && self.length >= 0.0) {
            return invalid(format!("length = {}: must be finite and >= 0", self.length));
        }
        if self.positions.len() != self.orientations.len() {
            return invalid(format!(
                "{} positions but {} orientations: must be equal",
                self.positions.len(),
                self.orientations.len()
            ));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|x| !(x.x.is_finite() && x.y.is_finite() && x.z.is_finite()))
        {
            return invalid(format!("position {i} is not finite"));
        }
        Ok(())
    }
}

/// Packing fraction: total particle volume over box volume (thesis eq. 3.1).
pub fn packing_fraction(c: &Rods) -> f64 {
    c.n() as f64 * c.particle_volume() / c.box_length.powi(3)
}

/// A pair (i < j) and its smallest surface gap over all periodic images (< 0: overlap).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairGap {
    pub i: usize,
    pub j: usize,
    pub gap: f64,
}

/// All pairs whose gap (minimum over the 27 periodic images) is below `max_gap`, by brute
/// force over every pair. Errors if the box is shorter than a particle (L + 2R), where images
/// of one particle would touch themselves.
pub fn pair_gaps(c: &Rods, max_gap: f64) -> Result<Vec<PairGap>> {
    c.check()?;
    let reach = c.length + 2.0 * c.radius;
    if c.box_length <= reach {
        return invalid(format!(
            "box_length = {}: must exceed the particle length L + 2R = {reach}",
            c.box_length
        ));
    }
    let n = c.n();
    let h = 0.5 * c.length;
    let axes: Vec<Vector3<f64>> = c.orientations.iter().map(|q| q * Vector3::z()).collect();
    let bl = c.box_length;
    let cut = reach + max_gap.max(0.0);
    let mut out = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let mut best = f64::INFINITY;
            for sx in -1..=1 {
                for sy in -1..=1 {
                    for sz in -1..=1 {
                        let shift = Vector3::new(sx as f64, sy as f64, sz as f64) * bl;
                        let d = c.positions[j] + shift - c.positions[i];
                        if d.norm() >= cut {
                            continue;
                        }
                        let dist = if c.length == 0.0 {
                            d.norm()
                        } else {
                            let (_, _, p, q) = closest_points_segments(
                                &(-h * axes[i]),
                                &(h * axes[i]),
                                &(d - h * axes[j]),
                                &(d + h * axes[j]),
                            );
                            (q - p).norm()
                        };
                        best = best.min(dist - 2.0 * c.radius);
                    }
                }
            }
            if best < max_gap {
                out.push(PairGap { i, j, gap: best });
            }
        }
    }
    Ok(out)
}

/// The deepest overlap found by the brute-force check: the most negative gap (or +inf when
/// no pair is within `max_gap` = 0 of contact), with the pair.
pub fn worst_gap(c: &Rods) -> Result<Option<PairGap>> {
    let g = pair_gaps(c, 0.0)?;
    Ok(g.into_iter()
        .min_by(|a, b| a.gap.partial_cmp(&b.gap).unwrap()))
}

/// Independent overlap check: Ok(()) when no pair has gap below -`tol`; otherwise an error
/// naming the worst pair and its gap.
pub fn check_no_overlap(c: &Rods, tol: f64) -> Result<()> {
    if !(tol.is_finite() && tol >= 0.0) {
        return invalid(format!("tol = {tol}: must be finite and >= 0"));
    }
    if let Some(w) = worst_gap(c)? {
        if w.gap < -tol {
            return invalid(format!(
                "particles {} and {} overlap by {:e}, deeper than the contact tolerance {tol:e}",
                w.i, w.j, -w.gap
            ));
        }
    }
    Ok(())
}

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

/// Mean contact number extrapolated linearly to zero cut-off (thesis sec. 2.2.5): a
/// least-squares line through (delta_k, <C>(delta_k)) evaluated at delta = 0. Rattlers are
/// removed at each cut-off when `min_contacts` is given. Returns (intercept, slope).
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

/// Nematic order parameter S (thesis eq. 2.11): the largest eigenvalue of
/// Q = (1/N) sum (3/2 u u^T - 1/2 I) over the unit axes u.
pub fn nematic_order(axes: &[Vector3<f64>]) -> Result<f64> {
    if axes.is_empty() {
        return invalid("no axes: nematic order needs at least one particle");
    }
    let mut q = Matrix3::zeros();
    for (i, u) in axes.iter().enumerate() {
        let nu = u.norm();
        if !(nu.is_finite() && nu > 0.0) {
            return invalid(format!(
                "axis {i} has norm {nu}: must be positive and finite"
            ));
        }
        let u = u / nu;
        q += 1.5 * u * u.transpose() - 0.5 * Matrix3::identity();
    }
    q /= axes.len() as f64;
    let e = SymmetricEigen::new(q).eigenvalues;
    Ok(e.max())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spheres(pos: &[Vector3<f64>]) -> (Vec<Vector3<f64>>, Vec<UnitQuaternion<f64>>) {
        (pos.to_vec(), vec![UnitQuaternion::identity(); pos.len()])
    }

    #[test]
    fn simple_cubic_lattice_has_six_contacts_and_pi_over_six() {
        // Unit spheres (diameter 1) on a simple cubic lattice of spacing 1: phi = pi/6, every
        // sphere touches 6 neighbours, some through the periodic boundary.
        let m = 4;
        let mut p = Vec::new();
        for a in 0..m {
            for b in 0..m {
                for c in 0..m {
                    p.push(Vector3::new(a as f64, b as f64, c as f64) + Vector3::repeat(0.5));
                }
            }
        }
        let (pos, ori) = spheres(&p);
        let r = Rods {
            box_length: m as f64,
            radius: 0.5,
            length: 0.0,
            positions: &pos,
            orientations: &ori,
        };
        assert!((packing_fraction(&r) - std::f64::consts::PI / 6.0).abs() < 1e-15);
        let g = pair_gaps(&r, 1e-3).unwrap();
        let (c, rattlers) = mean_contacts(r.n(), &g, 1e-6, Some(4));
        assert_eq!(c, 6.0);
        assert_eq!(rattlers, 0);
        check_no_overlap(&r, 1e-12).unwrap();
        let (c0, _) = extrapolated_contacts(r.n(), &g, &[1e-8, 1e-7, 1e-6], None).unwrap();
        assert!((c0 - 6.0).abs() < 1e-12);
    }

    #[test]
    fn overlap_through_the_boundary_is_found() {
        // Two spheres 0.9 apart across the periodic boundary (x = 0.2 and x = 9.3 in L = 10).
        let (pos, ori) = spheres(&[Vector3::new(0.2, 5.0, 5.0), Vector3::new(9.3, 5.0, 5.0)]);
        let r = Rods {
            box_length: 10.0,
            radius: 0.5,
            length: 0.0,
            positions: &pos,
            orientations: &ori,
        };
        let w = worst_gap(&r).unwrap().unwrap();
        assert!((w.gap + 0.1).abs() < 1e-12);
        assert!(check_no_overlap(&r, 1e-4).is_err());
    }

    #[test]
    fn crossed_rods_gap() {
        // Two rods L = 3, R = 0.5, axes x and y, centres 1.2 apart along z: gap 0.2.
        let pos = vec![Vector3::new(5.0, 5.0, 5.0), Vector3::new(5.0, 5.0, 6.2)];
        let ori = vec![
            UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::x()).unwrap(),
            UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::y()).unwrap(),
        ];
        let r = Rods {
            box_length: 10.0,
            radius: 0.5,
            length: 3.0,
            positions: &pos,
            orientations: &ori,
        };
        let g = pair_gaps(&r, 1.0).unwrap();
        assert_eq!(g.len(), 1);
        assert!((g[0].gap - 0.2).abs() < 1e-12);
    }

    #[test]
    fn rattlers_are_removed_repeatedly() {
        // A chain 0-1-2 plus a triangle 3-4-5: with min_contacts 2 the chain ends are
        // rattlers, after which 1 has no contact and goes too; the triangle remains with 2.
        let gp = |i, j| PairGap { i, j, gap: 0.0 };
        let g = vec![gp(0, 1), gp(1, 2), gp(3, 4), gp(4, 5), gp(3, 5)];
        let (c, rat) = mean_contacts(6, &g, 1e-9, Some(2));
        assert_eq!(rat, 3);
        assert_eq!(c, 2.0);
        let (c_all, rat0) = mean_contacts(6, &g, 1e-9, None);
        assert_eq!(rat0, 0);
        assert!((c_all - 10.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn nematic_order_limits() {
        let aligned = vec![Vector3::z(); 10];
        assert!((nematic_order(&aligned).unwrap() - 1.0).abs() < 1e-14);
        // Three orthogonal axes: Q = 0 exactly.
        let iso = vec![Vector3::x(), Vector3::y(), Vector3::z()];
        assert!(nematic_order(&iso).unwrap().abs() < 1e-14);
        assert!(nematic_order(&[]).is_err());
        assert!(nematic_order(&[Vector3::zeros()]).is_err());
    }

    #[test]
    fn bad_input_is_an_error() {
        let (pos, ori) = spheres(&[Vector3::zeros()]);
        let r = Rods {
            box_length: -1.0,
            radius: 0.5,
            length: 0.0,
            positions: &pos,
            orientations: &ori,
        };
        assert!(pair_gaps(&r, 0.0).is_err());
        assert!(extrapolated_contacts(1, &[], &[1e-6], None).is_err());
    }
}
