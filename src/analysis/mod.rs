//! Observables of particle configurations: packing fraction, contact numbers (raw, at a gap
//! cut-off, extrapolated to zero cut-off, with rattlers removed), nematic order S, and an
//! independent brute-force overlap check.
//!
//! The functions take plain data ([`Rods`]: monodisperse spherocylinders or spheres in a
//! periodic cubic box), so they depend on no engine. Pair gaps are computed over **all pairs
//! and all 27 periodic images** (no cell list, no minimum image), so they check an engine's
//! neighbour search rather than repeat it.

use crate::contact::{closest_points_segments, contact_perturbed, ContactShape, Pose};
use crate::error::invalid;
use crate::Result;
use nalgebra::{Matrix3, SymmetricEigen, UnitQuaternion, Vector3};
use rayon::prelude::*;
pub use sampled::{sampled_overlap, SampledOverlap};

pub mod height_map;
pub mod pore_size;
pub mod rdf;
mod sampled;
pub mod slab;

/// Rotation (rad) of the retried contact query of [`pair_gaps`] when the solver does not
/// converge (`crate::contact::contact_perturbed`): changes a gap by at most 1e-6 x the
/// bounding radius.
pub const PERTURB_ANGLE: f64 = 1e-6;

/// Surface samples per particle of the solver-free overlap check of [`check_no_overlap`]
/// for ellipsoids and superquadrics (measured spacing 0.023 D for superballs of half-width
/// 1/2 and exponent 3).
pub const OVERLAP_SAMPLES: usize = 20_000;

/// Particles of per-particle shape (a species table of contact-module shapes: spheres,
/// spherocylinders, ellipsoids, superquadrics, and each particle's species) in the periodic
/// box [0, L)^3, or, with `wall_diameter`, inside a hard cylinder of that diameter about the z
/// axis (x = y = 0), periodic along z over [0, L), or, with `wedge` = (l_w, alpha in radians), inside the hard
/// wedge 0 <= y <= x tan(alpha), x <= l_w, periodic along z over [0, L) (thesis sec. 2.2.4).
#[derive(Debug, Clone, Copy)]
pub struct Rods<'a> {
    pub box_length: f64,
    /// Diameter of the confining cylinder (None: periodic cubic box).
    pub wall_diameter: Option<f64>,
    /// Hard wedge (length l_w, angle alpha in radians); excludes `wall_diameter`.
    pub wedge: Option<(f64, f64)>,
    /// Species table (body frame; a spherocylinder's axis is the body z axis).
    pub shapes: &'a [ContactShape],
    /// Species of each particle (index into `shapes`).
    pub species: &'a [usize],
    pub positions: &'a [Vector3<f64>],
    /// Body -> world.
    pub orientations: &'a [UnitQuaternion<f64>],
}

/// Radius and half cylinder length of a sphere (0) or spherocylinder; None for other shapes.
pub fn rod_parameters(s: &ContactShape) -> Option<(f64, f64)> {
    match *s {
        ContactShape::Sphere { radius } => Some((radius, 0.0)),
        ContactShape::Spherocylinder { radius, length } => Some((radius, 0.5 * length)),
        _ => None,
    }
}

/// Total volume of particles with the given species: sum over species of count x volume
/// (exactly N V_p for one species).
pub fn total_volume(shapes: &[ContactShape], species: &[usize]) -> Result<f64> {
    let mut counts = vec![0usize; shapes.len()];
    for &s in species {
        if s >= shapes.len() {
            return invalid(format!(
                "species {s}: not in the table of {} shapes",
                shapes.len()
            ));
        }
        counts[s] += 1;
    }
    let mut v = 0.0;
    for (s, c) in shapes.iter().zip(counts) {
        v += c as f64 * crate::shape::volume_of(s)?;
    }
    Ok(v)
}

impl<'a> Rods<'a> {
    /// Particles in a periodic cubic box of side `box_length` (no walls).
    pub fn periodic(
        box_length: f64,
        shapes: &'a [ContactShape],
        species: &'a [usize],
        positions: &'a [Vector3<f64>],
        orientations: &'a [UnitQuaternion<f64>],
    ) -> Rods<'a> {
        Rods {
            box_length,
            wall_diameter: None,
            wedge: None,
            shapes,
            species,
            positions,
            orientations,
        }
    }
    pub fn n(&self) -> usize {
        self.positions.len()
    }
    pub fn shape(&self, i: usize) -> &ContactShape {
        &self.shapes[self.species[i]]
    }
    /// Total particle volume (thesis eq. 2.2 for rods, eq. 4.26-4.28 for superquadrics).
    pub fn total_volume(&self) -> Result<f64> {
        total_volume(self.shapes, self.species)
    }
    fn check(&self) -> Result<()> {
        if !(self.box_length.is_finite() && self.box_length > 0.0) {
            return invalid(format!(
                "box_length = {}: must be positive and finite",
                self.box_length
            ));
        }
        for (k, s) in self.shapes.iter().enumerate() {
            s.validate()
                .map_err(|e| crate::Error::InvalidInput(format!("species {k}: {e}")))?;
        }
        if self.positions.len() != self.orientations.len()
            || self.positions.len() != self.species.len()
        {
            return invalid(format!(
                "{} positions, {} orientations and {} species: must be equal",
                self.positions.len(),
                self.orientations.len(),
                self.species.len()
            ));
        }
        if let Some(i) = self.species.iter().position(|&s| s >= self.shapes.len()) {
            return invalid(format!(
                "particle {i}: species {} not in the table of {} shapes",
                self.species[i],
                self.shapes.len()
            ));
        }
        let mut dmax: f64 = 0.0;
        if self.wall_diameter.is_some() || self.wedge.is_some() {
            for s in self.shapes {
                // Rods: their diameter; ellipsoids and superquadrics: their bounding sphere.
                let d = match rod_parameters(s) {
                    Some((r, _)) => 2.0 * r,
                    None => 2.0 * crate::shape::bounding_radius_of(s)?,
                };
                dmax = dmax.max(d);
            }
        }
        if let Some(d) = self.wall_diameter {
            if !(d.is_finite() && d > dmax) {
                return invalid(format!(
                    "wall_diameter = {d}: must be finite and larger than the particle diameter"
                ));
            }
        }
        if let Some((l, a)) = self.wedge {
            if self.wall_diameter.is_some() {
                return invalid("wedge and wall_diameter: a container has one wall type");
            }
            if !(l.is_finite() && l > 0.0 && a > 0.0 && a < 0.5 * std::f64::consts::PI) {
                return invalid(format!(
                    "wedge = ({l}, {a} rad): needs a positive finite length and 0 < alpha < pi/2"
                ));
            }
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

/// Packing fraction: total particle volume over container volume (thesis eq. 3.1).
pub fn packing_fraction(c: &Rods) -> Result<f64> {
    let v = match (c.wall_diameter, c.wedge) {
        (Some(d), _) => 0.25 * std::f64::consts::PI * d * d * c.box_length,
        (None, Some((l, a))) => 0.5 * l * l * a.tan() * c.box_length,
        (None, None) => c.box_length.powi(3),
    };
    Ok(c.total_volume()? / v)
}

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
pub fn wall_penetration(c: &Rods) -> Result<Option<(usize, f64)>> {
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
/// error naming the pair; see also the solver-free [`sampled_overlap`]). Errors if the box is
/// not longer than the largest particle (twice its bounding radius), where images of one
/// particle would touch themselves.
///
/// In a periodic box at least three pair reaches wide the candidate pairs come from a cell
/// binning of this module's own (cells of edge >= the largest reach: only the 27 cells around
/// a particle can hold a partner, and only one image of it can be within reach), which makes
/// the search O(N): the brute force over all N^2/2 pairs took 4 s of a 75 s run of 10000
/// spheres. The result is the same list, gap for gap, as [`pair_gaps_brute_force`] (tested),
/// which the walls and small boxes use.
pub fn pair_gaps(c: &Rods, max_gap: f64) -> Result<Vec<PairGap>> {
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

/// A periodic cell binning of the centres for the pair searches: cells of edge at least
/// `reach`, so every partner within `reach` of a particle (nearest image) lies in the 27 cells
/// around its own, and only one image of it can be within reach.
struct PeriodicCells {
    /// Cells per box edge (at least 3, so the 27 cells around one are distinct).
    per_edge: usize,
    box_length: f64,
    members: Vec<Vec<usize>>,
}

impl PeriodicCells {
    /// None when fewer than three cells of edge `reach` fit along the box.
    fn new(c: &Rods, reach: f64) -> Option<PeriodicCells> {
        // (A relative margin of 1e-9 keeps the cell edge above the reach through the rounding
        // of the cell coordinates.)
        let per_edge = (c.box_length / (reach * (1.0 + 1e-9))).floor();
        if per_edge.is_nan() || per_edge < 3.0 {
            return None;
        }
        let mut cells = PeriodicCells {
            per_edge: per_edge as usize,
            box_length: c.box_length,
            members: Vec::new(),
        };
        cells.members = vec![Vec::new(); cells.per_edge.pow(3)];
        for (j, x) in c.positions.iter().enumerate() {
            let k = cells.index(cells.cell_of(x));
            cells.members[k].push(j);
        }
        Some(cells)
    }

    fn cell_of(&self, x: &Vector3<f64>) -> [usize; 3] {
        let (m, bl) = (self.per_edge, self.box_length);
        let k = |t: f64| ((t / bl * m as f64).floor() as i64).rem_euclid(m as i64) as usize;
        [k(x.x), k(x.y), k(x.z)]
    }

    fn index(&self, k: [usize; 3]) -> usize {
        (k[0] * self.per_edge + k[1]) * self.per_edge + k[2]
    }

    /// The particles j > i in the 27 cells around particle i's, in increasing order.
    fn partners_above(&self, c: &Rods, i: usize) -> Vec<usize> {
        let m = self.per_edge;
        let k = self.cell_of(&c.positions[i]);
        let mut partners: Vec<usize> = Vec::new();
        for a in [m - 1, 0, 1] {
            for b in [m - 1, 0, 1] {
                for z in [m - 1, 0, 1] {
                    let cell = [(k[0] + a) % m, (k[1] + b) % m, (k[2] + z) % m];
                    partners.extend(self.members[self.index(cell)].iter().filter(|&&j| j > i));
                }
            }
        }
        partners.sort_unstable();
        partners
    }
}

/// What the gap of a pair at separation d needs: bounding radii, unit axes.
struct PairGeometry {
    bounds: Vec<f64>,
    axes: Vec<Vector3<f64>>,
    max_gap: f64,
}

impl PairGeometry {
    /// Checks the configuration and that the box is longer than the largest particle.
    fn of(c: &Rods, max_gap: f64) -> Result<PairGeometry> {
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
    fn gap(&self, c: &Rods, i: usize, j: usize, d: &Vector3<f64>) -> Result<Option<f64>> {
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
pub fn pair_gaps_brute_force(c: &Rods, max_gap: f64) -> Result<Vec<PairGap>> {
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
pub fn worst_gap(c: &Rods) -> Result<Option<PairGap>> {
    let g = pair_gaps_brute_force(c, 0.0)?;
    Ok(g.into_iter()
        .min_by(|a, b| a.gap.partial_cmp(&b.gap).unwrap()))
}

/// Independent overlap check: Ok(()) when no pair has gap below -`tol` and no particle
/// penetrates the cylinder wall (if any) deeper than `tol`; otherwise an error naming the
/// worst pair (or particle) and its overlap.
///
/// Configurations with ellipsoids or superquadrics are checked by [`sampled_overlap`]
/// (`OVERLAP_SAMPLES` surface points per particle; no contact solver): an error when some
/// sample provably lies deeper than `tol` inside another particle.
pub fn check_no_overlap(c: &Rods, tol: f64) -> Result<()> {
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

/// Cubatic order parameter S4 (thesis eq. 4.17, after Batten et al.):
/// max over unit n of (1/14N) sum_i sum_{j=1..3} (35 (u_ij.n)^4 - 30 (u_ij.n)^2 + 3), where
/// u_ij are the three body axes of particle i. 1 for perfect cubatic order, 0 on average for
/// isotropic orientations. The maximum is searched (as in the thesis) over trial directions
/// (a deterministic Fibonacci lattice of `trials` points on the half sphere), the best of which
/// are refined by projected gradient ascent.
pub fn cubatic_order(orientations: &[UnitQuaternion<f64>], trials: usize) -> Result<f64> {
    if orientations.is_empty() {
        return invalid("no orientations: cubatic order needs at least one particle");
    }
    if trials < 10 {
        return invalid(format!(
            "trials = {trials}: need at least 10 trial directions"
        ));
    }
    let axes: Vec<[Vector3<f64>; 3]> = orientations
        .iter()
        .map(|q| {
            let r = q.to_rotation_matrix();
            [
                r.matrix().column(0).into(),
                r.matrix().column(1).into(),
                r.matrix().column(2).into(),
            ]
        })
        .collect();
    let n_f = orientations.len() as f64;
    // sum_j c_j^2 = 1, so the summand is 35 sum_j c_j^4 - 21.
    let value = |n: &Vector3<f64>| -> f64 {
        let s: f64 = axes
            .iter()
            .map(|a| a.iter().map(|u| u.dot(n).powi(4)).sum::<f64>())
            .sum();
        (35.0 * s - 21.0 * n_f) / (14.0 * n_f)
    };
    let grad = |n: &Vector3<f64>| -> Vector3<f64> {
        let mut g = Vector3::zeros();
        for a in &axes {
            for u in a {
                g += 4.0 * u.dot(n).powi(3) * u;
            }
        }
        g * (35.0 / (14.0 * n_f))
    };
    // Fibonacci lattice on the upper half sphere (n and -n give the same value).
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut cand: Vec<(f64, Vector3<f64>)> = (0..trials)
        .map(|k| {
            let z = 1.0 - (k as f64 + 0.5) / trials as f64;
            let r = (1.0 - z * z).sqrt();
            let t = golden * k as f64;
            let n = Vector3::new(r * t.cos(), r * t.sin(), z);
            (value(&n), n)
        })
        .collect();
    cand.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
    let mut best = f64::NEG_INFINITY;
    for (v0, n0) in cand.into_iter().take(5) {
        let (mut v, mut n) = (v0, n0);
        let mut step = 0.1;
        for _ in 0..200 {
            let g = grad(&n);
            let gt = g - g.dot(&n) * n;
            if gt.norm() < 1e-14 {
                break;
            }
            let trial = (n + step * gt / gt.norm()).normalize();
            let vt = value(&trial);
            if vt > v {
                v = vt;
                n = trial;
                step *= 1.2;
            } else {
                step *= 0.5;
                if step < 1e-12 {
                    break;
                }
            }
        }
        best = best.max(v);
    }
    Ok(best)
}

/// Radial distribution function of the particle centres in the periodic cubic box: bin
/// centres r_k and g(r_k) = (pair count in the shell) / (N rho V_shell / 2), by brute force
/// over all pairs with the minimum image, for r up to `r_max` < L/2.
pub fn radial_distribution(c: &Rods, r_max: f64, bins: usize) -> Result<Vec<(f64, f64)>> {
    c.check()?;
    if c.wall_diameter.is_some() || c.wedge.is_some() {
        return invalid("g(r): only for the periodic cubic box (no wall)");
    }
    if bins == 0 {
        return invalid("bins = 0: need at least one bin");
    }
    if !(r_max.is_finite() && r_max > 0.0 && r_max <= 0.5 * c.box_length) {
        return invalid(format!(
            "r_max = {r_max}: must be positive and at most half the box length {}",
            0.5 * c.box_length
        ));
    }
    let n = c.n();
    if n < 2 {
        return invalid(format!("{n} particles: g(r) needs at least 2"));
    }
    let dr = r_max / bins as f64;
    let bl = c.box_length;
    let hist = pair_distance_histogram(c, r_max, bins, true);
    let rho = n as f64 / bl.powi(3);
    Ok(hist
        .iter()
        .enumerate()
        .map(|(k, &h)| {
            let (r0, r1) = (k as f64 * dr, (k + 1) as f64 * dr);
            let shell = 4.0 / 3.0 * std::f64::consts::PI * (r1.powi(3) - r0.powi(3));
            (0.5 * (r0 + r1), h as f64 / (0.5 * n as f64 * rho * shell))
        })
        .collect())
}

/// Counts of the pairs i < j at nearest-image centre distance r < r_max in `bins` bins of
/// r_max / bins (g(r) before normalisation). With `binned`, when three cells of r_max fit
/// along the box, the pairs come from the cell binning of the pair search (O(N) instead of all
/// N^2/2 pairs: 0.36 s of a 10000-sphere run at r_max = 3 D); either way each pair is counted
/// once with the same distance, so the counts are the same (tested).
fn pair_distance_histogram(c: &Rods, r_max: f64, bins: usize, binned: bool) -> Vec<u64> {
    let (n, bl, dr) = (c.n(), c.box_length, r_max / bins as f64);
    let cells = if binned {
        PeriodicCells::new(c, r_max)
    } else {
        None
    };
    let count_row = |mut hist: Vec<u64>, i: usize| {
        let mut count = |j: usize| {
            let d = (c.positions[j] - c.positions[i]).map(|x| x - bl * (x / bl).round());
            let r = d.norm();
            if r < r_max {
                hist[((r / dr) as usize).min(bins - 1)] += 1;
            }
        };
        match &cells {
            Some(cells) => cells.partners_above(c, i).into_iter().for_each(&mut count),
            None => (i + 1..n).for_each(&mut count),
        }
        hist
    };
    (0..n)
        .into_par_iter()
        .fold(|| vec![0u64; bins], count_row)
        .reduce(
            || vec![0u64; bins],
            |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect(),
        )
}

/// Fraction of wall-aligned particles (thesis sec. 2.2.5, Fig. 2.6, 2.14): among the particles
/// whose centre lies within `layer` of a wall (the thesis takes `layer` = D), the fraction
/// whose axis is tangential to that wall within `max_angle` radians, i.e. |u . n| <=
/// sin(max_angle) with n the wall normal (thesis: 4 degrees). Cylinder: radial position above
/// R_cyl - `layer`, n the radial unit vector. Wedge: within `layer` of the back, bottom or
/// slope plane; a particle near two planes (a corner) counts as aligned when it is tangential
/// to either. Returns (fraction, particles in the layer); the fraction is 0 for an empty
/// layer. Errors without a wall.
pub fn wall_aligned_fraction(c: &Rods, layer: f64, max_angle: f64) -> Result<(f64, usize)> {
    c.check()?;
    if c.wall_diameter.is_none() && c.wedge.is_none() {
        return invalid("wall alignment: needs a cylinder or a wedge");
    }
    if !(layer.is_finite() && layer > 0.0) {
        return invalid(format!("layer = {layer}: must be positive and finite"));
    }
    if !(0.0..=0.5 * std::f64::consts::PI).contains(&max_angle) {
        return invalid(format!(
            "max_angle = {max_angle}: must be in [0, pi/2] radians"
        ));
    }
    let (mut near, mut aligned) = (0usize, 0usize);
    let mut normals = Vec::with_capacity(3);
    for (x, q) in c.positions.iter().zip(c.orientations) {
        normals.clear();
        if let Some(d) = c.wall_diameter {
            let rho = x.x.hypot(x.y);
            if rho > 0.5 * d - layer && rho > 0.0 {
                normals.push(Vector3::new(x.x / rho, x.y / rho, 0.0));
            }
        }
        if let Some((l, a)) = c.wedge {
            let (sin, cos) = a.sin_cos();
            if l - x.x < layer {
                normals.push(Vector3::x());
            }
            if x.y < layer {
                normals.push(Vector3::y());
            }
            if x.x * sin - x.y * cos < layer {
                normals.push(Vector3::new(-sin, cos, 0.0));
            }
        }
        if normals.is_empty() {
            continue;
        }
        near += 1;
        let u = q * Vector3::z();
        if normals.iter().any(|n| u.dot(n).abs() <= max_angle.sin()) {
            aligned += 1;
        }
    }
    let f = if near == 0 {
        0.0
    } else {
        aligned as f64 / near as f64
    };
    Ok((f, near))
}

/// Histogram of particle axis directions (thesis sec. 2.2.5): polar angle theta of the
/// headless axis in [0, pi/2] (u and -u identified, theta from +z) in `n_theta` equal bins,
/// azimuth phi in [0, pi) in `n_phi` equal bins; `counts[k_theta][k_phi]`.
pub fn orientation_histogram(
    axes: &[Vector3<f64>],
    n_theta: usize,
    n_phi: usize,
) -> Result<Vec<Vec<usize>>> {
    if n_theta == 0 || n_phi == 0 {
        return invalid(format!(
            "n_theta = {n_theta}, n_phi = {n_phi}: need at least one bin each"
        ));
    }
    let mut h = vec![vec![0usize; n_phi]; n_theta];
    for (i, u) in axes.iter().enumerate() {
        let nu = u.norm();
        if !(nu.is_finite() && nu > 0.0) {
            return invalid(format!(
                "axis {i} has norm {nu}: must be positive and finite"
            ));
        }
        let mut u = u / nu;
        if u.z < 0.0 {
            u = -u;
        }
        let theta = u.z.clamp(-1.0, 1.0).acos();
        let phi = u.y.atan2(u.x).rem_euclid(std::f64::consts::PI);
        let kt =
            ((theta / (0.5 * std::f64::consts::PI) * n_theta as f64) as usize).min(n_theta - 1);
        let kp = ((phi / std::f64::consts::PI * n_phi as f64) as usize).min(n_phi - 1);
        h[kt][kp] += 1;
    }
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spheres(pos: &[Vector3<f64>]) -> (Vec<Vector3<f64>>, Vec<UnitQuaternion<f64>>) {
        (pos.to_vec(), vec![UnitQuaternion::identity(); pos.len()])
    }

    /// `n` points uniform in the cube [0, box_length)^3 (ChaCha8 seeded with `seed`).
    fn uniform_points(n: usize, box_length: f64, seed: u64) -> Vec<Vector3<f64>> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| Vector3::new(rng.gen(), rng.gen(), rng.gen()) * box_length)
            .collect()
    }

    /// The species table of equal rods of radius 1/2 (leaked: test data only).
    fn mono_shape(length: f64) -> &'static [ContactShape] {
        Vec::leak(crate::packing::Particles::monodisperse(1, length).shapes)
    }
    fn zeros(n: usize) -> &'static [usize] {
        Vec::leak(vec![0; n])
    }

    fn sphere_rods<'a>(
        box_length: f64,
        pos: &'a [Vector3<f64>],
        ori: &'a [UnitQuaternion<f64>],
    ) -> Rods<'a> {
        Rods::periodic(box_length, mono_shape(0.0), zeros(pos.len()), pos, ori)
    }

    /// Volume of the spherical shell [k dr, (k + 1) dr).
    fn shell_volume(k: usize, dr: f64) -> f64 {
        let (r0, r1) = (k as f64 * dr, (k + 1) as f64 * dr);
        4.0 / 3.0 * std::f64::consts::PI * (r1.powi(3) - r0.powi(3))
    }

    /// The m^3 sites of a simple cubic lattice of spacing 1 from the origin.
    fn lattice(m: usize) -> Vec<Vector3<f64>> {
        (0..m * m * m)
            .map(|k| Vector3::new((k % m) as f64, ((k / m) % m) as f64, (k / (m * m)) as f64))
            .collect()
    }

    #[test]
    fn simple_cubic_lattice_has_six_contacts_and_pi_over_six() {
        // Unit spheres (diameter 1) on a simple cubic lattice of spacing 1: phi = pi/6, every
        // sphere touches 6 neighbours, some through the periodic boundary.
        let m = 4;
        let p: Vec<_> = lattice(m)
            .into_iter()
            .map(|x| x + Vector3::repeat(0.5))
            .collect();
        let (pos, ori) = spheres(&p);
        let r = Rods {
            box_length: m as f64,
            wall_diameter: None,
            wedge: None,
            shapes: mono_shape(0.0),
            species: zeros(pos.len()),
            positions: &pos,
            orientations: &ori,
        };
        assert!((packing_fraction(&r).unwrap() - std::f64::consts::PI / 6.0).abs() < 1e-15);
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
            wall_diameter: None,
            wedge: None,
            shapes: mono_shape(0.0),
            species: zeros(pos.len()),
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
            wall_diameter: None,
            wedge: None,
            shapes: mono_shape(3.0),
            species: zeros(pos.len()),
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
        // Threshold 3 removes the triangle as well: no particle is left to average over, and
        // the extrapolation says so instead of returning 0.
        assert_eq!(mean_contacts(6, &g, 1e-9, Some(3)).1, 6);
        let e = extrapolated_contacts(6, &g, &[1e-9, 1e-8], Some(3)).unwrap_err();
        assert!(
            e.to_string()
                .contains("every one of the 6 particles is a rattler"),
            "{e}"
        );
        let (c0, slope) = extrapolated_contacts(6, &g, &[1e-9, 1e-8], Some(2)).unwrap();
        assert_eq!((c0, slope), (2.0, 0.0));
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

    /// Shoemake's uniform random rotation from three uniforms.
    fn random_rotation(u1: f64, u2: f64, u3: f64) -> UnitQuaternion<f64> {
        let tau = std::f64::consts::TAU;
        UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
            (1.0 - u1).sqrt() * (tau * u2).cos(),
            (1.0 - u1).sqrt() * (tau * u2).sin(),
            u1.sqrt() * (tau * u3).sin(),
            u1.sqrt() * (tau * u3).cos(),
        ))
    }

    #[test]
    fn cubatic_order_limits() {
        use rand::{Rng, SeedableRng};
        // One common orientation (any): perfect cubatic order, S4 = 1 exactly at the optimum.
        let q = random_rotation(0.3, 0.7, 0.1);
        let s4 = cubatic_order(&vec![q; 50], 500).unwrap();
        assert!((s4 - 1.0).abs() < 1e-9, "{s4}");
        // Two populations sharing the z axis (one turned 45 deg about it): n = z still gives 1.
        let mut qs = vec![UnitQuaternion::identity(); 20];
        qs.extend(vec![
            UnitQuaternion::from_axis_angle(
                &Vector3::z_axis(),
                0.25 * std::f64::consts::PI
            );
            20
        ]);
        assert!((cubatic_order(&qs, 500).unwrap() - 1.0).abs() < 1e-9);
        // Isotropic orientations: <35 c^4 - 30 c^2 + 3> = 7 - 10 + 3 = 0 for uniform c; the
        // per-particle value has standard deviation below 1, so for N = 20000 the maximum over
        // directions of the mean stays within a few times 1/sqrt(N) = 0.007 of 0.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let iso: Vec<_> = (0..20000)
            .map(|_| random_rotation(rng.gen(), rng.gen(), rng.gen()))
            .collect();
        let s4 = cubatic_order(&iso, 300).unwrap();
        assert!(s4.abs() < 0.05, "{s4}");
        assert!(cubatic_order(&[], 100).is_err());
        assert!(cubatic_order(&iso[..3], 5).is_err());
    }

    #[test]
    fn radial_distribution_of_lattice_and_ideal_gas() {
        // Simple cubic lattice, spacing 1: the first shell (r = 1) holds 6 neighbours, so
        // 4 pi r^2 rho g dr integrated over its bin is 6; no pair closer than 1.
        let m = 6;
        let p = lattice(m);
        let (pos, ori) = spheres(&p);
        let r = sphere_rods(m as f64, &pos, &ori);
        // Bins of 0.3 up to 1.2: the shell r = 1 lies inside [0.9, 1.2), the next (sqrt 2)
        // beyond.
        let g = radial_distribution(&r, 1.2, 4).unwrap();
        let dr = 0.3;
        let shell = |k: usize, v: f64| v * shell_volume(k, dr);
        let first: f64 = g
            .iter()
            .enumerate()
            .filter(|(_, (rc, _))| (rc - 1.05).abs() < 1e-9)
            .map(|(k, (_, v))| shell(k, *v))
            .sum();
        assert!((first - 6.0).abs() < 1e-9, "{first}");
        assert!(g.iter().take(3).all(|(_, v)| *v == 0.0));
        // Uniform random points: g = 1 within the Poisson error of each bin.
        let (pos, ori) = spheres(&uniform_points(3000, 10.0, 9));
        let r = sphere_rods(10.0, &pos, &ori);
        let g = radial_distribution(&r, 5.0, 10).unwrap();
        let rho = 3.0;
        for (k, (_, v)) in g.iter().enumerate() {
            let expected_pairs = 0.5 * 3000.0 * rho * shell_volume(k, 0.5);
            // 5 standard deviations of a Poisson count.
            assert!(
                (v - 1.0).abs() < 5.0 / expected_pairs.sqrt(),
                "bin {k}: {v}"
            );
        }
        assert!(radial_distribution(&r, 6.0, 10).is_err());
    }

    /// The cell-binned pair count of g(r) equals the all-pairs count bin for bin: uniform
    /// points (pairs through every face of the box) and a jammed packing (many pairs at the
    /// bin edge r = 1), with 3 and 4 cells along the box, and a box of fewer than 3 cells.
    #[test]
    fn binned_pair_distances_equal_all_pairs() {
        use crate::packing::{run, McmParams, Scheme};
        let (pos, ori) = spheres(&uniform_points(2000, 12.0, 5));
        let gas = sphere_rods(12.0, &pos, &ori);
        let mut prm = McmParams::new(400, 0.0, 7);
        prm.scheme = Scheme::Original;
        let dense = run(&prm).unwrap().packing;
        let mut pairs = 0;
        for (r, r_max, bins) in [(&gas, 4.0, 40), (&gas, 3.0, 7), (&gas, 5.0, 10)] {
            let all = pair_distance_histogram(r, r_max, bins, false);
            assert_eq!(pair_distance_histogram(r, r_max, bins, true), all);
            pairs += all.iter().sum::<u64>();
        }
        let v = dense.view();
        let r_max = v.box_length / 3.0 * (1.0 - 1e-6);
        let all = pair_distance_histogram(&v, r_max, 30, false);
        assert_eq!(pair_distance_histogram(&v, r_max, 30, true), all);
        assert!(PeriodicCells::new(&v, r_max).is_some());
        assert!(PeriodicCells::new(&gas, 5.0).is_none());
        pairs += all.iter().sum::<u64>();
        assert!(pairs > 100_000, "{pairs}");
    }

    #[test]
    fn orientation_histogram_of_uniform_axes() {
        use rand::{Rng, SeedableRng};
        // Uniform directions: P(theta bin) = cos(theta0) - cos(theta1) on the half sphere,
        // azimuth uniform; each count within 5 binomial standard deviations.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let n = 200_000;
        let axes: Vec<_> = (0..n)
            .map(|_| random_rotation(rng.gen(), rng.gen(), rng.gen()) * Vector3::z())
            .collect();
        let (nt, np) = (6, 4);
        let h = orientation_histogram(&axes, nt, np).unwrap();
        let w = 0.5 * std::f64::consts::PI / nt as f64;
        for (kt, row) in h.iter().enumerate() {
            let p_theta = (kt as f64 * w).cos() - ((kt + 1) as f64 * w).cos();
            for &c in row {
                let p = p_theta / np as f64;
                let sd = (n as f64 * p * (1.0 - p)).sqrt();
                assert!((c as f64 - n as f64 * p).abs() < 5.0 * sd, "{kt}: {c}");
            }
        }
        // Axis along -z counts as theta = 0; along y as theta = pi/2, phi = pi/2.
        let h = orientation_histogram(&[-Vector3::z(), Vector3::y()], 2, 2).unwrap();
        assert_eq!(h, vec![vec![1, 0], vec![0, 1]]);
        assert!(orientation_histogram(&axes, 0, 1).is_err());
    }

    #[test]
    fn wall_alignment_counts_tangential_particles_in_the_layer() {
        // Cylinder D_cyl = 10; three rods in the layer (rho > 4): one along z (tangential),
        // one along the azimuth (tangential), one radial (not); one rod near the axis (ignored).
        let pos = vec![
            Vector3::new(4.5, 0.0, 1.0),
            Vector3::new(0.0, 4.4, 3.0),
            Vector3::new(-4.2, 0.0, 5.0),
            Vector3::new(0.5, 0.5, 7.0),
        ];
        let to = |v: Vector3<f64>| UnitQuaternion::rotation_between(&Vector3::z(), &v).unwrap();
        let ori = vec![
            UnitQuaternion::identity(),
            to(Vector3::new(1.0, 0.0, 0.0)),
            to(Vector3::new(1.0, 0.0, 0.0)),
            UnitQuaternion::identity(),
        ];
        let r = Rods {
            box_length: 20.0,
            wall_diameter: Some(10.0),
            wedge: None,
            shapes: mono_shape(1.0),
            species: zeros(pos.len()),
            positions: &pos,
            orientations: &ori,
        };
        let (f, near) = wall_aligned_fraction(&r, 1.0, 4f64.to_radians()).unwrap();
        assert_eq!(near, 3);
        assert!((f - 2.0 / 3.0).abs() < 1e-15);
        let periodic = Rods {
            wall_diameter: None,
            wedge: None,
            ..r
        };
        assert!(wall_aligned_fraction(&periodic, 1.0, 0.1).is_err());
    }

    #[test]
    fn wedge_alignment_uses_the_nearest_walls() {
        // Wedge l_w = 10, alpha = 30 deg. Near the back (x = 9.5): along y is tangential; near
        // the bottom (y = 0.5): along x is tangential, along y is not; near the slope: along
        // the slope direction is tangential; one rod deep inside is ignored.
        let a = 30f64.to_radians();
        let slope_dir = Vector3::new(a.cos(), a.sin(), 0.0);
        let on_slope = 6.0 * slope_dir + 0.5 * Vector3::new(a.sin(), -a.cos(), 0.0);
        let pos = vec![
            Vector3::new(9.5, 2.0, 1.0),
            Vector3::new(5.0, 0.5, 2.0),
            Vector3::new(6.0, 0.5, 3.0),
            on_slope + Vector3::new(0.0, 0.0, 4.0),
            Vector3::new(8.0, 2.0, 5.0),
        ];
        let to = |v: Vector3<f64>| UnitQuaternion::rotation_between(&Vector3::z(), &v).unwrap();
        let ori = vec![
            to(Vector3::y()),
            to(Vector3::x()),
            to(Vector3::y()),
            to(slope_dir),
            to(Vector3::x()),
        ];
        let r = Rods {
            box_length: 20.0,
            wall_diameter: None,
            wedge: Some((10.0, a)),
            shapes: mono_shape(1.0),
            species: zeros(pos.len()),
            positions: &pos,
            orientations: &ori,
        };
        let (f, near) = wall_aligned_fraction(&r, 1.0, 4f64.to_radians()).unwrap();
        assert_eq!(near, 4);
        assert!((f - 0.75).abs() < 1e-15, "{f}");
    }

    /// The cell-binned search returns the brute force's list, pair for pair and gap for gap
    /// (bitwise): a dense sphere packing (many near contacts, pairs through the boundary),
    /// random rods, and a mixture of superballs, ellipsoids and spheres with overlaps, at gaps
    /// from 0 to 1; and boxes that fit fewer than three reaches (the brute force itself).
    #[test]
    fn binned_pair_search_equals_the_brute_force() {
        use crate::packing::{random_start, run, McmParams, Scheme};
        use rand::{Rng, SeedableRng};
        let mut prm = McmParams::new(400, 0.0, 7);
        prm.scheme = Scheme::Original;
        let dense = run(&prm).unwrap().packing;
        let rods = random_start(300, 1.0, 0.3, 4).unwrap();
        let small = random_start(40, 0.0, 0.3, 4).unwrap();
        let mut checked = 0;
        for p in [&dense, &rods, &small] {
            let v = p.view();
            for max_gap in [0.0, 1e-3, 0.3, 1.0] {
                let binned = pair_gaps(&v, max_gap).unwrap();
                assert_eq!(binned, pair_gaps_brute_force(&v, max_gap).unwrap());
                checked += binned.len();
            }
        }
        // Mixture: superballs (gamma 3), ellipsoids and spheres at random in a box of 3.3
        // reaches, overlaps included.
        let shapes = [
            ContactShape::Superquadric {
                semi_axes: [0.5; 3],
                exponents: [3.0; 3],
            },
            ContactShape::Ellipsoid {
                semi_axes: [0.6, 0.4, 0.3],
            },
            ContactShape::Sphere { radius: 0.45 },
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let box_length = 7.0;
        let n = 150;
        let species: Vec<usize> = (0..n).map(|i| i % 3).collect();
        let pos: Vec<Vector3<f64>> = (0..n)
            .map(|_| Vector3::new(rng.gen(), rng.gen(), rng.gen()) * box_length)
            .collect();
        let ori: Vec<UnitQuaternion<f64>> = (0..n)
            .map(|_| random_rotation(rng.gen(), rng.gen(), rng.gen()))
            .collect();
        let r = Rods::periodic(box_length, &shapes, &species, &pos, &ori);
        let binned = pair_gaps(&r, 0.1).unwrap();
        assert_eq!(binned, pair_gaps_brute_force(&r, 0.1).unwrap());
        assert!(binned.iter().any(|g| g.gap < 0.0));
        checked += binned.len();
        assert!(checked > 5000, "{checked} pairs");
    }

    #[test]
    fn bad_input_is_an_error() {
        let (pos, ori) = spheres(&[Vector3::zeros()]);
        let r = Rods {
            box_length: -1.0,
            wall_diameter: None,
            wedge: None,
            shapes: mono_shape(0.0),
            species: zeros(pos.len()),
            positions: &pos,
            orientations: &ori,
        };
        assert!(pair_gaps(&r, 0.0).is_err());
        assert!(extrapolated_contacts(1, &[], &[1e-6], None).is_err());
    }
}
