//! Capture of particles by cylinders (thesis 003, section 6.3): a particle whose surface touches
//! a cylinder (centre within one particle radius of the solid cylinder) is captured and stays
//! fixed for the rest of the run. Several cylinders may be present.
//!
//! A [`Simulation`](super::Simulation) given a capture set (`Simulation::with_capture`)
//! applies it after every (sub)step and treats captured particles as fixed: no field
//! evaluation, zero force (as the thesis does), no displacement. [`CaptureSet::apply`] can also
//! be called by hand after each step: it marks particles now in contact as captured at their
//! current position and puts every captured particle back at its capture position.

use crate::error::{invalid, require_positive, Result};
use crate::magnetics::Magnet;
use nalgebra::Vector3;

/// A solid circular cylinder in any pose: centre (m), unit axis, radius R and half-length L (m),
/// i.e. the points with distance from the axis <= R and |axial coordinate| <= L.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderBody {
    pub centre: Vector3<f64>,
    axis: Vector3<f64>,
    pub radius: f64,
    pub half_length: f64,
}

impl CylinderBody {
    /// `axis` need not be unit length; all values finite, R and L positive.
    pub fn new(
        centre: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        half_length: f64,
    ) -> Result<CylinderBody> {
        if !centre.iter().all(|v| v.is_finite()) {
            return invalid(format!("cylinder centre {centre:?} m: must be finite"));
        }
        let n = axis.norm();
        if !(n.is_finite() && n > 0.0) {
            return invalid(format!(
                "cylinder axis {axis:?}: must be finite and non-zero"
            ));
        }
        require_positive(radius, || format!("cylinder radius {radius} m"))?;
        require_positive(half_length, || {
            format!("cylinder half-length {half_length} m")
        })?;
        Ok(CylinderBody {
            centre,
            axis: axis / n,
            radius,
            half_length,
        })
    }

    /// The body of a magnet (same centre, axis and shape).
    pub fn from_magnet(m: &Magnet) -> Result<CylinderBody> {
        CylinderBody::new(
            m.centre,
            m.axis(),
            m.cylinder.radius_m(),
            m.cylinder.half_length_m(),
        )
    }

    pub fn axis(&self) -> Vector3<f64> {
        self.axis
    }

    /// Signed Euclidean distance (m) from `p` to the solid cylinder's surface: > 0 outside,
    /// 0 on the surface, < 0 inside (minus the distance to the nearest surface point).
    pub fn signed_distance(&self, p: &Vector3<f64>) -> f64 {
        let d = p - self.centre;
        let z = d.dot(&self.axis);
        // |d x a| is the distance from the axis without the cancellation of sqrt(|d|^2 - z^2).
        let rho = d.cross(&self.axis).norm();
        let dr = rho - self.radius;
        let dz = z.abs() - self.half_length;
        if dr <= 0.0 && dz <= 0.0 {
            dr.max(dz)
        } else {
            dr.max(0.0).hypot(dz.max(0.0))
        }
    }

    /// Whether a sphere of radius `a` centred at `p` touches or overlaps the cylinder.
    pub fn touches(&self, p: &Vector3<f64>, a: f64) -> bool {
        self.signed_distance(p) <= a
    }
}

/// Which particles are captured, by which cylinder, when and where.
#[derive(Debug, Clone)]
pub struct CaptureSet {
    pub bodies: Vec<CylinderBody>,
    captured: Vec<Option<Capture>>,
}

/// One capture event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capture {
    /// Index of the cylinder (the first one touched, in `bodies` order).
    pub cylinder: usize,
    /// Time (s) of the step after which it was found in contact.
    pub time: f64,
    /// The fixed position (m).
    pub position: Vector3<f64>,
}

impl CaptureSet {
    pub fn new(bodies: Vec<CylinderBody>, n_particles: usize) -> CaptureSet {
        CaptureSet {
            bodies,
            captured: vec![None; n_particles],
        }
    }

    /// Bodies of all magnets of an assembly.
    pub fn for_assembly(a: &crate::magnetics::Assembly, n_particles: usize) -> Result<CaptureSet> {
        let bodies = a
            .magnets
            .iter()
            .map(CylinderBody::from_magnet)
            .collect::<Result<Vec<_>>>()?;
        Ok(CaptureSet::new(bodies, n_particles))
    }

    /// Rejects initial positions in contact with (or inside) a cylinder, naming the first
    /// particle and cylinder found, and a particle count that differs from the set's.
    pub fn check_initial(&self, particles: &super::Particles) -> Result<()> {
        if particles.len() != self.captured.len() {
            return invalid(format!(
                "capture set built for {} particles, given {}",
                self.captured.len(),
                particles.len()
            ));
        }
        for (i, p) in particles.positions.iter().enumerate() {
            for (c, b) in self.bodies.iter().enumerate() {
                let d = b.signed_distance(p);
                if d <= particles.radius {
                    return invalid(format!(
                        "particle {i} at {p:?} m starts {} cylinder {c} (surface distance {d:e} \
                         m, particle radius {:e} m): initial positions must be clear of every \
                         cylinder",
                        if d < 0.0 { "inside" } else { "in contact with" },
                        particles.radius
                    ));
                }
            }
        }
        Ok(())
    }

    /// Marks the particles now touching a cylinder as captured at time `time` (s), fixes every
    /// captured particle at its capture position, and returns the indices captured by this
    /// call. Panics if `positions` has another length than the set (a programming error).
    pub fn apply(&mut self, positions: &mut [Vector3<f64>], radius: f64, time: f64) -> Vec<usize> {
        assert_eq!(
            positions.len(),
            self.captured.len(),
            "capture set and positions differ in length"
        );
        let mut new = Vec::new();
        for (i, p) in positions.iter_mut().enumerate() {
            match &self.captured[i] {
                Some(c) => *p = c.position,
                None => {
                    if let Some(c) = self.bodies.iter().position(|b| b.touches(p, radius)) {
                        self.captured[i] = Some(Capture {
                            cylinder: c,
                            time,
                            position: *p,
                        });
                        new.push(i);
                    }
                }
            }
        }
        new
    }

    /// The first cylinder (index) and point on the straight path p -> p + step at which a
    /// sphere of radius `a` touches a cylinder, if its end point touches one (the path is
    /// bisected to 1e-12 of its length from the last free point). None if the end is free.
    pub fn first_contact_on_path(
        &self,
        p: &Vector3<f64>,
        step: &Vector3<f64>,
        a: f64,
    ) -> Option<(usize, Vector3<f64>)> {
        let end = p + step;
        let c = self.bodies.iter().position(|b| b.touches(&end, a))?;
        let body = &self.bodies[c];
        let (mut free, mut hit) = (0.0f64, 1.0f64);
        while hit - free > 1e-12 {
            let mid = 0.5 * (free + hit);
            if body.touches(&(p + step * mid), a) {
                hit = mid;
            } else {
                free = mid;
            }
        }
        Some((c, p + step * hit))
    }

    /// Marks particle `i` as captured by cylinder `cylinder` at `time` (s), fixed at
    /// `position` (m); a particle already captured keeps its first capture.
    pub fn mark(&mut self, i: usize, cylinder: usize, time: f64, position: Vector3<f64>) {
        if self.captured[i].is_none() {
            self.captured[i] = Some(Capture {
                cylinder,
                time,
                position,
            });
        }
    }

    pub fn capture(&self, i: usize) -> Option<&Capture> {
        self.captured.get(i).and_then(|c| c.as_ref())
    }

    pub fn is_captured(&self, i: usize) -> bool {
        self.capture(i).is_some()
    }

    pub fn count(&self) -> usize {
        self.captured.iter().filter(|c| c.is_some()).count()
    }

    /// Captured fraction of all particles (0 for an empty set).
    pub fn fraction(&self) -> f64 {
        if self.captured.is_empty() {
            0.0
        } else {
            self.count() as f64 / self.captured.len() as f64
        }
    }

    /// Captured fraction of the particles in `subset` (e.g. a TOP or SIDE region); 0 if empty.
    pub fn fraction_of(&self, subset: &[usize]) -> f64 {
        if subset.is_empty() {
            return 0.0;
        }
        subset.iter().filter(|&&i| self.is_captured(i)).count() as f64 / subset.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brownian::run_rng;
    use crate::brownian::{Fluid, Particles, Setup, Simulation};

    #[test]
    fn distance_basics() {
        let b = CylinderBody::new(Vector3::zeros(), Vector3::z(), 1.0, 2.0).unwrap();
        assert_eq!(b.signed_distance(&Vector3::new(0.0, 0.0, 5.0)), 3.0);
        assert_eq!(b.signed_distance(&Vector3::new(3.0, 0.0, 1.0)), 2.0);
        assert_eq!(b.signed_distance(&Vector3::new(4.0, 0.0, 6.0)), 5.0);
        assert_eq!(b.signed_distance(&Vector3::new(0.5, 0.0, 0.0)), -0.5);
        assert_eq!(b.signed_distance(&Vector3::new(0.0, 0.0, 1.75)), -0.25);
        let e = CylinderBody::new(Vector3::zeros(), Vector3::zeros(), 1.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("axis"), "{e}");
    }

    #[test]
    fn captured_particles_stay_fixed() {
        let a = 1e-7;
        let body = CylinderBody::new(Vector3::zeros(), Vector3::z(), 1e-6, 1e-6).unwrap();
        // Particle 0 drifts toward the cylinder along -x under a constant force; particle 1
        // is far away.
        let p = Particles::new(
            vec![Vector3::new(1.5e-6, 0.0, 0.0), Vector3::new(0.0, 0.0, 1e-5)],
            a,
        )
        .unwrap();
        let mut setup = Setup::new(p, Fluid::new(0.0, 1e-3).unwrap(), 1e-4).unwrap();
        setup.constant_force = Vector3::new(-1e-14, 0.0, 0.0);
        setup.capture = Some(CaptureSet::new(vec![body], 2));
        let mut sim = Simulation::new(setup, run_rng(1, 0)).unwrap();
        let mut t_cap = None;
        for _ in 0..2000 {
            sim.step().unwrap();
            if t_cap.is_none() && sim.is_fixed(0) {
                t_cap = Some(sim.particles().positions[0]);
            }
        }
        let fixed = t_cap.expect("particle 0 is captured");
        assert_eq!(sim.particles().positions[0], fixed);
        assert!(body.signed_distance(&fixed) <= a);
        assert!(
            body.signed_distance(&fixed)
                > a - 1.1 * 1e-14 * 1e-4 / (6.0 * std::f64::consts::PI * 1e-3 * a)
        );
        let cs = sim.capture().unwrap();
        assert!(!cs.is_captured(1));
        assert_eq!(cs.fraction(), 0.5);
        assert_eq!(cs.fraction_of(&[1]), 0.0);
        // A particle that starts in contact is rejected by name.
        let bad = Particles::new(vec![Vector3::new(1.05e-6, 0.0, 0.0)], a).unwrap();
        let e = CaptureSet::new(vec![body], 1)
            .check_initial(&bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains("particle 0"), "{e}");
    }
}
