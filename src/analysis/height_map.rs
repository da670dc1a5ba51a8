//! The top surface of a layer of posed ellipsoids on a substrate: the height of the highest
//! particle point above each node of a square grid (exact per ellipsoid), its RMS roughness,
//! and the coverage of the substrate by the first layer (seed 000, "surface micro-roughness").
//!
//! Above a node at horizontal offset (dx, dy) from a centre, the surface x^T M x = 1 gives
//! M_zz t^2 + 2 t (M_xz dx + M_yz dy) + (M_xx dx^2 + 2 M_xy dx dy + M_yy dy^2 - 1) = 0 for the
//! height t above the centre; the larger root is the top, where the discriminant is >= 0.
//! A node no particle covers has height 0 (the substrate). The box is periodic in x and y.

use super::slab::PosedEllipsoid;
use crate::error::{invalid, Result};
use nalgebra::Matrix3;

/// Heights on an n x n grid of nodes at (i + 1/2, j + 1/2) L / n, m.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMap {
    pub box_side_m: f64,
    pub n: usize,
    pub heights_m: Vec<f64>,
    /// Node covered by a particle that touches the substrate (first-layer coverage).
    pub first_layer: Vec<bool>,
}

/// The height map of `particles` in the periodic square of side `box_side_m` on `n` x `n`
/// nodes; a particle whose lowest point is below `touch_m` counts as touching the substrate.
pub fn height_map(
    particles: &[PosedEllipsoid],
    box_side_m: f64,
    n: usize,
    touch_m: f64,
) -> Result<HeightMap> {
    if n == 0 || n > 20_000 {
        return invalid(format!(
            "height map of {n} x {n} nodes: must be 1 to 20000 per side"
        ));
    }
    let l = box_side_m;
    let dx = l / n as f64;
    let mut heights = vec![0.0f64; n * n];
    let mut first = vec![false; n * n];
    for p in particles {
        let r = p.orientation.to_rotation_matrix().into_inner();
        let [a, b, c] = p.semi_axes;
        let d = Matrix3::from_diagonal(&nalgebra::Vector3::new(
            1.0 / (a * a),
            1.0 / (b * b),
            1.0 / (c * c),
        ));
        let m = r * d * r.transpose();
        let dinv = Matrix3::from_diagonal(&nalgebra::Vector3::new(a * a, b * b, c * c));
        let minv = r * dinv * r.transpose();
        // Horizontal extents of the projection: sqrt((M^-1)_xx), sqrt((M^-1)_yy).
        let (ex, ey) = (minv[(0, 0)].sqrt(), minv[(1, 1)].sqrt());
        let touches = p.position.z - minv[(2, 2)].sqrt() < touch_m;
        let i0 = ((p.position.x - ex) / dx - 0.5).ceil() as i64;
        let i1 = ((p.position.x + ex) / dx - 0.5).floor() as i64;
        let j0 = ((p.position.y - ey) / dx - 0.5).ceil() as i64;
        let j1 = ((p.position.y + ey) / dx - 0.5).floor() as i64;
        for j in j0..=j1 {
            let oy = (j as f64 + 0.5) * dx - p.position.y;
            let jj = j.rem_euclid(n as i64) as usize;
            for i in i0..=i1 {
                let ox = (i as f64 + 0.5) * dx - p.position.x;
                let bq = m[(0, 2)] * ox + m[(1, 2)] * oy;
                let cq =
                    m[(0, 0)] * ox * ox + 2.0 * m[(0, 1)] * ox * oy + m[(1, 1)] * oy * oy - 1.0;
                let disc = bq * bq - m[(2, 2)] * cq;
                if disc < 0.0 {
                    continue;
                }
                let top = p.position.z + (-bq + disc.sqrt()) / m[(2, 2)];
                let k = jj * n + i.rem_euclid(n as i64) as usize;
                if top > heights[k] {
                    heights[k] = top;
                }
                if touches {
                    first[k] = true;
                }
            }
        }
    }
    Ok(HeightMap {
        box_side_m,
        n,
        heights_m: heights,
        first_layer: first,
    })
}

impl HeightMap {
    /// Mean height of the top surface, m.
    pub fn mean_m(&self) -> f64 {
        self.heights_m.iter().sum::<f64>() / self.heights_m.len() as f64
    }

    /// RMS deviation of the height from its mean, m.
    pub fn rms_roughness_m(&self) -> f64 {
        let mean = self.mean_m();
        let var = self
            .heights_m
            .iter()
            .map(|h| (h - mean) * (h - mean))
            .sum::<f64>()
            / self.heights_m.len() as f64;
        var.sqrt()
    }

    /// Fraction of the nodes covered by a particle touching the substrate.
    pub fn first_layer_coverage(&self) -> f64 {
        self.first_layer.iter().filter(|&&b| b).count() as f64 / self.first_layer.len() as f64
    }
}

/// Nematic-type order of unit axes against z: S = <(3 (e.z)^2 - 1) / 2> (1: all vertical,
/// -1/2: all horizontal, 0: isotropic). None for no axes.
pub fn order_against_z(axes_z: impl Iterator<Item = f64>) -> Option<f64> {
    let (mut s, mut k) = (0.0, 0usize);
    for ez in axes_z {
        s += 1.5 * ez * ez - 0.5;
        k += 1;
    }
    (k > 0).then(|| s / k as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn a_single_sphere_gives_its_cap_heights() {
        let s = PosedEllipsoid {
            semi_axes: [1.0; 3],
            position: Vector3::new(5.0, 5.0, 1.0),
            orientation: UnitQuaternion::from_euler_angles(0.2, 0.3, 0.4),
        };
        let hm = height_map(&[s], 10.0, 100, 1e-9).unwrap();
        let k = 50 * 100 + 50; // node (5.05, 5.05)
        let rho2 = 2.0 * 0.05f64.powi(2);
        assert!((hm.heights_m[k] - (1.0 + (1.0 - rho2).sqrt())).abs() < 1e-12);
        let covered = hm.first_layer.iter().filter(|&&b| b).count();
        // pi r^2 / node area = pi / 0.01 = 314 nodes, to within the boundary nodes.
        assert!((covered as f64 - 314.16).abs() < 20.0);
    }
}
