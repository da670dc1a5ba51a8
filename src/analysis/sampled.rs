//! Solver-free overlap check for ellipsoids and superquadrics: dense surface samples of each
//! particle tested against the inside function of every neighbour, so a packing made with the
//! contact module's Newton-Raphson is checked by code that shares nothing with it.
//!
//! For a superquadric with semi-axes a_k and exponents g_k >= 2 (thesis eq. 4.3) the inside
//! function F(y) = sum_k |y_k / a_k|^g_k has, everywhere in the body (u_k = |y_k / a_k| <= 1,
//! sum u_k^g_k <= 1), |dF/dy_k| = g_k u_k^(g_k - 1) / a_k and so
//! |grad F|^2 <= (max_k g_k / a_k)^2 sum_k u_k^(2 g_k - 2) <= (max_k g_k / a_k)^2 = L^2
//! (2 g - 2 >= g). Along the segment from an inside point y to its nearest surface point q
//! (inside the convex body) F changes by 1 - F(y) <= L |q - y|: the distance from y to the
//! surface is at least (1 - F(y)) / L. A sample of particle i with that bound above `tol`
//! proves that i reaches deeper than `tol` into j, hence that no translation shorter than
//! `tol` separates them: a rigorous overlap verdict (tight at face centres, where
//! |grad F| = L).
//!
//! **Resolution.** Overlaps whose region on both surfaces contains no sample are missed. The
//! samples (area-weighted Fibonacci lattice of the shape module) are characterised by their
//! spacing h = the largest nearest-neighbour distance between samples of one particle; a lens
//! of depth delta between surfaces of curvature radius rho has a cap of radius about
//! sqrt(rho delta), so overlaps deeper than about h^2 / rho are seen. h is reported with the
//! verdict and is the tolerance of the check.

use super::Configuration;
use crate::contact::ContactShape;
use crate::error::invalid;
use crate::shape::ConvexShape;
use crate::Result;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::collections::HashMap;

/// The outcome of [`sampled_overlap`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledOverlap {
    /// The pair (i, j) with the deepest proven penetration and that depth ((1 - F) / L, a
    /// lower bound on the distance the deepest sample lies inside the other particle); None if
    /// no sample lies inside another particle.
    pub worst: Option<(usize, usize, f64)>,
    /// Largest nearest-neighbour distance between samples of one particle, over the species:
    /// the resolution of the check (module docs).
    pub spacing: f64,
}

/// Inside function F (thesis eq. 4.3) of a superquadric in its body frame.
fn inside(a: &[f64; 3], g: &[f64; 3], y: &Vector3<f64>) -> f64 {
    (0..3).map(|k| (y[k] / a[k]).abs().powf(g[k])).sum()
}

/// Semi-axes and exponents of an ellipsoid or superquadric (spheres: exponents 2).
pub(super) fn superquadric_parameters(s: &ContactShape) -> Option<([f64; 3], [f64; 3])> {
    match *s {
        ContactShape::Sphere { radius } => Some(([radius; 3], [2.0; 3])),
        ContactShape::Ellipsoid { semi_axes } => Some((semi_axes, [2.0; 3])),
        ContactShape::Superquadric {
            semi_axes,
            exponents,
        } => Some((semi_axes, exponents)),
        ContactShape::Spherocylinder { .. } => None,
    }
}

/// Largest nearest-neighbour distance in a point set (grid hash with cells of size `cell`;
/// a point whose neighbourhood of 27 cells is empty widens the search).
fn max_nearest_distance(pts: &[Vector3<f64>], cell: f64) -> f64 {
    let key = |p: &Vector3<f64>| {
        (
            (p.x / cell).floor() as i64,
            (p.y / cell).floor() as i64,
            (p.z / cell).floor() as i64,
        )
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, p) in pts.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    let mut worst: f64 = 0.0;
    for (i, p) in pts.iter().enumerate() {
        let (cx, cy, cz) = key(p);
        let mut best = f64::INFINITY;
        let mut reach = 1i64;
        // Widen until a neighbour is found within the searched cube (its inscribed radius).
        while best > (reach as f64) * cell {
            best = f64::INFINITY;
            for dx in -reach..=reach {
                for dy in -reach..=reach {
                    for dz in -reach..=reach {
                        if let Some(v) = grid.get(&(cx + dx, cy + dy, cz + dz)) {
                            for &j in v {
                                if j != i {
                                    best = best.min((pts[j] - p).norm());
                                }
                            }
                        }
                    }
                }
            }
            reach += 1;
        }
        worst = worst.max(best);
    }
    worst
}

/// Solver-free overlap check of a configuration of ellipsoids / superquadrics (spheres among
/// them allowed) over all pairs and all periodic images (27 in the periodic box, the 3 along
/// z in a cylinder or wedge), with `samples` surface points per particle (module docs). Pairs
/// only: the walls are checked by [`super::wall_penetration`].
pub fn sampled_overlap(c: &Configuration, samples: usize) -> Result<SampledOverlap> {
    c.check()?;
    // Images along the periodic directions only (z alone behind walls).
    let lat = if c.wall_diameter.is_some() || c.wedge.is_some() {
        0
    } else {
        1
    };
    if samples < 100 {
        return invalid(format!("samples = {samples}: need at least 100"));
    }
    let mut params = Vec::new();
    let mut body_samples = Vec::new();
    let mut bounds = Vec::new();
    let mut spacing: f64 = 0.0;
    for s in c.shapes {
        let Some((a, g)) = superquadric_parameters(s) else {
            return invalid(format!(
                "sampled overlap check: {} is not an ellipsoid or superquadric",
                s.name()
            ));
        };
        let q = crate::shape::Superquadric::new(a, g)?;
        let pts = q.surface_samples(samples);
        let area_cell = 2.0
            * (4.0 * std::f64::consts::PI * q.bounding_radius().powi(2) / samples as f64).sqrt();
        spacing = spacing.max(max_nearest_distance(&pts, area_cell));
        bounds.push(q.bounding_radius());
        params.push((a, g));
        body_samples.push(pts);
    }
    let n = c.n();
    let bl = c.box_length;
    let rot: Vec<_> = c
        .orientations
        .iter()
        .map(|q| *q.to_rotation_matrix().matrix())
        .collect();
    // Deepest proven penetration of a sample of `from` (world offset d_from) into `into`.
    let probe = |from: usize, into: usize, d: &Vector3<f64>| -> f64 {
        let (si, sj) = (c.species[from], c.species[into]);
        let (a, g) = &params[sj];
        let rj = bounds[sj];
        // Bound of |grad F| inside the body (module docs).
        let lip = (0..3).map(|k| g[k] / a[k]).fold(0.0, f64::max);
        let mut deepest: f64 = 0.0;
        for s in &body_samples[si] {
            // Sample of `from` relative to the centre of `into`.
            let w = rot[from] * s - d;
            if w.norm_squared() >= rj * rj {
                continue;
            }
            let y = rot[into].transpose() * w;
            let f = inside(a, g, &y);
            if f < 1.0 {
                deepest = deepest.max((1.0 - f) / lip);
            }
        }
        deepest
    };
    let rows: Vec<Option<(usize, usize, f64)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut worst: Option<(usize, usize, f64)> = None;
            for j in i + 1..n {
                let reach = bounds[c.species[i]] + bounds[c.species[j]];
                for sx in -lat..=lat {
                    for sy in -lat..=lat {
                        for sz in -1..=1 {
                            let shift = Vector3::new(sx as f64, sy as f64, sz as f64) * bl;
                            let d = c.positions[j] + shift - c.positions[i];
                            if d.norm() >= reach {
                                continue;
                            }
                            let depth = probe(i, j, &d).max(probe(j, i, &-d));
                            if depth > 0.0 && worst.is_none_or(|w| depth > w.2) {
                                worst = Some((i, j, depth));
                            }
                        }
                    }
                }
            }
            worst
        })
        .collect();
    let worst = rows
        .into_iter()
        .flatten()
        .max_by(|a, b| a.2.total_cmp(&b.2));
    Ok(SampledOverlap { worst, spacing })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn pair(
        gap: f64,
        g: f64,
    ) -> (
        Vec<Vector3<f64>>,
        Vec<UnitQuaternion<f64>>,
        Vec<ContactShape>,
    ) {
        // Two aligned superballs of half-width 1/2 facing along x: the faces are parallel at
        // distance `gap` (negative: overlap of depth -gap along x, the common normal by
        // symmetry).
        (
            vec![
                Vector3::new(3.0, 3.0, 3.0),
                Vector3::new(4.0 + gap, 3.0, 3.0),
            ],
            vec![UnitQuaternion::identity(); 2],
            vec![ContactShape::Superquadric {
                semi_axes: [0.5; 3],
                exponents: [g; 3],
            }],
        )
    }

    /// Closed-form configurations: aligned superballs apart by 1e-3 show no sample inside the
    /// other; pushed together by delta = 2e-3 the check proves a penetration of at most delta
    /// and at least a fair part of it (the face centre is the deepest point, depth delta).
    #[test]
    fn aligned_superballs_apart_and_overlapping() {
        for g in [2.0, 3.0, 5.0] {
            let (pos, ori, shapes) = pair(1e-3, g);
            let species = [0, 0];
            let r = Configuration::periodic(8.0, &shapes, &species, &pos, &ori);
            let s = sampled_overlap(&r, 20_000).unwrap();
            assert!(s.worst.is_none(), "g = {g}: {:?}", s.worst);
            assert!(
                s.spacing > 0.0 && s.spacing < 0.03,
                "g = {g}: {}",
                s.spacing
            );
            let (pos, ..) = pair(-2e-3, g);
            let r = Configuration {
                positions: &pos,
                ..r
            };
            let (i, j, depth) = sampled_overlap(&r, 20_000).unwrap().worst.unwrap();
            assert_eq!((i, j), (0, 1));
            assert!(
                depth <= 2e-3 * (1.0 + 1e-9) && depth > 0.5e-3,
                "g = {g}: {depth}"
            );
        }
    }
}
