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

pub mod ellipsoid;
pub mod sphere;
pub mod spherocylinder;
pub mod superquadric;

pub use ellipsoid::Ellipsoid;
pub use sphere::Sphere;
pub use spherocylinder::Spherocylinder;
pub use superquadric::Superquadric;

use crate::error::{invalid, Result};

/// Checks that a length is positive and finite; the error names the quantity and the value.
pub(crate) fn check_length(name: &str, v: f64) -> Result<()> {
    if !(v.is_finite() && v > 0.0) {
        return invalid(format!("{name} = {v}: must be positive and finite"));
    }
    Ok(())
}

/// `n` directions of a Fibonacci (golden-angle) lattice on the unit sphere: equal solid angle
/// per point, ordered by z from +1 to -1 (Gonzalez 2010, Math. Geosci. 42, 49).
pub(crate) fn fibonacci_directions(n: usize) -> Vec<Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|k| {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * k as f64;
            Vector3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Near-uniform (area-weighted) surface samples of a star-shaped convex body.
///
/// Candidates: Fibonacci directions u (equal solid angle), stretched by `stretch` (v = S u / |S u|,
/// S = diag(stretch), which spreads candidates over elongated bodies), projected radially onto
/// the surface by `radial(v) = r(v)` (distance from the centre to the surface along unit v).
/// Each candidate carries the surface area it represents,
/// dA/dOmega_u = r^2 / (v . n) * det S / |S u|^3
/// (radial projection: dA = r^2 dOmega_v / cos(v, n); stretching: dOmega_v = det S / |S u|^3 dOmega_u).
/// Then `n` points are drawn by systematic resampling of the candidates in lattice order with
/// these weights; the candidate count is raised until every weight is below half a stratum,
/// so no candidate is drawn twice.
pub(crate) fn area_weighted_samples<R, N>(
    n: usize,
    stretch: Vector3<f64>,
    radial: R,
    normal: N,
) -> Vec<Vector3<f64>>
where
    R: Fn(&Vector3<f64>) -> f64,
    N: Fn(&Vector3<f64>) -> Vector3<f64>,
{
    if n == 0 {
        return Vec::new();
    }
    let det = stretch.x * stretch.y * stretch.z;
    let mut m = (16 * n).max(64);
    const MAX_CANDIDATES: usize = 4_000_000;
    loop {
        let mut pts = Vec::with_capacity(m);
        let mut w = Vec::with_capacity(m);
        for u in fibonacci_directions(m) {
            let su = stretch.component_mul(&u);
            let sn = su.norm();
            let v = su / sn;
            let r = radial(&v);
            let p = v * r;
            let nrm = normal(&p);
            let c = v.dot(&nrm).max(1e-300);
            w.push(r * r / c * det / (sn * sn * sn));
            pts.push(p);
        }
        let total: f64 = w.iter().sum();
        let wmax = w.iter().cloned().fold(0.0, f64::max);
        let stratum = total / n as f64;
        if wmax <= 0.5 * stratum || m >= MAX_CANDIDATES {
            let mut out = Vec::with_capacity(n);
            let mut acc = 0.0;
            let mut next = 0.5 * stratum;
            for (p, wk) in pts.iter().zip(w.iter()) {
                acc += wk;
                while acc > next && out.len() < n {
                    out.push(*p);
                    next += stratum;
                }
            }
            while out.len() < n {
                out.push(*pts.last().unwrap());
            }
            return out;
        }
        let need = (2.0 * n as f64 * wmax / (total / m as f64)).ceil() as usize + 1;
        m = need.max(2 * m).min(MAX_CANDIDATES);
    }
}

/// Volume of a shape given by the contact module's plain parameters (the packing species
/// descriptor). Sphere and spherocylinder: pi R^2 (4R/3 + L) (thesis eq. 2.2, L = 0 for the
/// sphere, the expression the MCM has always used, so monodisperse packings keep their exact
/// packing fractions); ellipsoid and superquadric from their shape modules (eq. 4.26-4.28).
pub fn volume_of(s: &crate::contact::ContactShape) -> Result<f64> {
    use crate::contact::ContactShape as C;
    let rod = |r: f64, l: f64| std::f64::consts::PI * r * r * (4.0 / 3.0 * r + l);
    Ok(match *s {
        C::Sphere { radius } => rod(radius, 0.0),
        C::Spherocylinder { radius, length } => rod(radius, length),
        C::Ellipsoid { semi_axes } => Ellipsoid::new(semi_axes)?.volume(),
        C::Superquadric {
            semi_axes,
            exponents,
        } => Superquadric::new(semi_axes, exponents)?.volume(),
    })
}

/// Bounding radius (smallest centred sphere containing the shape) of a contact-module shape:
/// L/2 + R for a spherocylinder, eq. 4.38 (or its dual maximisation) for a superquadric.
pub fn bounding_radius_of(s: &crate::contact::ContactShape) -> Result<f64> {
    use crate::contact::ContactShape as C;
    Ok(match *s {
        C::Sphere { radius } => radius,
        C::Spherocylinder { radius, length } => 0.5 * length + radius,
        C::Ellipsoid { semi_axes } => Ellipsoid::new(semi_axes)?.bounding_radius(),
        C::Superquadric {
            semi_axes,
            exponents,
        } => Superquadric::new(semi_axes, exponents)?.bounding_radius(),
    })
}
