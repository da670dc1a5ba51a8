//! Sphere-ellipsoid contact through the distance from the sphere centre to the ellipsoid
//! surface.
//!
//! The closest surface point of the ellipsoid sum (x_k/a_k)^2 = 1 to a point p (body frame)
//! is x_k = a_k^2 p_k / (a_k^2 + t), where t is the root of the decreasing function
//! f(t) = sum (a_k p_k / (a_k^2 + t))^2 - 1: t > 0 outside, t in (-a_min^2, 0) inside
//! (Eberly, "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", 2013).
//! The root is bracketed and found by bisection (exact to rounding, no divergence); the
//! degenerate interior case (p on the shortest axis' plane, no root) takes t = -a_min^2.

use super::{Contact, Pose};
use nalgebra::Vector3;

/// Closest surface point of the ellipsoid with semi-axes `a` (body frame) to `p`, and
/// whether p is strictly inside.
pub fn closest_point_ellipsoid(p: &Vector3<f64>, a: &[f64; 3]) -> (Vector3<f64>, bool) {
    let f = |t: f64| -> f64 {
        (0..3)
            .map(|k| {
                let v = a[k] * p[k] / (a[k] * a[k] + t);
                v * v
            })
            .sum::<f64>()
            - 1.0
    };
    let f0 = f(0.0);
    let inside = f0 < 0.0;
    if f0 == 0.0 {
        return (*p, false);
    }
    let point_of = |t: f64| Vector3::from_fn(|k, _| a[k] * a[k] * p[k] / (a[k] * a[k] + t));
    let (mut lo, mut hi);
    if !inside {
        lo = 0.0;
        let amax = a.iter().cloned().fold(0.0, f64::max);
        hi = amax * super::norm_no_overflow(p);
    } else {
        let m = (0..3)
            .min_by(|&i, &j| a[i].partial_cmp(&a[j]).unwrap())
            .unwrap();
        let amin2 = a[m] * a[m];
        // Axes sharing the smallest semi-axis.
        let pm2: f64 = (0..3).filter(|&k| a[k] == a[m]).map(|k| p[k] * p[k]).sum();
        if pm2 == 0.0 {
            // No pole at -amin^2: if f stays negative up to it, the closest point is
            // x_k = a_k^2 p_k/(a_k^2 - amin^2) off the shortest axes, completed on them.
            let g: f64 = (0..3)
                .filter(|&k| a[k] != a[m])
                .map(|k| {
                    let v = a[k] * p[k] / (a[k] * a[k] - amin2);
                    v * v
                })
                .sum::<f64>()
                - 1.0;
            if g <= 0.0 {
                let mut x = Vector3::zeros();
                for k in 0..3 {
                    if a[k] != a[m] {
                        x[k] = a[k] * a[k] * p[k] / (a[k] * a[k] - amin2);
                    }
                }
                // Put the remainder on the first shortest axis.
                x[m] = a[m] * (-g).sqrt();
                return (x, true);
            }
        }
        lo = -amin2;
        hi = 0.0;
    }
    // Bisection on (lo, hi): f(lo) > 0 > f(hi) (or the pole at lo).
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let t = 0.5 * (lo + hi);
    (point_of(t), inside)
}

/// Contact of a sphere (centre `c`, radius `r`) with an ellipsoid (pose `pb`, semi-axes
/// `axes`). The normal is minus the ellipsoid's outward normal at its closest point; a
/// centre exactly at the ellipsoid's centre takes the shortest axis.
pub fn contact_sphere_ellipsoid(c: &Vector3<f64>, r: f64, pb: &Pose, axes: [f64; 3]) -> Contact {
    let p = pb.to_local(c);
    let (x, inside) = closest_point_ellipsoid(&p, &axes);
    let nu_local = Vector3::new(
        x.x / (axes[0] * axes[0]),
        x.y / (axes[1] * axes[1]),
        x.z / (axes[2] * axes[2]),
    );
    let nu = pb.orientation * nu_local.normalize();
    let normal = -nu;
    let dist = super::norm_no_overflow(&(x - p));
    let gap = if inside { -dist - r } else { dist - r };
    Contact {
        point_a: c + r * normal,
        point_b: pb.to_world(&x),
        normal,
        gap,
        method: "point-ellipsoid-distance",
        pw_scale: None,
    }
}
