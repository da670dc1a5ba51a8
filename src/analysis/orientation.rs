//! Orientation observables: the wall-aligned fraction near a container wall and the histogram
//! of axis directions (thesis sec. 2.2.5).

use super::Configuration;
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;

/// Fraction of wall-aligned particles (thesis sec. 2.2.5, Fig. 2.6, 2.14): among the particles
/// whose centre lies within `layer` of a wall (the thesis takes `layer` = D), the fraction
/// whose axis is tangential to that wall within `max_angle` radians, i.e. |u . n| <=
/// sin(max_angle) with n the wall normal (thesis: 4 degrees). Cylinder: radial position above
/// R_cyl - `layer`, n the radial unit vector. Wedge: within `layer` of the back, bottom or
/// slope plane; a particle near two planes (a corner) counts as aligned when it is tangential
/// to either. Returns (fraction, particles in the layer); the fraction is 0 for an empty
/// layer. Errors without a wall.
pub fn wall_aligned_fraction(
    c: &Configuration,
    layer: f64,
    max_angle: f64,
) -> Result<(f64, usize)> {
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
