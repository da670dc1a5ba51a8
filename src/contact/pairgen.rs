//! Random pairs of posed superquadrics with a prescribed signed gap, built from the closed
//! forms of the surface only (thesis 003 eq. 4.5 parametric point, eq. 4.6 normal), never
//! from a contact solver: used by the validation cases 303/304 and tests/stress_contact.rs.
//!
//! Construction: a surface point s_a of A at random parameters (u, v) with unit normal n
//! (world, after a random rotation R_a); a surface point s_b of B at random parameters with
//! normal m_b, and R_b a rotation taking m_b onto -n, twisted by a random angle about -n;
//! x_b = x_a + R_a s_a + delta n - R_b s_b. The tangent planes at the two points are then
//! parallel at distance delta with the bodies on opposite sides, so for delta > 0 the bodies
//! are apart with distance exactly delta (the plane separates them and the pair realises
//! it), and for delta < 0 they overlap (each point lies strictly inside the other body,
//! both bodies being strictly convex) and (p_a, p_b) is a common-normal pair with k.n = delta.

use super::Pose;
use nalgebra::{Unit, UnitQuaternion, Vector3};
use rand::Rng;
use std::f64::consts::PI;

/// A generated pair.
#[derive(Debug, Clone)]
pub struct GenPair {
    pub axes_a: [f64; 3],
    pub exps_a: [f64; 3],
    pub pose_a: Pose,
    pub axes_b: [f64; 3],
    pub exps_b: [f64; 3],
    pub pose_b: Pose,
    /// Prescribed signed gap.
    pub gap: f64,
    /// Prescribed normal (from a to b) and contact points (world).
    pub normal: Vector3<f64>,
    pub point_a: Vector3<f64>,
    pub point_b: Vector3<f64>,
}

/// Eq. 4.5 surface point at parameters (u, v).
pub fn parametric_point(a: &[f64; 3], g: &[f64; 3], u: f64, v: f64) -> Vector3<f64> {
    let sp = |c: f64, e: f64| c.signum() * c.abs().powf(e);
    let e: Vec<f64> = g.iter().map(|x| 2.0 / x).collect();
    Vector3::new(
        a[0] * sp(v.cos(), e[0]) * sp(u.cos(), e[0]),
        a[1] * sp(v.cos(), e[1]) * sp(u.sin(), e[1]),
        a[2] * sp(v.sin(), e[2]),
    )
}

/// Eq. 4.6 unit normal at x.
pub fn normal_at(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::from_fn(|k, _| g[k] / a[k] * x[k].signum() * (x[k] / a[k]).abs().powf(g[k] - 1.0))
        .normalize()
}

/// Uniform random rotation (normalised Gaussian quaternion).
pub fn random_rotation<R: Rng>(rng: &mut R) -> UnitQuaternion<f64> {
    use rand::distributions::Distribution;
    let n = rand_distr_normal();
    let q = nalgebra::Quaternion::new(n.sample(rng), n.sample(rng), n.sample(rng), n.sample(rng));
    UnitQuaternion::from_quaternion(q)
}

/// Standard normal by Box-Muller (no extra dependency).
struct Normal01;
impl rand::distributions::Distribution<f64> for Normal01 {
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        let u1: f64 = 1.0 - rng.gen::<f64>();
        let u2: f64 = rng.gen();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
}
fn rand_distr_normal() -> Normal01 {
    Normal01
}

/// Random surface parameters, avoiding exact zeros of cos/sin (a coordinate exactly 0 is
/// fine for the geometry but makes the rotation of B degenerate only in measure zero).
fn random_uv<R: Rng>(rng: &mut R) -> (f64, f64) {
    (rng.gen_range(-PI..PI), rng.gen_range(-0.5 * PI..0.5 * PI))
}

/// The smallest semi-axis of two bodies with semi-axes `aa` and `ab` (the size near-contact
/// gaps are measured in).
pub fn min_semi_axis(aa: &[f64; 3], ab: &[f64; 3]) -> f64 {
    aa.iter()
        .chain(ab.iter())
        .cloned()
        .fold(f64::INFINITY, f64::min)
}

/// A near-contact gap for bodies with semi-axes `aa` and `ab`: magnitude
/// 10^U(`log10_mag`) times [`min_semi_axis`], sign + or - with probability 1/2. Returns
/// (size, magnitude, signed gap).
pub fn random_signed_gap<R: Rng>(
    rng: &mut R,
    aa: &[f64; 3],
    ab: &[f64; 3],
    log10_mag: std::ops::Range<f64>,
) -> (f64, f64, f64) {
    let size = min_semi_axis(aa, ab);
    let mag = 10f64.powf(rng.gen_range(log10_mag)) * size;
    let delta = if rng.gen_bool(0.5) { mag } else { -mag };
    (size, mag, delta)
}

/// Builds a pair with prescribed signed gap `delta` (see the module doc).
pub fn make_pair<R: Rng>(
    rng: &mut R,
    axes_a: [f64; 3],
    exps_a: [f64; 3],
    axes_b: [f64; 3],
    exps_b: [f64; 3],
    delta: f64,
    position_scale: f64,
) -> GenPair {
    let ra = random_rotation(rng);
    let xa = Vector3::new(
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
    ) * position_scale;
    let (u, v) = random_uv(rng);
    let sa = parametric_point(&axes_a, &exps_a, u, v);
    let n = ra * normal_at(&axes_a, &exps_a, &sa);
    let (u, v) = random_uv(rng);
    let sb = parametric_point(&axes_b, &exps_b, u, v);
    let mb = normal_at(&axes_b, &exps_b, &sb);
    let align = UnitQuaternion::rotation_between(&mb, &(-n)).unwrap_or_else(|| {
        // mb = n exactly: rotate by pi about any axis perpendicular to mb
        let perp = if mb.x.abs() < 0.9 {
            mb.cross(&Vector3::x())
        } else {
            mb.cross(&Vector3::y())
        };
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(perp), PI)
    });
    let twist = UnitQuaternion::from_axis_angle(&Unit::new_normalize(-n), rng.gen_range(-PI..PI));
    let rb = twist * align;
    let pa = xa + ra * sa;
    let pb = pa + delta * n;
    let xb = pb - rb * sb;
    GenPair {
        axes_a,
        exps_a,
        pose_a: Pose::new(xa, ra),
        axes_b,
        exps_b,
        pose_b: Pose::new(xb, rb),
        gap: delta,
        normal: n,
        point_a: pa,
        point_b: pb,
    }
}
