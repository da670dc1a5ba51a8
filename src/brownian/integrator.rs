//! The Ermak–McCammon update (thesis 003, eq. 6.3, 6.7, 6.11):
//!   r(t + dt) = r(t) + M F dt + R,   <R R^T> = 2 kB T M dt,
//! with M the mobility (D = kB T M) and no divergence term (zero for all tensors offered).
//!
//! Only the terms a simulation needs are built: no mobility matrix or noise factorisation
//! without hydrodynamic interactions, no noise at T = 0, no pair loop without repulsion or
//! moments, no field evaluation without a field source.
//!
//! Time-step guard: before a step moves anything, the deterministic displacement M F dt of
//! every particle is compared with `max_fraction` times the radius. [`StepGuard::Refuse`]
//! returns an `Err` naming the particle, its displacement and the largest safe dt;
//! [`StepGuard::Substep`] halves the step (fresh forces, mobility and noise on each half) up to
//! `max_halvings` times, then refuses the same way. The state is unchanged by a refused step.
//! With `guard_field_force = false` the guard looks at the displacement of the pair and
//! constant forces only (the repulsion it protects): the force of the external field varies on
//! the scale of the distance to the magnets, not of R, so its step is an accuracy choice of dt
//! (checked by the capture scenes' time-step convergence), not a stability limit.
//!
//! Capture (section 6.3): with `capture` set, a particle that touches a cylinder after a
//! (sub)step is captured and fixed for the rest of the run "by setting the particle forces to
//! zero": no field is evaluated for it, it gets no force and no displacement (deterministic or
//! random), and the step guard ignores it. It still repels and (with dipole pairs) attracts the
//! free particles, and with hydrodynamics it still enters the mobility matrix as a sphere.
//! A free particle whose deterministic displacement M F dt would end in contact with a cylinder
//! is captured at the first contact point on that straight path (bisection), without noise and
//! without the step guard: near a magnetized cylinder the drift can exceed the guard's limit in
//! the last steps before contact, and sub-stepping the whole system for it would cost much and
//! change nothing but the capture time by less than one step.

use super::capture::CaptureSet;
use super::forces::{
    dipole_force, magnetic_dipole_force, FieldFn, FieldSource, LangevinMoment, Mie,
};
use super::mobility::{mobility_matrix, stokes_mobility, Hydrodynamics};
use super::noise::{NoiseGenerator, NoiseMethod};
use super::{standard_normal, Params, Particles};
use crate::consts::MU0;
use crate::error::{invalid, require_positive, Result};
use nalgebra::{DVector, Matrix3, Vector3};
use rand::Rng;

/// One force (N) per particle.
type Forces = Vec<Vector3<f64>>;

/// What to do when the deterministic displacement of a step is too large for the repulsion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepGuard {
    /// Refuse with an Err when any |M F dt| > max_fraction * R.
    Refuse { max_fraction: f64 },
    /// Halve the step until |M F dt| <= max_fraction * R, at most `max_halvings` times.
    Substep {
        max_fraction: f64,
        max_halvings: u32,
    },
}

impl Default for StepGuard {
    fn default() -> Self {
        StepGuard::Refuse { max_fraction: 0.1 }
    }
}

/// Magnetic terms: a field source, the moment law, and the dipole–dipole cut-off (m; default
/// 30 R in the thesis). `dipole_pairs = false` leaves out the particle–particle dipole forces.
pub struct Magnetic {
    pub source: Box<dyn FieldSource>,
    pub moment: LangevinMoment,
    pub dipole_pairs: bool,
    pub cutoff: f64,
}

/// Moment (A m^2) and field (A/m) used by [`Magnetic::harmonic_trap`]; any non-zero values give the
/// same force.
const TRAP_MOMENT: f64 = 1e-16;
const TRAP_FIELD: f64 = 1e5;

impl Magnetic {
    /// The magnetic terms that make the force on every particle F = -k r (N), r its position (m),
    /// `stiffness` k in N/m (no dipole pairs).
    pub fn harmonic_trap(stiffness: f64) -> Result<Self> {
        require_positive(stiffness, || format!("trap stiffness k = {stiffness} N/m"))?;
        let c = -stiffness / (MU0 * TRAP_MOMENT);
        let source = FieldFn(move |p: &Vector3<f64>| {
            let mut g = Matrix3::zeros();
            g.set_column(0, &(p * c));
            (Vector3::new(TRAP_FIELD, 0.0, 0.0), g)
        });
        Ok(Magnetic {
            source: Box::new(source),
            moment: LangevinMoment::fixed(TRAP_MOMENT)?,
            dipole_pairs: false,
            cutoff: 0.0,
        })
    }
}

/// A Brownian-dynamics simulation of identical spheres.
pub struct Simulation {
    pub particles: Particles,
    pub params: Params,
    pub hydrodynamics: Hydrodynamics,
    /// Used only when `hydrodynamics` is not free-draining.
    pub noise: NoiseMethod,
    pub repulsion: Option<Mie>,
    pub magnetic: Option<Magnetic>,
    /// A constant force (N) on every particle.
    pub constant_force: Vector3<f64>,
    pub guard: StepGuard,
    /// Whether the guard counts the external-field force (default true; see module docs).
    pub guard_field_force: bool,
    /// Capture by cylinders (None: no capture). Built for the same number of particles.
    pub capture: Option<CaptureSet>,
    /// Elapsed time (s).
    pub time: f64,
}

impl Simulation {
    /// Free particles (no forces), free-draining, default guard. Rejects initial overlaps
    /// (centre distance < 2R), naming the first pair found.
    pub fn new(particles: Particles, params: Params) -> Result<Simulation> {
        check_overlaps(&particles)?;
        Ok(Simulation {
            particles,
            params,
            hydrodynamics: Hydrodynamics::FreeDraining,
            noise: NoiseMethod::Cholesky,
            repulsion: None,
            magnetic: None,
            constant_force: Vector3::zeros(),
            guard: StepGuard::default(),
            guard_field_force: true,
            capture: None,
            time: 0.0,
        })
    }

    /// Adds capture by the cylinders of `capture`: rejects (naming particle and cylinder) any
    /// particle that starts in contact with or inside a cylinder.
    pub fn with_capture(mut self, capture: CaptureSet) -> Result<Simulation> {
        capture.check_initial(&self.particles)?;
        self.capture = Some(capture);
        Ok(self)
    }

    /// Whether particle `i` is captured (always false without capture).
    pub fn is_fixed(&self, i: usize) -> bool {
        self.capture.as_ref().is_some_and(|c| c.is_captured(i))
    }

    /// Human-readable list of the terms that are built and used.
    pub fn active_terms(&self) -> Vec<String> {
        let mut t = vec![format!("mobility: {}", self.hydrodynamics.scene_name())];
        if self.params.temperature > 0.0 {
            t.push(match self.hydrodynamics {
                Hydrodynamics::FreeDraining => "noise: independent (no HI)".to_string(),
                _ => format!("noise: {:?}", self.noise),
            });
        } else {
            t.push("noise: off (T = 0)".into());
        }
        if self.constant_force != Vector3::zeros() {
            t.push(format!("constant force {:?} N", self.constant_force));
        }
        if let Some(m) = &self.repulsion {
            t.push(format!("Mie({}, {}) repulsion", m.n, m.m));
        }
        if let Some(c) = &self.capture {
            t.push(format!("capture by {} cylinder(s)", c.bodies.len()));
        }
        if let Some(m) = &self.magnetic {
            t.push("external field force".into());
            if m.dipole_pairs {
                t.push(format!("dipole-dipole (cut-off {:e} m)", m.cutoff));
            }
        }
        t
    }

    /// Total force (N) on every particle at the current positions; zero on captured ones.
    pub fn forces(&self) -> Result<Vec<Vector3<f64>>> {
        Ok(self.forces_and_field_part()?.0)
    }

    /// (total force, the external-field part of it) (N) per particle.
    fn forces_and_field_part(&self) -> Result<(Forces, Forces)> {
        let pos = &self.particles.positions;
        let n = pos.len();
        let fixed: Vec<bool> = (0..n).map(|i| self.is_fixed(i)).collect();
        let mut f = vec![self.constant_force; n];
        let mut f_field = vec![Vector3::zeros(); n];
        if let Some(mie) = &self.repulsion {
            for i in 0..n {
                for j in (i + 1)..n {
                    let fij = mie.pair_force(&(pos[i] - pos[j]));
                    f[i] += fij;
                    f[j] -= fij;
                }
            }
        }
        if let Some(mag) = &self.magnetic {
            let kt = self.params.kt();
            let mut moments = vec![Vector3::zeros(); n];
            for i in 0..n {
                // A captured particle needs its moment only for the dipole pairs.
                if fixed[i] && !mag.dipole_pairs {
                    continue;
                }
                let (h, g) = mag.source.h_and_gradient(&pos[i]);
                moments[i] = mag.moment.moment(&h, kt);
                f_field[i] = magnetic_dipole_force(&moments[i], &g);
                f[i] += f_field[i];
            }
            if mag.dipole_pairs {
                for i in 0..n {
                    for j in (i + 1)..n {
                        let r = pos[i] - pos[j];
                        if r.norm() < mag.cutoff {
                            let fij = dipole_force(&r, &moments[i], &moments[j]);
                            f[i] += fij;
                            f[j] -= fij;
                        }
                    }
                }
            }
        }
        for i in (0..n).filter(|&i| fixed[i]) {
            f[i] = Vector3::zeros();
            f_field[i] = Vector3::zeros();
        }
        if let Some((i, v)) = f
            .iter()
            .enumerate()
            .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
        {
            return invalid(format!(
                "force on particle {i} is {v:?} N at position {:?} m: not finite",
                pos[i]
            ));
        }
        Ok((f, f_field))
    }

    /// One step of length `params.dt` (possibly sub-stepped, see [`StepGuard`]).
    /// A refused step (or sub-step) leaves positions, time and captures as they were before it.
    pub fn step<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<()> {
        let dt = self.params.dt;
        let before = (
            self.particles.positions.clone(),
            self.time,
            self.capture.clone(),
        );
        let result = self.advance(rng, dt, 0);
        if result.is_err() {
            (self.particles.positions, self.time, self.capture) = before;
        }
        result
    }

    /// `steps` steps.
    pub fn run<R: Rng + ?Sized>(&mut self, rng: &mut R, steps: u64) -> Result<()> {
        for _ in 0..steps {
            self.step(rng)?;
        }
        Ok(())
    }

    fn advance<R: Rng + ?Sized>(&mut self, rng: &mut R, dt: f64, depth: u32) -> Result<()> {
        let n = self.particles.len();
        let a = self.particles.radius;
        let (f, f_field) = self.forces_and_field_part()?;
        let mu0 = stokes_mobility(self.params.viscosity, a)?;
        let stack = |forces: &[Vector3<f64>]| {
            let mut v = DVector::<f64>::zeros(3 * n);
            for (i, fi) in forces.iter().enumerate() {
                v.fixed_rows_mut::<3>(3 * i).copy_from(fi);
            }
            v
        };
        let fv = stack(&f);
        let mobility = match self.hydrodynamics {
            Hydrodynamics::FreeDraining => None,
            kind => Some(mobility_matrix(
                kind,
                &self.particles.positions,
                a,
                self.params.viscosity,
            )?),
        };
        let velocity = match &mobility {
            None => &fv * mu0,
            Some(m) => m * &fv,
        };
        // The velocity the guard looks at: all of it, or without the external-field part.
        let guarded = if self.guard_field_force || self.magnetic.is_none() {
            velocity.clone()
        } else {
            let fg = fv - stack(&f_field);
            match &mobility {
                None => fg * mu0,
                Some(m) => m * fg,
            }
        };
        // Guard on the deterministic displacement.
        let (max_fraction, max_halvings) = match self.guard {
            StepGuard::Refuse { max_fraction } => (max_fraction, 0),
            StepGuard::Substep {
                max_fraction,
                max_halvings,
            } => (max_fraction, max_halvings),
        };
        let fixed: Vec<bool> = (0..n).map(|i| self.is_fixed(i)).collect();
        // Ballistic capture: a free particle whose deterministic step ends in contact with a
        // cylinder is captured where its path first touches; its step needs no guard.
        let arriving: Vec<Option<(usize, Vector3<f64>)>> = (0..n)
            .map(|i| {
                let c = self.capture.as_ref()?;
                if fixed[i] {
                    return None;
                }
                let v: Vector3<f64> = velocity.fixed_rows::<3>(3 * i).into();
                c.first_contact_on_path(&self.particles.positions[i], &(v * dt), a)
            })
            .collect();
        let (worst, vmax) = (0..n)
            .filter(|&i| !fixed[i] && arriving[i].is_none())
            .map(|i| (i, guarded.fixed_rows::<3>(3 * i).norm()))
            .fold((0, 0.0f64), |acc, x| if x.1 > acc.1 { x } else { acc });
        if vmax * dt > max_fraction * a {
            if depth < max_halvings {
                self.advance(rng, 0.5 * dt, depth + 1)?;
                return self.advance(rng, 0.5 * dt, depth + 1);
            }
            return invalid(format!(
                "time step too large for the forces: particle {worst} would move {:e} m in \
                 dt = {dt:e} s, more than {max_fraction} x radius {a:e} m (force {:?} N at {:?} m); \
                 use dt <= {:e} s{}",
                vmax * dt,
                f[worst],
                self.particles.positions[worst],
                max_fraction * a / vmax,
                if max_halvings > 0 {
                    format!(" ({max_halvings} halvings were not enough)")
                } else {
                    String::new()
                }
            ));
        }
        let mut dx = velocity * dt;
        let kt = self.params.kt();
        if kt > 0.0 {
            let g = DVector::from_fn(3 * n, |_, _| standard_normal(rng));
            match &mobility {
                None => dx += g * (2.0 * kt * mu0 * dt).sqrt(),
                Some(m) => {
                    let gen = NoiseGenerator::new(self.noise, m)?;
                    dx += gen.apply(&g, (2.0 * kt * dt).sqrt());
                }
            }
        }
        for (i, p) in self.particles.positions.iter_mut().enumerate() {
            if !fixed[i] {
                *p += dx.fixed_rows::<3>(3 * i);
            }
        }
        self.time += dt;
        if let Some(c) = &mut self.capture {
            for (i, hit) in arriving.iter().enumerate() {
                if let Some((body, at)) = hit {
                    self.particles.positions[i] = *at;
                    c.mark(i, *body, self.time, *at);
                }
            }
            c.apply(&mut self.particles.positions, a, self.time);
        }
        Ok(())
    }
}

/// Err naming the first pair (i < j) whose centres are closer than 2R.
pub fn check_overlaps(p: &Particles) -> Result<()> {
    let d = 2.0 * p.radius;
    for i in 0..p.len() {
        for j in (i + 1)..p.len() {
            let r = (p.positions[i] - p.positions[j]).norm();
            if r < d {
                return invalid(format!(
                    "initial overlap: particles {i} and {j} are {r:e} m apart, less than the \
                     diameter 2R = {d:e} m"
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brownian::run_rng;

    #[test]
    fn trap_force_is_minus_k_r() {
        let k = 3e-7;
        let p = vec![
            Vector3::new(1e-7, -2e-7, 3e-7),
            Vector3::new(-4e-7, 0.0, 5e-8),
        ];
        let mut sim = Simulation::new(
            Particles::new(p.clone(), 1e-8).unwrap(),
            Params::new(298.0, 1e-3, 1e-6).unwrap(),
        )
        .unwrap();
        sim.magnetic = Some(Magnetic::harmonic_trap(k).unwrap());
        for (f, r) in sim.forces().unwrap().iter().zip(&p) {
            assert!((f + r * k).norm() <= 1e-15 * k * r.norm(), "{f:?} {r:?}");
        }
        assert!(Magnetic::harmonic_trap(0.0).is_err());
        assert!(Magnetic::harmonic_trap(f64::NAN).is_err());
    }

    fn pair(sep: f64) -> Particles {
        Particles::new(vec![Vector3::zeros(), Vector3::new(sep, 0.0, 0.0)], 1e-7).unwrap()
    }

    #[test]
    fn overlap_rejected_with_pair() {
        let p = Particles::new(
            vec![
                Vector3::zeros(),
                Vector3::new(1e-6, 0.0, 0.0),
                Vector3::new(1.5e-7, 0.0, 0.0),
            ],
            1e-7,
        )
        .unwrap();
        let e = Simulation::new(p, Params::new(298.0, 1e-3, 1e-6).unwrap())
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("particles 0 and 2"), "{e}");
    }

    #[test]
    fn big_step_refused_or_substepped() {
        let params = Params::new(298.0, 1e-3, 1e-3).unwrap();
        let mut s = Simulation::new(pair(2.0e-7 * 1.001), params).unwrap();
        s.repulsion = Some(Mie::thesis_default(params.kt(), 1e-7).unwrap());
        let before = s.particles.clone();
        let e = s.step(&mut run_rng(1, 0)).unwrap_err().to_string();
        assert!(e.contains("time step too large"), "{e}");
        assert_eq!(s.particles, before);
        s.guard = StepGuard::Substep {
            max_fraction: 0.1,
            max_halvings: 30,
        };
        s.params.temperature = 0.0;
        s.step(&mut run_rng(1, 0)).unwrap();
        let r = (s.particles.positions[1] - s.particles.positions[0]).norm();
        assert!(r > 2e-7 && r.is_finite(), "{r}");
        assert!((s.time - 1e-3).abs() < 1e-15);
    }
}
