//! Particle shapes (thesis 003 sections 2.2, 4.2-4.3 and appendices 4.A-4.C; seed 000 appendix A).
//!
//! Every shape lives in its body frame (centre at the origin, principal axes along x, y, z) and
//! implements [`ConvexShape`]. Lengths in metres (or reduced units where an engine says so).

use nalgebra::Vector3;

/// What the packing, deposition and contact code need of one convex particle.
pub trait ConvexShape: Send + Sync + std::fmt::Debug {
    /// Volume.
    fn volume(&self) -> f64;
    /// Principal moments of inertia about the centre at unit density, body frame (Ixx, Iyy, Izz).
    fn principal_inertia_unit_density(&self) -> Vector3<f64>;
    /// Principal moments for a given mass (= unit-density moments * mass / volume).
    fn principal_inertia(&self, mass: f64) -> Vector3<f64> {
        self.principal_inertia_unit_density() * (mass / self.volume())
    }
    /// Radius of the smallest sphere about the centre containing the shape.
    fn bounding_radius(&self) -> f64;
    /// Implicit function, body frame: < 0 inside, 0 on the surface, > 0 outside (the scale is
    /// shape-specific and documented by each shape).
    fn implicit(&self, p: &Vector3<f64>) -> f64;
    /// Outward unit normal at (or near) the surface point p, body frame.
    fn normal(&self, p: &Vector3<f64>) -> Vector3<f64>;
    /// Support point: the surface point farthest along direction `d` (need not be unit), body frame.
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64>;
    /// About `n` near-uniformly spread surface points, body frame.
    fn surface_samples(&self, n: usize) -> Vec<Vector3<f64>>;
}
