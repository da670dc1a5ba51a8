//! Spherocylinder-spherocylinder contact by the closest points of the two axis segments
//! (Vega & Lago, Comput. Chem. 18, 55 (1994), thesis 003 refs. 25-26; the clamping follows
//! the same minimisation of |P(s) - Q(t)|^2 over the unit square).
//!
//! Parallel and nearly parallel segments: exactly parallel segments whose projections overlap
//! take the closest points at the middle of the overlap (symmetric under swapping the pair);
//! otherwise the unconstrained minimum is clamped to [0, 1] and the other parameter recomputed
//! and clamped (exact for the convex quadratic on the square), and for nearly parallel axes
//! (sin^2 < 1e-6, where that solution loses digits as eps / sin^2) the best of it and the four
//! endpoint-to-segment candidates is taken (each is well conditioned; the minimum of the
//! convex distance over the square lies on one of them).

use super::{Contact, Pose};
use nalgebra::Vector3;

/// A unit vector perpendicular to `u` (unit).
pub fn any_perpendicular(u: &Vector3<f64>) -> Vector3<f64> {
    let e = if u.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    u.cross(&e).normalize()
}

/// Closest points between segments [p0, p1] and [q0, q1]: returns (s, t, P, Q) with
/// P = p0 + s (p1 - p0), Q = q0 + t (q1 - q0), s, t in [0, 1].
pub fn closest_points_segments(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64, Vector3<f64>, Vector3<f64>) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    let at = |s: f64, t: f64| (s, t, p0 + s * d1, q0 + t * d2);
    if a == 0.0 && e == 0.0 {
        return at(0.0, 0.0);
    }
    if a == 0.0 {
        return at(0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e == 0.0 {
        return at((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(&d2);
    // sin^2 of the angle between the axes, from the cross product (no cancellation).
    let sin2 = d1.cross(&d2).norm_squared() / (a * e);
    if sin2 == 0.0 {
        // Parallel: project q0, q1 onto the line of p, in units of s.
        let sq0 = -c / a; // (q0 - p0).d1 / a
        let sq1 = sq0 + b / a;
        let (lo, hi) = (sq0.min(sq1).max(0.0), sq0.max(sq1).min(1.0));
        let s = if lo <= hi {
            0.5 * (lo + hi)
        } else if sq0.max(sq1) < 0.0 {
            0.0
        } else {
            1.0
        };
        let t = ((p0 + s * d1 - q0).dot(&d2) / e).clamp(0.0, 1.0);
        let s = ((q0 + t * d2 - p0).dot(&d1) / a).clamp(0.0, 1.0);
        return at(s, t);
    }
    let denom = a * e - b * b;
    let mut s = if denom > 0.0 {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    let mut best = at(s, t);
    if sin2 < 1e-6 {
        // Nearly parallel: the interior solution is ill-conditioned (denom has relative
        // error eps / sin^2); the minimum then lies at an endpoint of one segment unless the
        // interior one is better, so take the best of the four endpoint-to-segment
        // candidates (each well conditioned) and the interior one.
        let mut d_best = (best.3 - best.2).norm_squared();
        let t_of = |p: Vector3<f64>| ((p - q0).dot(&d2) / e).clamp(0.0, 1.0);
        let s_of = |q: Vector3<f64>| ((q - p0).dot(&d1) / a).clamp(0.0, 1.0);
        for cand in [
            (0.0, t_of(*p0)),
            (1.0, t_of(*p1)),
            (s_of(*q0), 0.0),
            (s_of(*q1), 1.0),
        ] {
            let r = at(cand.0, cand.1);
            let d = (r.3 - r.2).norm_squared();
            if d < d_best || d_best.is_nan() {
                d_best = d;
                best = r;
            }
        }
    }
    best
}

/// Contact of two spherocylinders (pose, radius, length between hemisphere centres along the
/// body z axis). Intersecting axes have no defined normal: the normalised cross product of
/// the axes is returned (any perpendicular for coincident parallel axes), oriented from a to b
/// where the centres differ along it.
pub fn contact_spherocylinder_spherocylinder(
    pa: &Pose,
    ra: f64,
    la: f64,
    pb: &Pose,
    rb: f64,
    lb: f64,
) -> Contact {
    let ua = pa.axis_z();
    let ub = pb.axis_z();
    let (p0, p1) = (pa.position - 0.5 * la * ua, pa.position + 0.5 * la * ua);
    let (q0, q1) = (pb.position - 0.5 * lb * ub, pb.position + 0.5 * lb * ub);
    let (_, _, p, q) = closest_points_segments(&p0, &p1, &q0, &q1);
    let d = q - p;
    let dist = super::norm_no_overflow(&d);
    let normal = if dist > 0.0 {
        d / dist
    } else {
        let c = ua.cross(&ub);
        let mut n = if c.norm() > 1e-12 {
            c.normalize()
        } else {
            any_perpendicular(&ua)
        };
        if n.dot(&(pb.position - pa.position)) < 0.0 {
            n = -n;
        }
        n
    };
    Contact {
        point_a: p + ra * normal,
        point_b: q - rb * normal,
        normal,
        gap: dist - ra - rb,
        method: "segment-closest-points",
        pw_scale: None,
    }
}
