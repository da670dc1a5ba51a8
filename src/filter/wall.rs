//! No slip on the exact fibre surfaces. The carrier flow lives on a lattice: its voxels are solid
//! where their centre is inside a fibre, and the trilinear interpolation between voxel centres
//! ([`VelocityLattice::at`]) vanishes on that staircase, up to half a voxel off the exact
//! cylinders on which the particles are captured. At a few voxels per fibre diameter the
//! interpolated flow neither vanishes on the exact surface nor keeps its normal part zero there,
//! so it carries particles into the fibres by itself: an interception that does not depend on
//! the speed and swamps the magnetic and Brownian capture (case 950's bed: 83 % of the particles
//! captured with no field and no noise).
//!
//! The scheme: within a wall layer of thickness delta (about one voxel) around the exact
//! surfaces, with d the exact distance from the point p to the nearest fibre surface and n its
//! outward normal ([`FibreBed::nearest_surface`]), the flow is taken at the point
//! q = p + (delta - d) n, the layer's outer edge on the same normal, and written
//!
//!   u(p) = (d / delta) u_t(q) + (d / delta)^2 u_n(q) n,   u_n = u . n,  u_t = u - u_n n,
//!
//! the leading terms of a no-slip flow's Taylor expansion at a rigid wall: the tangential
//! velocity grows linearly with the distance (the wall shear, Leveque's approximation of the
//! concentration boundary layer, M. A. Leveque, Ann. Mines 13, 201 (1928); case 454's oracle),
//! and the normal velocity quadratically, because div u = 0 and u vanishes on the wall give
//! du_n/dn = 0 there. The layer's edge values fix the two coefficients, so u is continuous at
//! d = delta and the flow outside the layer is the lattice's, unchanged (a run whose particles
//! never come within delta of a fibre keeps its bytes). On the surface u = 0, and the flux that
//! the flow carries through the surface d = a of a particle of radius a is the edge's times
//! (a / delta)^2: interception, of order (a / delta)^2, is all the flow captures. The nearest
//! fibre alone sets d and n: where two fibres are about equally near (a contact between them)
//! the flow is continuous only up to that choice. Measured: no capture by the flow alone in a
//! loose bed (the scene's test), but some in a packed bed of touching fibres, falling with the
//! voxel (benches/RESULTS.md, filter; not yet explained).
//!
//! Stepping: the flow alone must not carry a particle across the surface in one explicit step,
//! so a step whose flow displacement towards the wall exceeds half the distance is shortened
//! ([`Wall::max_approach_m`]); with u_n ~ d^2 that limit is only reached far from the wall and
//! at long steps.

use super::bed::FibreBed;
use super::flow::VelocityLattice;
use nalgebra::Vector3;

/// Where the flow was corrected: the particle's distance to the nearest fibre surface and the
/// flow's speed towards it (m/s, >= 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    pub distance_m: f64,
    pub approach_m_s: f64,
}

impl Wall {
    /// The largest displacement towards the wall the flow may make in one step (m).
    pub fn max_approach_m(&self) -> f64 {
        0.5 * self.distance_m
    }
}

/// The carrier flow at `p` (m/s) with no slip on the exact fibre surfaces of `bed` within its
/// wall layer ([`FibreBed::with_wall_layer`]; none: the lattice's interpolation), and the wall
/// when `p` is inside the layer.
pub fn no_slip_flow(
    flow: &VelocityLattice,
    bed: &FibreBed,
    p: &Vector3<f64>,
) -> (Vector3<f64>, Option<Wall>) {
    let delta = bed.wall_layer_m();
    let surface = if delta > 0.0 {
        bed.nearest_surface(p)
    } else {
        None
    };
    let Some(s) = surface else {
        return (flow.at(p), None);
    };
    let d = s.distance_m.max(0.0);
    let n = s.normal;
    let edge = flow.at(&(p + n * (delta - d)));
    let normal = edge.dot(&n);
    let tangential = edge - n * normal;
    let f = d / delta;
    let u = tangential * f + n * (normal * f * f);
    let wall = Wall {
        distance_m: d,
        approach_m_s: (-u.dot(&n)).max(0.0),
    };
    (u, Some(wall))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CELL: [f64; 3] = [1e-3, 1e-3, 1e-3];
    const R: f64 = 1e-4;
    const H: f64 = CELL[0] / 40.0;

    /// One fibre along x through the cell's centre (spanning it: with its images an infinite
    /// wire), the wall layer one voxel.
    fn wire_bed() -> FibreBed {
        let c = Vector3::new(0.5e-3, 0.5e-3, 0.5e-3);
        FibreBed::new(CELL, R, 0.6e-3, &[c], &[Vector3::x()], 1e-8)
            .unwrap()
            .with_wall_layer(H)
            .unwrap()
    }

    /// A smooth known field that does not vanish on the wire (a uniform flow along z plus a
    /// shear), sampled on 40^3 voxels.
    fn known_flow() -> VelocityLattice {
        VelocityLattice::from_fn([40; 3], H, |p| {
            Vector3::new(2e-4 * (p.z / CELL[2]), 1e-4, 1e-3)
        })
        .unwrap()
    }

    /// On the exact surface the corrected flow is zero; beyond the layer it is the lattice's
    /// interpolation bit for bit; inside, the tangential part goes as d and the normal part as
    /// d^2 relative to the value at the layer's edge on the same normal; continuous at the edge.
    #[test]
    fn vanishes_on_the_surface_and_is_the_lattice_flow_beyond_the_layer() {
        let (bed, flow) = (wire_bed(), known_flow());
        let centre = Vector3::new(0.5e-3, 0.5e-3, 0.5e-3);
        for k in 0..16 {
            let phi = k as f64 * std::f64::consts::TAU / 16.0 + 0.1;
            let n = Vector3::new(0.0, phi.cos(), phi.sin());
            let x = Vector3::new(0.37e-3 * k as f64 / 16.0, 0.0, 0.0);
            let at = |d: f64| no_slip_flow(&flow, &bed, &(centre + x + n * (R + d)));
            // on the surface
            let (u0, w0) = at(0.0);
            assert!(u0.norm() < 1e-18, "{u0}");
            assert!(w0.is_some());
            // beyond the layer: the lattice's interpolation, bit for bit
            for d in [1.0001 * H, 1.5 * H, 3.0 * H] {
                let p = centre + x + n * (R + d);
                let (u, w) = no_slip_flow(&flow, &bed, &p);
                assert_eq!(u, flow.at(&p));
                assert!(w.is_none());
            }
            // inside: u_t ~ d, u_n ~ d^2 against the edge value
            let edge = flow.at(&(centre + x + n * (R + H)));
            let (en, et) = (edge.dot(&n), edge - n * edge.dot(&n));
            assert!(et.norm() > 1e-4 && en.abs() > 1e-5, "{edge} {n}");
            for f in [0.1, 0.25, 0.5, 0.9] {
                let (u, w) = at(f * H);
                let un = u.dot(&n);
                let ut = u - n * un;
                assert!((ut - et * f).norm() < 1e-12 * et.norm(), "{ut} {et} {f}");
                assert!((un - en * f * f).abs() < 1e-12 * en.abs(), "{un} {en} {f}");
                let w = w.unwrap();
                assert!((w.distance_m - f * H).abs() < 1e-12 * H);
                assert!((w.approach_m_s - (-un).max(0.0)).abs() <= 1e-12 * en.abs());
            }
            // continuous at the edge
            let (inner, _) = at(H * (1.0 - 1e-9));
            assert!((inner - edge).norm() < 1e-6 * edge.norm(), "{inner} {edge}");
        }
    }

    /// Without a wall layer the flow is the lattice's everywhere, on the surface too.
    #[test]
    fn no_layer_no_correction() {
        let c = Vector3::new(0.5e-3, 0.5e-3, 0.5e-3);
        let bed = FibreBed::new(CELL, R, 0.6e-3, &[c], &[Vector3::x()], 1e-8).unwrap();
        let flow = known_flow();
        let p = c + Vector3::new(0.0, 0.0, -R);
        let (u, w) = no_slip_flow(&flow, &bed, &p);
        assert_eq!(u, flow.at(&p));
        assert!(w.is_none() && u.norm() > 1e-4);
    }
}
