//! Sphere-spherocylinder contact: closest point of the axis segment to the sphere centre.

use super::{Contact, Pose};
use nalgebra::Vector3;

/// Closest point to `p` on the segment from `s0` to `s1`.
pub fn closest_point_segment(
    p: &Vector3<f64>,
    s0: &Vector3<f64>,
    s1: &Vector3<f64>,
) -> Vector3<f64> {
    let d = s1 - s0;
    let dd = d.norm_squared();
    if dd == 0.0 {
        return *s0;
    }
    let t = ((p - s0).dot(&d) / dd).clamp(0.0, 1.0);
    s0 + t * d
}

/// Contact of a sphere (centre `c`, radius `r`) with a spherocylinder (pose `pb`, radius
/// `rb`, length `lb` between hemisphere centres along its body z axis). A centre on the axis
/// has no defined normal: a direction perpendicular to the axis is returned.
pub fn contact_sphere_spherocylinder(
    c: &Vector3<f64>,
    r: f64,
    pb: &Pose,
    rb: f64,
    lb: f64,
) -> Contact {
    let u = pb.axis_z();
    let s0 = pb.position - 0.5 * lb * u;
    let s1 = pb.position + 0.5 * lb * u;
    let q = closest_point_segment(c, &s0, &s1);
    let d = q - c;
    let dist = super::norm_no_overflow(&d);
    let normal = if dist > 0.0 {
        d / dist
    } else {
        super::contact_spherocylinder_spherocylinder::any_perpendicular(&u)
    };
    Contact {
        point_a: c + r * normal,
        point_b: q - rb * normal,
        normal,
        gap: dist - r - rb,
        method: "sphere-spherocylinder",
        pw_scale: None,
    }
}
