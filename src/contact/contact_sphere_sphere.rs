//! Sphere-sphere contact (closed form).

use super::Contact;
use nalgebra::Vector3;

/// Contact of spheres (centre `ca`, radius `ra`) and (`cb`, `rb`): gap = |cb - ca| - ra - rb,
/// normal (cb - ca)/|cb - ca|. Concentric spheres have no defined normal: +z is returned.
pub fn contact_sphere_sphere(ca: &Vector3<f64>, ra: f64, cb: &Vector3<f64>, rb: f64) -> Contact {
    let d = cb - ca;
    let dist = super::norm_no_overflow(&d);
    let normal = if dist > 0.0 { d / dist } else { Vector3::z() };
    Contact {
        point_a: ca + ra * normal,
        point_b: cb - rb * normal,
        normal,
        gap: dist - ra - rb,
        method: "sphere-sphere",
        pw_scale: None,
    }
}
