//! Independent overlap checks: particles against the container's walls and against each
//! other (exact pair gaps for rods, surface samples for ellipsoids and superquadrics).

use super::sampled::{self, sampled_overlap};
use super::{rod_parameters, worst_gap, Configuration};
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;

/// Surface samples per particle of the solver-free overlap check of [`check_no_overlap`]
/// for ellipsoids and superquadrics (measured spacing 0.023 D for superballs of half-width
/// 1/2 and exponent 3).
pub const OVERLAP_SAMPLES: usize = 20_000;

/// Deepest penetration (> 0) of any particle into the wall: over the end points p (centres
/// for spheres), the largest sqrt(p_x^2 + p_y^2) + R - R_cyl in the cylinder, or R minus the
/// distance to the nearest of the back, bottom and slope planes in the wedge; None in the
/// periodic box or when nothing penetrates.
///
/// Ellipsoids and superquadrics (no contact solver, no support function): the deepest of
/// [`OVERLAP_SAMPLES`] surface samples of the shape module ([`ConvexShape::surface_samples`]),
/// with R = 0 in the formulas above. A lower bound of the true penetration: for a sample
/// spacing h and principal curvatures at most kappa the deepest point is missed by at most
/// kappa h^2 / 2 (the body contains a ball of radius 1/kappa tangent at its deepest point,
/// Blaschke's rolling theorem; the wall's distance function is at least the tangent plane's).
///
/// [`ConvexShape::surface_samples`]: crate::shape::ConvexShape::surface_samples
pub fn wall_penetration(c: &Configuration) -> Result<Option<(usize, f64)>> {
    c.check()?;
    if c.wall_diameter.is_none() && c.wedge.is_none() {
        return Ok(None);
    }
    // Surface samples of the non-rod species (body frame), computed once per species.
    let samples: Vec<Option<Vec<Vector3<f64>>>> = c
        .shapes
        .iter()
        .map(|s| match sampled::superquadric_parameters(s) {
            Some((a, g)) if rod_parameters(s).is_none() => {
                use crate::shape::ConvexShape;
                Ok(Some(
                    crate::shape::Superquadric::new(a, g)?.surface_samples(OVERLAP_SAMPLES),
                ))
            }
            _ => Ok(None),
        })
        .collect::<Result<_>>()?;
    let depth = |e: &Vector3<f64>, r: f64| match (c.wall_diameter, c.wedge) {
        (Some(d), _) => e.x.hypot(e.y) + r - 0.5 * d,
        (None, Some((l, a))) => {
            let slope = (e.x * a.tan() - e.y) * a.cos();
            r - (l - e.x).min(e.y).min(slope)
        }
        (None, None) => f64::NEG_INFINITY,
    };
    let mut worst: Option<(usize, f64)> = None;
    for (i, (x, q)) in c.positions.iter().zip(c.orientations).enumerate() {
        if let Some(pts) = &samples[c.species[i]] {
            let rot = q.to_rotation_matrix();
            for y in pts {
                let pen = depth(&(x + rot * y), 0.0);
                if pen > 0.0 && worst.is_none_or(|w| pen > w.1) {
                    worst = Some((i, pen));
                }
            }
            continue;
        }
        let (r, h) = rod_parameters(c.shape(i)).expect("rods and sampled shapes only");
        let a = q * Vector3::z();
        for s in [-h, h] {
            let e = x + s * a;
            let pen = depth(&e, r);
            if pen > 0.0 && worst.is_none_or(|w| pen > w.1) {
                worst = Some((i, pen));
            }
        }
    }
    Ok(worst)
}

/// Independent overlap check: Ok(()) when no pair has gap below -`tol` and no particle
/// penetrates the cylinder wall (if any) deeper than `tol`; otherwise an error naming the
/// worst pair (or particle) and its overlap.
///
/// Configurations with ellipsoids or superquadrics are checked by [`sampled_overlap`]
/// (`OVERLAP_SAMPLES` surface points per particle; no contact solver): an error when some
/// sample provably lies deeper than `tol` inside another particle.
pub fn check_no_overlap(c: &Configuration, tol: f64) -> Result<()> {
    if !(tol.is_finite() && tol >= 0.0) {
        return invalid(format!("tol = {tol}: must be finite and >= 0"));
    }
    if c.shapes.iter().any(|s| rod_parameters(s).is_none()) {
        if let Some((i, pen)) = wall_penetration(c)? {
            if pen > tol {
                return invalid(format!(
                    "particle {i}: a surface sample lies {pen:e} beyond the wall, deeper than \
                     the contact tolerance {tol:e} (sampled check)"
                ));
            }
        }
        let s = sampled_overlap(c, OVERLAP_SAMPLES)?;
        if let Some((i, j, depth)) = s.worst.filter(|w| w.2 > tol) {
            return invalid(format!(
                "particles {i} and {j} overlap: a surface sample of one lies {depth:e} inside \
                 the other, deeper than the contact tolerance {tol:e} (sampled check, spacing \
                 {:.3e})",
                s.spacing
            ));
        }
        return Ok(());
    }
    if let Some((i, pen)) = wall_penetration(c)? {
        if pen > tol {
            return invalid(format!(
                "particle {i} penetrates the cylinder wall by {pen:e}, deeper than the contact \
                 tolerance {tol:e}"
            ));
        }
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
