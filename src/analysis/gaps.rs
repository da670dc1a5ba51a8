//! Pair gaps: the smallest surface gap of every pair within reach, over all periodic images,
//! by a cell search or by brute force, and the deepest overlap.

use super::cells::PeriodicCells;
use super::{rod_parameters, Configuration};
use crate::contact::{closest_points_segments, contact_perturbed, Pose};
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;
use rayon::prelude::*;

/// Rotation (rad) of the retried contact query of [`pair_gaps`] when the solver does not
/// converge (`crate::contact::contact_perturbed`): changes a gap by at most 1e-6 x the
/// bounding radius.
pub const PERTURB_ANGLE: f64 = 1e-6;

/// A pair (i < j) and its smallest surface gap over all periodic images (< 0: overlap).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairGap {
    pub i: usize,
    pub j: usize,
    pub gap: f64,
}

/// All pairs whose gap (minimum over the 27 periodic images) is below `max_gap`.
/// Spheres and spherocylinders: closest points of the axis segments (Vega & Lago); pairs with
/// an ellipsoid or superquadric: the contact module's certified solver, retried from a pose
/// rotated by [`PERTURB_ANGLE`] when it does not converge (a query that still fails is an
/// error naming the pair; see also the solver-free
/// [`sampled_overlap`](super::sampled_overlap)). Errors if the box is not longer than the
/// largest particle (twice its bounding radius), where images of one particle would touch
/// themselves.
///
/// In a periodic box at least three pair reaches wide the candidate pairs come from a cell
/// binning of the analysis module's own (`cells.rs`; cells of edge >= the largest reach: only
/// the 27 cells around a particle can hold a partner, and only one image of it can be within
/// reach), which makes the search O(N): the brute force over all N^2/2 pairs took 4 s of a
/// 75 s run of 10000 spheres. The result is the same list, gap for gap, as
/// [`pair_gaps_brute_force`] (tested), which the walls and small boxes use.
pub fn pair_gaps(c: &Configuration, max_gap: f64) -> Result<Vec<PairGap>> {
    let geometry = PairGeometry::of(c, max_gap)?;
    let reach = geometry.reach();
    let periodic = c.wall_diameter.is_none() && c.wedge.is_none();
    let cells = if periodic {
        PeriodicCells::new(c, reach)
    } else {
        None
    };
    let Some(cells) = cells else {
        return pair_gaps_brute_force(c, max_gap);
    };
    let bl = c.box_length;
    // Rows i in parallel (rayon), concatenated in order: the result does not depend on the
    // thread count.
    let rows: Vec<Result<Vec<PairGap>>> = (0..c.n())
        .into_par_iter()
        .map(|i| {
            let partners = cells.partners_above(c, i);
            let mut row = Vec::new();
            for j in partners {
                // The nearest image, written as the brute force writes every image
                // (x_j + shift) - x_i, so the gap is bitwise the same.
                let raw = c.positions[j] - c.positions[i];
                let s = raw.map(|t| {
                    if t > 0.5 * bl {
                        -1.0
                    } else if t < -0.5 * bl {
                        1.0
                    } else {
                        0.0
                    }
                });
                let d = c.positions[j] + s * bl - c.positions[i];
                if let Some(gap) = geometry.gap(c, i, j, &d)? {
                    if gap < max_gap {
                        row.push(PairGap { i, j, gap });
                    }
                }
            }
            Ok(row)
        })
        .collect();
    concatenate(rows)
}

/// What the gap of a pair at separation d needs: bounding radii, unit axes.
struct PairGeometry {
    bounds: Vec<f64>,
    axes: Vec<Vector3<f64>>,
    max_gap: f64,
}

impl PairGeometry {
    /// Checks the configuration and that the box is longer than the largest particle.
    fn of(c: &Configuration, max_gap: f64) -> Result<PairGeometry> {
        c.check()?;
        let bounds: Vec<f64> = c
            .shapes
            .iter()
            .map(crate::shape::bounding_radius_of)
            .collect::<Result<_>>()?;
        let largest = 2.0 * bounds.iter().cloned().fold(0.0, f64::max);
        if c.box_length <= largest {
            return invalid(format!(
                "box_length = {}: must exceed the largest particle length {largest}",
                c.box_length
            ));
        }
        Ok(PairGeometry {
            bounds,
            axes: c.orientations.iter().map(|q| q * Vector3::z()).collect(),
            max_gap,
        })
    }

    /// The largest centre distance at which two particles can be within `max_gap` of
    /// contact: twice the largest bounding radius plus the gap.
    fn reach(&self) -> f64 {
        2.0 * self.bounds.iter().cloned().fold(0.0, f64::max) + self.max_gap.max(0.0)
    }

    /// Surface gap of particles i and j with j at separation `d` from i; None when the
    /// centres are too far apart for the gap to be below `max_gap`.
    fn gap(&self, c: &Configuration, i: usize, j: usize, d: &Vector3<f64>) -> Result<Option<f64>> {
        let (si, sj) = (c.shape(i), c.shape(j));
        let rods = rod_parameters(si).zip(rod_parameters(sj));
        let cut = match rods {
            Some(((ri, hi), (rj, hj))) => (hi + hj) + (ri + rj),
            None => self.bounds[c.species[i]] + self.bounds[c.species[j]],
        } + self.max_gap.max(0.0);
        if d.norm() >= cut {
            return Ok(None);
        }
        Ok(Some(match rods {
            Some(((ri, hi), (rj, hj))) if hi == 0.0 && hj == 0.0 => d.norm() - (ri + rj),
            Some(((ri, hi), (rj, hj))) => {
                let (ai, aj) = (self.axes[i], self.axes[j]);
                let (_, _, p, q) = closest_points_segments(
                    &(-hi * ai),
                    &(hi * ai),
                    &(d - hj * aj),
                    &(d + hj * aj),
                );
                (q - p).norm() - (ri + rj)
            }
            None => {
                let pa = Pose::new(Vector3::zeros(), c.orientations[i]);
                let pb = Pose::new(*d, c.orientations[j]);
                contact_perturbed(si, &pa, sj, &pb, PERTURB_ANGLE)
                    .map_err(|e| crate::Error::InvalidInput(format!("pair ({i}, {j}): {e}")))?
                    .gap
            }
        }))
    }
}

fn concatenate(rows: Vec<Result<Vec<PairGap>>>) -> Result<Vec<PairGap>> {
    let mut out = Vec::new();
    for r in rows {
        out.extend(r?);
    }
    Ok(out)
}

/// [`pair_gaps`] by brute force over every pair and every image (the independent overlap
/// check of the validation cases, through [`worst_gap`]).
pub fn pair_gaps_brute_force(c: &Configuration, max_gap: f64) -> Result<Vec<PairGap>> {
    let geometry = PairGeometry::of(c, max_gap)?;
    let n = c.n();
    let bl = c.box_length;
    // Images along the periodic directions only (z alone in the cylinder and the wedge).
    let lat = if c.wall_diameter.is_some() || c.wedge.is_some() {
        0
    } else {
        1
    };
    let rows: Vec<Result<Vec<PairGap>>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut row = Vec::new();
            for j in i + 1..n {
                let mut best = f64::INFINITY;
                for sx in -lat..=lat {
                    for sy in -lat..=lat {
                        for sz in -1..=1 {
                            let shift = Vector3::new(sx as f64, sy as f64, sz as f64) * bl;
                            let d = c.positions[j] + shift - c.positions[i];
                            if let Some(gap) = geometry.gap(c, i, j, &d)? {
                                best = best.min(gap);
                            }
                        }
                    }
                }
                if best < max_gap {
                    row.push(PairGap { i, j, gap: best });
                }
            }
            Ok(row)
        })
        .collect();
    concatenate(rows)
}

/// The deepest overlap found by the brute-force check: the most negative gap (or +inf when
/// no pair is within `max_gap` = 0 of contact), with the pair.
pub fn worst_gap(c: &Configuration) -> Result<Option<PairGap>> {
    let g = pair_gaps_brute_force(c, 0.0)?;
    Ok(g.into_iter()
        .min_by(|a, b| a.gap.partial_cmp(&b.gap).unwrap()))
}
