//! Random dense packings by the mechanical contraction method (MCM; thesis 003 ch. 2-3).
//!
//! **Reduced units**: lengths in particle diameters (D = 2R = 1), volumes in D^3, mass equal to
//! the particle volume (density 1, thesis sec. 3.6). A spherocylinder has radius R = 1/2 and a
//! cylinder of length L (= aspect L/D) between its hemisphere centres; L = 0 is a sphere.
//!
//! The algorithm (sec. 2.2.1, 3.2): a dilute random overlap-free start (random sequential
//! addition at `phi0`, fixed seed, ChaCha8) in a periodic cubic box, a hard cylinder or a hard
//! wedge ([`Container`]; wall overlaps through virtual particles, sec. 2.2.4, for ellipsoids and
//! superquadrics through the support point beyond the wall's tangent plane); the volume is reduced
//! by Delta V and positions are scaled (orientations kept); overlaps deeper than
//! `overlap_tol` are removed by translating and rotating the overlapping particles
//! ([`Scheme::Revised`], eq. 3.2-3.13, or [`Scheme::Original`], eq. 2.4-2.10). When the
//! overlaps cannot be removed within `tries_per_particle * N` particle moves, the run reverts
//! to the last overlap-free configuration and halves Delta V, at most `halvings` times; the
//! last overlap-free configuration is the result. An optional final stage
//! ([`Setup::final_stage`]) continues from there with its own schedule and scheme.
//!
//! Overlap removal visits the particles in index order (Gauss-Seidel: each move sees the moves
//! before it), with per-particle neighbour (Verlet) lists (module `neighbours`: built from a
//! cell grid over the container, periodic along the periodic directions, clamped across the
//! walls; a particle's list is rebuilt when a point of its axis has moved a quarter of the
//! skin); a particle is rechecked only when it or a neighbour moved. Each move counts as one
//! try. Runs are deterministic for a given seed.
//!
//! The door: a [`Setup`] (`setup.rs`) describes the run; [`Mcm::new`] checks it and makes the
//! random start; [`Mcm::step`] is one compression step; [`driver::run`] runs the engine to
//! its end with progress, checkpoint and stop hooks ([`crate::driver::Hooks`]), and
//! [`driver::run_to_end`] does so without them.

use crate::contact::{closest_points_segments, ContactShape};
use crate::error::invalid;
use crate::Result;
pub use container::{wedge_min_length, wedge_min_packing_fraction, Container};
use nalgebra::{Matrix3, Unit, UnitQuaternion, Vector3};
use neighbours::{Grid, Neighbours};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Particle radius in reduced units (diameter 1).
pub const RADIUS: f64 = 0.5;

/// Volume of one particle (R = 1/2, cylinder length L; thesis eq. 2.2).
pub fn particle_volume(length: f64) -> f64 {
    let s = ParticleShapes::monodisperse(1, length).shapes[0];
    crate::shape::volume_of(&s).unwrap_or(f64::NAN)
}

/// Principal moments of inertia (I_xy, I_z) of a z-aligned spherocylinder of radius 1/2 and
/// mass m (thesis eq. 2.3).
pub fn principal_inertia(length: f64, mass: f64) -> (f64, f64) {
    rod_inertia(RADIUS, length, mass)
}

/// Principal moments of inertia (I_xy, I_z) of a z-aligned spherocylinder of radius r, cylinder
/// length l and mass m (thesis eq. 2.3).
pub fn rod_inertia(r: f64, l: f64, mass: f64) -> (f64, f64) {
    let den = 3.0 * l + 4.0 * r;
    let ixy = mass / 20.0
        * (5.0 * l.powi(3) + 20.0 * l * l * r + 45.0 * l * r * r + 32.0 * r.powi(3))
        / den;
    let iz = mass / 10.0 * (15.0 * l * r * r + 16.0 * r.powi(3)) / den;
    (ixy, iz)
}

/// A configuration: particles of per-particle shape ([`ParticleShapes`]) in a [`Container`]: a
/// periodic cubic box [0, L)^3, or a cylinder about the z axis, periodic in z over [0, L).
#[derive(Debug, Clone)]
pub struct Packing {
    pub container: Container,
    /// Side of the periodic box, or period along the cylinder axis.
    pub box_length: f64,
    /// The shape of every particle.
    pub particles: ParticleShapes,
    pub positions: Vec<Vector3<f64>>,
    /// Orientation (body -> world); a rod's axis is the body z axis.
    pub orientations: Vec<UnitQuaternion<f64>>,
}

impl Packing {
    /// The same particles with particle k of the result the particle `order[k]` of this one
    /// (position, orientation and species; `order` a permutation of 0..N).
    fn renumbered(&self, order: &[usize]) -> Packing {
        let mut q = self.clone();
        for (k, &i) in order.iter().enumerate() {
            q.positions[k] = self.positions[i];
            q.orientations[k] = self.orientations[i];
            q.particles.species[k] = self.particles.species[i];
        }
        q
    }

    pub fn n(&self) -> usize {
        self.positions.len()
    }
    /// The common cylinder length when every particle is the same sphere (0) or spherocylinder
    /// of radius 1/2; None for mixtures, other radii and superquadrics.
    pub fn monodisperse_length(&self) -> Option<f64> {
        match self.particles.shapes.as_slice() {
            [ContactShape::Sphere { radius }] if *radius == RADIUS => Some(0.0),
            [ContactShape::Spherocylinder { radius, length }] if *radius == RADIUS => Some(*length),
            _ => None,
        }
    }
    /// Unit axis (body z) of particle i (world).
    pub fn axis(&self, i: usize) -> Vector3<f64> {
        self.orientations[i] * Vector3::z()
    }
    pub fn axes(&self) -> Vec<Vector3<f64>> {
        (0..self.n()).map(|i| self.axis(i)).collect()
    }
    /// Packing fraction: total particle volume over the container volume (thesis eq. 3.1).
    pub fn packing_fraction(&self) -> f64 {
        self.particles.total_volume().unwrap_or(f64::NAN) / self.container.volume(self.box_length)
    }
    /// The configuration as the plain data the analysis functions take.
    pub fn view(&self) -> crate::analysis::Rods<'_> {
        crate::analysis::Rods {
            box_length: self.box_length,
            wall_diameter: match self.container {
                Container::Periodic => None,
                Container::Cylinder { diameter } => Some(diameter),
                Container::Wedge { .. } => None,
            },
            wedge: match self.container {
                Container::Wedge { length, angle_rad } => Some((length, angle_rad)),
                _ => None,
            },
            shapes: &self.particles.shapes,
            species: &self.particles.species,
            positions: &self.positions,
            orientations: &self.orientations,
        }
    }
}

/// One compression step that was accepted.
#[derive(Debug, Clone, Copy)]
pub struct StepRecord {
    pub step: usize,
    pub packing_fraction: f64,
    pub delta_v: f64,
    /// Particle moves needed to remove the overlaps of this step.
    pub tries: u64,
}

/// Overlap of one pair, as seen from particle i.
#[derive(Debug, Clone, Copy)]
struct Overlap {
    /// Overlap depth delta_ij > 0.
    depth: f64,
    /// Unit normal from i to j.
    normal: Vector3<f64>,
    /// Closest-point vector between the axes, from i's axis point to j's (original scheme k_ij).
    k: Vector3<f64>,
    /// Contact point of i relative to its centre (r_c,ij of eq. 3.2).
    rc: Vector3<f64>,
    /// Position of i's axis point along its axis, in [-L/2, L/2] (l_ij of eq. 2.4).
    l: f64,
}

/// Gap and contact geometry of rod i (radius ri, half cylinder length hi, at the origin) and
/// rod j (rj, hj) at separation `d` (minimum image); spheres have h = 0.
/// Returns (gap, normal i->j, k, rc_i, l_i, rc_j, l_j).
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
#[inline(always)]
fn pair_geometry(
    (ri, hi): (f64, f64),
    (rj, hj): (f64, f64),
    ai: &Vector3<f64>,
    aj: &Vector3<f64>,
    d: &Vector3<f64>,
) -> (
    f64,
    Vector3<f64>,
    Vector3<f64>,
    Vector3<f64>,
    f64,
    Vector3<f64>,
    f64,
) {
    if hi == 0.0 && hj == 0.0 {
        let dist = d.norm();
        let n = if dist > 0.0 { d / dist } else { Vector3::x() };
        return (dist - (ri + rj), n, *d, ri * n, 0.0, -rj * n, 0.0);
    }
    let (p0, p1) = (-hi * ai, hi * ai);
    let (q0, q1) = (d - hj * aj, d + hj * aj);
    let (s, t, p, q) = closest_points_segments(&p0, &p1, &q0, &q1);
    let k = q - p;
    let dist = k.norm();
    let n = if dist > 1e-300 {
        k / dist
    } else {
        let c = ai.cross(aj);
        let mut n = if c.norm() > 1e-12 {
            c.normalize()
        } else {
            let e = if ai.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            ai.cross(&e).normalize()
        };
        if n.dot(d) < 0.0 {
            n = -n;
        }
        n
    };
    let rc_i = p + ri * n;
    let rc_j = (q - d) - rj * n;
    (
        dist - (ri + rj),
        n,
        k,
        rc_i,
        (s - 0.5) * (hi + hi),
        rc_j,
        (t - 0.5) * (hj + hj),
    )
}

/// Body-to-world inverse inertia tensor of particle i (mass = volume).
fn inverse_inertia_world(q: &UnitQuaternion<f64>, inertia: &Vector3<f64>) -> Matrix3<f64> {
    let r = q.to_rotation_matrix();
    let inv_body = Matrix3::from_diagonal(&inertia.map(|i| 1.0 / i));
    r.matrix() * inv_body * r.matrix().transpose()
}

/// The move (translation, rotation) of one particle under the revised scheme (eq. 3.6-3.12).
// `!(lam2 > 0.0)` is meant: a NaN multiplier means no move.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn move_revised(
    ov: &[Overlap],
    q: &UnitQuaternion<f64>,
    body: &species::Props,
    prm: &Setup,
) -> (Vector3<f64>, Option<UnitQuaternion<f64>>) {
    let (sphere, mass) = (body.sphere, body.mass);
    let sum_n: Vector3<f64> = ov.iter().map(|o| o.normal).sum();
    let dmin = ov.iter().map(|o| o.depth).fold(f64::INFINITY, f64::min);
    // Torque-like sum of eq. 3.7 (zero for spheres: r_c is parallel to n).
    let tau: Vector3<f64> = if sphere {
        Vector3::zeros()
    } else {
        ov.iter().map(|o| o.normal.cross(&o.rc)).sum()
    };
    let inv_i = inverse_inertia_world(q, &body.inertia);
    let lam2 = (sum_n.norm_squared() / mass + tau.dot(&(inv_i * tau))) / (2.0 * prm.energy); // eq. 3.8
    if !(lam2 > 0.0) {
        return (Vector3::zeros(), None);
    }
    let lam = lam2.sqrt();
    let v = -sum_n / (lam * mass); // eq. 3.6
    let dx = dmin * prm.dt * v; // eq. 3.9
    if sphere {
        return (dx, None);
    }
    let w = inv_i * tau / lam; // eq. 3.7
    let wn = w.norm();
    if wn == 0.0 {
        return (dx, None);
    }
    let dtheta = wn * dmin * prm.dt; // eq. 3.12
                                     // Rodrigues rotation (eq. 3.10-3.11) about the world axis w / |w|, applied in the world
                                     // frame (eq. 3.13 with omega expressed in world coordinates).
    let rot = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(w / wn), dtheta);
    (dx, Some(rot * q))
}

/// The move of one particle under the original scheme (eq. 2.7-2.10, delta-weighted sums,
/// unit mass, xi = I_xy / m).
fn move_original(
    ov: &[Overlap],
    q: &UnitQuaternion<f64>,
    sphere: bool,
    xi: f64,
    prm: &Setup,
) -> (Vector3<f64>, Option<UnitQuaternion<f64>>) {
    let ez = q * Vector3::z();
    // Sign: k_ij points from i to j, so moving along -k removes the overlap.
    let v: Vector3<f64> = -ov.iter().map(|o| o.depth * o.k).sum::<Vector3<f64>>();
    let w: Vector3<f64> = if sphere {
        Vector3::zeros()
    } else {
        // Components of k_ij perpendicular to the axis (n = 4, 5), weighted by l_ij / xi:
        // the rate of change of e_z (eq. 2.9).
        -ov.iter()
            .map(|o| o.depth * o.l * (o.k - o.k.dot(&ez) * ez))
            .sum::<Vector3<f64>>()
            / xi
    };
    // eq. 2.10: the smallest time that removes a fraction beta of one overlap at its rate.
    let mut dt = f64::INFINITY;
    for o in ov {
        let khat = o.normal;
        let rate = -(v + o.l * w).dot(&khat);
        if rate > 0.0 {
            dt = dt.min(o.depth / rate);
        }
    }
    if !dt.is_finite() {
        return (Vector3::zeros(), None);
    }
    let dt = prm.beta * dt;
    let dx = dt * v;
    if sphere || w.norm() == 0.0 {
        return (dx, None);
    }
    let new_ez = (ez + dt * w).normalize();
    let rot =
        UnitQuaternion::rotation_between(&ez, &new_ez).unwrap_or_else(UnitQuaternion::identity);
    (dx, Some(rot * q))
}

/// Centre-distance cutoff for any contact of two species (sum of the bounding radii, plus a
/// margin for the contact tolerance). For two rods (L_i + L_j)/2 + R_i + R_j, written so that
/// equal rods of radius 1/2 give exactly L + D + 1e-6 as before mixtures existed.
fn pair_cutoff(a: &species::Props, b: &species::Props) -> f64 {
    if a.sq.is_none() && b.sq.is_none() {
        (a.h + b.h) + (a.r + b.r) + 1e-6
    } else {
        a.bound + b.bound + 1e-6
    }
}

/// The largest pair cutoff over all pairs of species (the neighbour lists use it).
fn max_pair_cutoff(props: &[species::Props]) -> f64 {
    let big = props
        .iter()
        .max_by(|a, b| a.bound.total_cmp(&b.bound))
        .expect("at least one species");
    pair_cutoff(big, big)
}

/// Checks that the periodic length is at least twice the largest pair cutoff (unique minimum
/// image) and, for a cylinder, that every particle fits in it.
fn check_box(container: &Container, box_length: f64, props: &[species::Props]) -> Result<()> {
    let rc = max_pair_cutoff(props);
    if box_length.is_nan() || box_length < 2.0 * rc {
        return invalid(format!(
            "box length {box_length:.4} is below twice the largest pair cutoff {rc:.4} (sum of \
             bounding radii): the minimum image would miss contacts; use more particles"
        ));
    }
    // Ellipsoids and superquadrics: the bounding sphere (the random start places it inside).
    let dmax = props
        .iter()
        .map(|s| 2.0 * if s.sq.is_some() { s.bound } else { s.r })
        .fold(0.0, f64::max);
    container.check(dmax)
}

/// Overlap of particle i (species props `a`, orientation `qi`, at the origin) with j (`b`,
/// `qj`, at separation `d`) by the contact solver (ellipsoids, superquadrics; spheres among
/// them as exponent-2 superquadrics), bounding spheres first. None when apart or not deeper
/// than `tol`; a solver that did not converge is an error naming the pair.
#[allow(clippy::too_many_arguments)]
fn sq_overlap(
    (i, a, qi): (usize, &species::Props, &UnitQuaternion<f64>),
    (j, b, qj): (usize, &species::Props, &UnitQuaternion<f64>),
    d: &Vector3<f64>,
    tol: f64,
) -> Result<Option<Overlap>> {
    use crate::analysis::PERTURB_ANGLE;
    use crate::contact::{contact_perturbed, contact_superquadric_perturbed, Pose};
    if d.norm() >= a.bound + b.bound {
        return Ok(None);
    }
    let (Some(sa), Some(sb)) = (&a.sq, &b.sq) else {
        return invalid("superquadric pair without superquadric shapes (internal)");
    };
    // Separating-axis prefilter along the line of centres u (support points in closed form):
    // the extents h_a(u) + h_b(-u) fall short of |d| by the projected gap. The overlap depth
    // (the shortest separating translation) is at most the projected overlap along any
    // axis, so a projected gap above -tol means the pair overlaps by less than tol: no
    // solver call (most neighbour pairs in a packing).
    let dist = d.norm();
    if dist > 0.0 {
        let u = d / dist;
        let ha = u.dot(&(qi * sa.support(&(qi.inverse() * u))));
        let hb = -u.dot(&(qj * sb.support(&(qj.inverse() * -u))));
        if dist - (ha + hb) > -tol {
            return Ok(None);
        }
    }
    let (pa, pb) = (Pose::new(Vector3::zeros(), *qi), Pose::new(*d, *qj));
    // A query that does not converge (nearly parallel faces of large-exponent superballs:
    // 50 superballs of exponent 5 stopped with this error before the retry) is retried from
    // b rotated by PERTURB_ANGLE = 1e-6 rad, which moves its surface by at most 0.87e-6 D
    // for a superball of half-width 1/2 (bounding radius <= 0.5 sqrt 3), 1% of the default
    // overlap_tol; a query that still fails is an error naming the pair.
    // A pair with a superquadric goes to the superquadric solver with the species' shapes
    // (bounding radii computed once); other pairs (spheres, ellipsoids) through the dispatch.
    let sq_pair = [&a.shape, &b.shape]
        .iter()
        .any(|s| matches!(s, ContactShape::Superquadric { .. }));
    let c = if sq_pair {
        contact_superquadric_perturbed(sa, &pa, sb, &pb, PERTURB_ANGLE)
    } else {
        contact_perturbed(&a.shape, &pa, &b.shape, &pb, PERTURB_ANGLE)
    };
    let c = c.map_err(|e| {
        crate::Error::InvalidInput(format!(
            "MCM overlap of particles {i} and {j} (centre distance {:.6}): {e}",
            d.norm()
        ))
    })?;
    if c.gap >= -tol {
        return Ok(None);
    }
    // Contact point of i: its common-normal surface point (r_c,ij of eq. 3.2).
    Ok(Some(Overlap {
        depth: -c.gap,
        normal: c.normal,
        k: c.point_b - c.point_a,
        rc: c.point_a,
        l: 0.0,
    }))
}

/// Overlaps deeper than `tol` of particle i with the particles in `nb` and with the walls
/// (cylinder, wedge): virtual wall particles for spheres and rods, the support-function depth
/// for ellipsoids and superquadrics.
fn overlaps_of(
    p: &Packing,
    props: &[species::Props],
    i: usize,
    nb: &[usize],
    tol: f64,
    out: &mut Vec<Overlap>,
) -> Result<()> {
    out.clear();
    let spc = &p.particles.species;
    let si = &props[spc[i]];
    let xi = p.positions[i];
    if let Some(sa) = &si.sq {
        for &j in nb {
            let sj = &props[spc[j]];
            let d = p.container.separation(&xi, &p.positions[j], p.box_length);
            let (qi, qj) = (&p.orientations[i], &p.orientations[j]);
            if let Some(o) = sq_overlap((i, si, qi), (j, sj, qj), &d, tol)? {
                out.push(o);
            }
        }
        if p.container != Container::Periodic {
            // Walls: the depth of the deepest body point beyond the wall's tangent plane, the
            // mirror-image virtual particle of sec. 2.2.4 generalised to convex bodies
            // (`Container::convex_wall_contacts`).
            let rot = p.orientations[i].to_rotation_matrix();
            let support = |u: &Vector3<f64>| rot * sa.support(&(rot.transpose() * u));
            let mut walls = Vec::new();
            p.container
                .convex_wall_contacts(&xi, si.bound, support, &mut walls);
            for w in walls {
                if w.depth > tol {
                    out.push(Overlap {
                        depth: w.depth,
                        normal: w.normal,
                        // As for solver pairs: point on the wall minus contact point.
                        k: -w.depth * w.normal,
                        rc: w.rc,
                        l: 0.0,
                    });
                }
            }
        }
        return Ok(());
    }
    // Spheres need no axes (pair_geometry ignores them).
    let axis = |j: usize| {
        if props[spc[j]].sphere {
            Vector3::z()
        } else {
            p.axis(j)
        }
    };
    let ai = axis(i);
    // One pair: j's props, axis and separation; `jj` is j's index, None for a virtual wall
    // particle (identical to i, with its own axis, sec. 2.2.4).
    let mut check =
        |d: Vector3<f64>, sj: &species::Props, aj: Vector3<f64>, jj: Option<usize>| -> Result<()> {
            if d.norm_squared() >= pair_cutoff(si, sj).powi(2) {
                return Ok(());
            }
            if let (Some(jj), Some(_)) = (jj, &sj.sq) {
                // A sphere among superquadrics meets a superquadric: the contact solver.
                let (qi, qj) = (&p.orientations[i], &p.orientations[jj]);
                if let Some(o) = sq_overlap((i, si, qi), (jj, sj, qj), &d, tol)? {
                    out.push(o);
                }
                return Ok(());
            }
            let (gap, n, k, rci, li, _, _) =
                pair_geometry((si.r, si.h), (sj.r, sj.h), &ai, &aj, &d);
            if gap < -tol {
                out.push(Overlap {
                    depth: -gap,
                    normal: n,
                    k,
                    rc: rci,
                    l: li,
                });
            }
            Ok(())
        };
    for &j in nb {
        let d = p.container.separation(&xi, &p.positions[j], p.box_length);
        let sj = &props[spc[j]];
        // The axis is needed only within the cutoff (checked again in `check`).
        if d.norm_squared() < pair_cutoff(si, sj).powi(2) {
            check(d, sj, axis(j), Some(j))?;
        }
    }
    if p.container != Container::Periodic {
        let mut virt = Vec::new();
        p.container
            .wall_virtuals(&xi, &p.axis(i), si.h, si.r, &mut virt);
        for (d, a) in virt {
            check(d, si, a, None)?;
        }
    }
    Ok(())
}

/// Lower bound of the surface gap of particles i and j at separation `d` for the neighbour
/// lists: rods by their axis segments, everything else by centre distance minus the pair
/// cutoff (bounding spheres).
fn list_gap_bound(
    props: &[species::Props],
    spc: &[usize],
    p: &Packing,
    i: usize,
    j: usize,
    d: &Vector3<f64>,
) -> f64 {
    let (a, b) = (&props[spc[i]], &props[spc[j]]);
    if a.sq.is_none() && b.sq.is_none() && (a.h > 0.0 || b.h > 0.0) {
        let (ai, aj) = (p.axis(i), p.axis(j));
        let (_, _, pa, pb) =
            closest_points_segments(&(-a.h * ai), &(a.h * ai), &(d - b.h * aj), &(d + b.h * aj));
        (pb - pa).norm() - (a.r + b.r)
    } else {
        d.norm() - (pair_cutoff(a, b) - 1e-6)
    }
}

/// Checks the box and builds the neighbour lists of `p` (skin `max_skin`, less in a small box).
/// Largest neighbour-list skin of the Gauss-Seidel schemes (D): their moves are up to an
/// overlap depth or more, so lists rebuild often with a thin skin.
const GS_SKIN: f64 = 0.3;

fn neighbour_lists(
    p: &Packing,
    props: &[species::Props],
    list_gap: &neighbours::ListGap,
    max_skin: f64,
) -> Result<Neighbours> {
    check_box(&p.container, p.box_length, props)?;
    let cutoff = max_pair_cutoff(props);
    let skin = (0.5 * p.box_length - cutoff).min(max_skin);
    let half: Vec<f64> = p.particles.species.iter().map(|&k| props[k].h).collect();
    Neighbours::new(p, cutoff, skin, half, list_gap)
}

/// Removes overlaps deeper than the tolerance; returns Ok(tries) when the configuration is
/// overlap-free, Err(tries) when the try budget ran out.
///
/// Sweeps over the particles in index order (Gauss-Seidel: each move sees the moves before
/// it); a particle is rechecked only when it or a neighbour moved since it was last found
/// free of overlaps, so an exhausted queue means no pair overlaps deeper than the tolerance.
/// Each move counts as one try.
fn remove_overlaps(
    p: &mut Packing,
    prm: &Setup,
    budget: u64,
) -> Result<std::result::Result<u64, u64>> {
    let props = species::props_of(&p.particles)?;
    remove_overlaps_with(p, &props, prm, budget)
}

/// [`remove_overlaps`] with the species props already computed.
fn remove_overlaps_with(
    p: &mut Packing,
    props: &[species::Props],
    prm: &Setup,
    budget: u64,
) -> Result<std::result::Result<u64, u64>> {
    if prm.scheme == Scheme::Relax {
        return relax::relax_overlaps(p, props, prm, budget);
    }
    let n = p.n();
    let spc = p.particles.species.clone();
    let list_gap =
        |p: &Packing, i: usize, j: usize, d: &Vector3<f64>| list_gap_bound(props, &spc, p, i, j, d);
    let mut nb = neighbour_lists(p, props, &list_gap, GS_SKIN)?;
    let mut dirty = DirtySet::full(n);
    let mut ov = Vec::new();
    let mut tries = 0u64;
    while !dirty.is_empty() {
        // One pass in index order; particles marked behind the current one wait for the next.
        let mut from = 0;
        while let Some(i) = dirty.take_next(from) {
            from = i + 1;
            overlaps_of(p, props, i, &nb.lists[i], prm.overlap_tol, &mut ov)?;
            if ov.is_empty() {
                continue;
            }
            if tries >= budget {
                return Ok(Err(tries));
            }
            tries += 1;
            let body = &props[p.particles.species[i]];
            let (dx, q) = match prm.scheme {
                Scheme::Revised => move_revised(&ov, &p.orientations[i], body, prm),
                Scheme::Original => {
                    move_original(&ov, &p.orientations[i], body.sphere, body.xi, prm)
                }
                Scheme::Relax => unreachable!("the relax scheme moves all particles at once"),
            };
            p.positions[i] = p.container.wrap(&(p.positions[i] + dx), p.box_length);
            if let Some(q) = q {
                p.orientations[i] = UnitQuaternion::new_normalize(*q.quaternion());
            }
            nb.moved(p, i, &list_gap);
            dirty.insert(i);
            for &j in &nb.lists[i] {
                dirty.insert(j);
            }
        }
    }
    Ok(Ok(tries))
}

/// The particles still to be checked, as a bit set (finding the next one costs a word scan
/// instead of a pass over all N flags).
struct DirtySet {
    words: Vec<u64>,
    count: usize,
}

impl DirtySet {
    fn full(n: usize) -> DirtySet {
        let mut words = vec![u64::MAX; n.div_ceil(64)];
        if !n.is_multiple_of(64) {
            *words.last_mut().expect("n > 0") = (1u64 << (n % 64)) - 1;
        }
        DirtySet { words, count: n }
    }
    fn is_empty(&self) -> bool {
        self.count == 0
    }
    fn insert(&mut self, i: usize) {
        let (w, b) = (i / 64, 1u64 << (i % 64));
        if self.words[w] & b == 0 {
            self.words[w] |= b;
            self.count += 1;
        }
    }
    /// Removes and returns the smallest member at or after `from`.
    fn take_next(&mut self, from: usize) -> Option<usize> {
        let mut w = from / 64;
        if w >= self.words.len() {
            return None;
        }
        let mut bits = self.words[w] & (u64::MAX << (from % 64));
        loop {
            if bits != 0 {
                let i = w * 64 + bits.trailing_zeros() as usize;
                self.words[w] &= !(1u64 << (i % 64));
                self.count -= 1;
                return Some(i);
            }
            w += 1;
            if w >= self.words.len() {
                return None;
            }
            bits = self.words[w];
        }
    }
}

/// A random overlap-free start in the periodic cubic box (see [`random_start_in`]).
pub fn random_start(n: usize, length: f64, phi0: f64, seed: u64) -> Result<Packing> {
    random_start_in(Container::Periodic, n, length, phi0, seed)
}

/// A random overlap-free start of `n` equal particles of cylinder length `length` (see
/// [`random_start_of`]).
pub fn random_start_in(
    container: Container,
    n: usize,
    length: f64,
    phi0: f64,
    seed: u64,
) -> Result<Packing> {
    random_start_of(
        container,
        ParticleShapes::monodisperse(n, length),
        phi0,
        seed,
    )
}

/// A random overlap-free start: random sequential addition of the particles at packing
/// fraction phi0, uniform positions (in the cylinder: uniform over the disk, rejected when an
/// end point penetrates the wall) and orientations (ChaCha8 seeded with `seed`). Particles are
/// placed in order of decreasing bounding radius (index order among equals), so the large
/// ones of a mixture find room first. From 5000 particles on, the particles (positions,
/// orientations, species) are then renumbered along a Z-order curve
/// (`Z_ORDER_MIN_PARTICLES`).
pub fn random_start_of(
    container: Container,
    particles: ParticleShapes,
    phi0: f64,
    seed: u64,
) -> Result<Packing> {
    let p = random_sequential_addition(container, particles, phi0, seed)?;
    if p.n() >= Z_ORDER_MIN_PARTICLES {
        return Ok(p.renumbered(&relax::z_order(&p.positions)));
    }
    Ok(p)
}

/// The placement of [`random_start_of`], in the caller's numbering.
fn random_sequential_addition(
    container: Container,
    particles: ParticleShapes,
    phi0: f64,
    seed: u64,
) -> Result<Packing> {
    particles.validate()?;
    let n = particles.n();
    let props = species::props_of(&particles)?;
    let box_length = container.length_for_volume(particles.total_volume()? / phi0);
    check_box(&container, box_length, &props)?;
    let mut order: Vec<usize> = (0..n).collect();
    let bound = |i: usize| props[particles.species[i]].bound;
    order.sort_by(|&a, &b| bound(b).total_cmp(&bound(a)));
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut p = Packing {
        container,
        box_length,
        particles,
        positions: vec![Vector3::zeros(); n],
        orientations: vec![UnitQuaternion::identity(); n],
    };
    let max_attempts = 1000 * n as u64 + 1000;
    let mut attempts = 0u64;
    let mut placed: Vec<usize> = Vec::with_capacity(n);
    // The placed particles in a cell grid (grid index k = placed[k]) of edge above the largest
    // pair cutoff: a trial is checked against the particles in the 27 cells around it, in
    // the order they were placed, which is the order and outcome of a scan over all placed
    // particles (the others are beyond the cutoff and skipped by it), without its N^2/2 cost
    // (0.9 s of a 10000-sphere run, 2%).
    let mut grid = Grid::new(
        &container,
        box_length,
        max_pair_cutoff(&props) * (1.0 + 1e-9),
        &[],
    );
    let mut near: Vec<usize> = Vec::new();
    while placed.len() < n {
        attempts += 1;
        if attempts > max_attempts {
            return invalid(format!(
                "phi0 = {phi0}: random sequential addition placed only {} of {n} particles in \
                 {max_attempts} attempts; lower phi0",
                placed.len()
            ));
        }
        let i = order[placed.len()];
        let si = &props[p.particles.species[i]];
        let u = Vector3::new(rng.gen::<f64>(), rng.gen::<f64>(), rng.gen::<f64>());
        // Rods: both end spheres inside; superquadrics: the bounding sphere.
        let rad = if si.sq.is_some() { si.bound } else { si.r };
        let x = container.trial_centre(&u, box_length, rad);
        // Uniform random rotation (Shoemake's method).
        let (u1, u2, u3): (f64, f64, f64) = (rng.gen(), rng.gen(), rng.gen());
        let tau = std::f64::consts::TAU;
        let q = UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
            (1.0 - u1).sqrt() * (tau * u2).cos(),
            (1.0 - u1).sqrt() * (tau * u2).sin(),
            u1.sqrt() * (tau * u3).sin(),
            u1.sqrt() * (tau * u3).cos(),
        ));
        let a = q * Vector3::z();
        let inside = [-si.h, si.h]
            .iter()
            .all(|s| container.sphere_inside(&(x + *s * a), rad));
        if !inside {
            continue;
        }
        near.clear();
        grid.for_each_near(&x, |k| near.push(k));
        near.sort_unstable();
        let mut ok = true;
        for j in near.iter().map(|&k| placed[k]) {
            let sj = &props[p.particles.species[j]];
            let d = container.separation(&x, &p.positions[j], box_length);
            if d.norm_squared() >= pair_cutoff(si, sj).powi(2) {
                continue;
            }
            let free = if si.sq.is_some() || sj.sq.is_some() {
                // Any overlap (tolerance 0) rejects the trial.
                sq_overlap((i, si, &q), (j, sj, &p.orientations[j]), &d, 0.0)?.is_none()
            } else {
                pair_geometry((si.r, si.h), (sj.r, sj.h), &a, &p.axis(j), &d).0 > 0.0
            };
            if !free {
                ok = false;
                break;
            }
        }
        if ok {
            p.positions[i] = x;
            p.orientations[i] = q;
            grid.push(&x);
            placed.push(i);
        }
    }
    Ok(p)
}

/// Smallest random start whose particles are renumbered along a Z-order curve of their
/// positions (`relax::z_order`), so that the Gauss-Seidel sweeps of the overlap removal, which
/// follow the index order, and every neighbour list read nearby memory; the compression
/// scales positions and keeps the order coherent. The relaxation renumbers its own copy at
/// every step already. Built-in sphere scene, seed 1, one thread, ns of CPU per move without
/// / with the renumbering (measured in one run; the trajectories differ, so the moves do too):
/// N = 1000 133, 133 / 141, 136; 2000 143, 139 / 138, 135; 5000 145, 152 / 138, 140; 10000
/// 150, 147 / 142, 146; 20000 164 / 139 (101.1 against 86.3 CPU s). Without it the cost of a
/// move grows with N as the arrays outgrow the cache; with it the cost is flat. Below 5000
/// it gains nothing measurable, and every validation case (N <= 2000) keeps its packings.
const Z_ORDER_MIN_PARTICLES: usize = 5000;

/// Compresses `p` by `dv`, orientations kept: the cubic box to side (L^3 - dv)^(1/3) with all
/// coordinates scaled; the cylinder to length L - dv / (pi R_cyl^2) with z scaled (its
/// diameter is fixed, sec. 2.2.4).
fn compress(p: &Packing, dv: f64) -> Option<Packing> {
    let v = p.container.volume(p.box_length) - dv;
    if v <= 0.0 {
        return None;
    }
    let l = p.container.length_for_volume(v);
    let mut q = p.clone();
    q.box_length = l;
    for x in q.positions.iter_mut() {
        *x = p.container.scale_position(x, p.box_length, l);
    }
    Some(q)
}

mod container;
pub mod driver;
mod engine;
pub mod measure;
mod neighbours;
mod relax;
mod setup;
mod species;
pub use driver::{run_from, run_to_end};
pub use engine::{Mcm, McmResult, McmState, StepOutcome};
pub use setup::{Scheme, Setup, Stage};
pub use species::ParticleShapes;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_walls;
