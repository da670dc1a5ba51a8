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
use super::forces::{dipole_force, magnetic_dipole_force, Mie};
use super::mobility::{mobility_matrix, stokes_mobility, Hydrodynamics};
use super::noise::{NoiseGenerator, NoiseMethod};
use super::setup::{check_time_step, Fluid, Magnetic, Setup, StepGuard};
use super::{standard_normal, Particles};
use crate::error::{invalid, Result};
use nalgebra::{DVector, Vector3};
use rand_chacha::ChaCha8Rng;

/// One force (N) per particle.
type Forces = Vec<Vector3<f64>>;

/// A Brownian-dynamics run of identical spheres: the terms its [`Setup`] built, the current
/// positions and time, the captures so far, and the run's random stream.
pub struct Simulation {
    particles: Particles,
    fluid: Fluid,
    dt_s: f64,
    hydrodynamics: Hydrodynamics,
    noise: NoiseMethod,
    repulsion: Option<Mie>,
    magnetic: Option<Magnetic>,
    constant_force: Vector3<f64>,
    guard: StepGuard,
    guard_field_force: bool,
    capture: Option<CaptureSet>,
    /// The run's random stream (noise).
    rng: ChaCha8Rng,
    /// Elapsed time (s).
    time: f64,
}

impl Simulation {
    /// The run of `setup`, its noise drawn from `stream` (one stream per run, e.g.
    /// [`super::run_rng`], continued as it is). Rejects initial overlaps (centre distance < 2R,
    /// naming the first pair found) and any particle that starts in contact with or inside a
    /// capturing cylinder (naming particle and cylinder).
    pub fn new(setup: Setup, stream: ChaCha8Rng) -> Result<Simulation> {
        check_time_step(setup.dt_s)?;
        check_overlaps(&setup.particles)?;
        if let Some(c) = &setup.capture {
            c.check_initial(&setup.particles)?;
        }
        Ok(Simulation {
            particles: setup.particles,
            fluid: setup.fluid,
            dt_s: setup.dt_s,
            hydrodynamics: setup.hydrodynamics,
            noise: setup.noise,
            repulsion: setup.repulsion,
            magnetic: setup.magnetic,
            constant_force: setup.constant_force,
            guard: setup.guard,
            guard_field_force: setup.guard_field_force,
            capture: setup.capture,
            rng: stream,
            time: 0.0,
        })
    }

    /// The particles: current positions (m) and the radius (m).
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    pub fn fluid(&self) -> &Fluid {
        &self.fluid
    }

    /// The time step (s).
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// Elapsed time (s).
    pub fn time_s(&self) -> f64 {
        self.time
    }

    /// The magnetic terms (None without them).
    pub fn magnetic(&self) -> Option<&Magnetic> {
        self.magnetic.as_ref()
    }

    /// The captures so far (None without capture).
    pub fn capture(&self) -> Option<&CaptureSet> {
        self.capture.as_ref()
    }

    /// The random stream, as far as the steps have drawn it (the next stage of a cascade
    /// continues it).
    pub fn into_stream(self) -> ChaCha8Rng {
        self.rng
    }

    /// Whether particle `i` is captured (always false without capture).
    pub fn is_fixed(&self, i: usize) -> bool {
        self.capture.as_ref().is_some_and(|c| c.is_captured(i))
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
            let kt = self.fluid.kt();
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

    /// One step of length `dt_s` (possibly sub-stepped, see [`StepGuard`]).
    /// A refused step (or sub-step) leaves positions, time and captures as they were before it.
    pub fn step(&mut self) -> Result<()> {
        let dt = self.dt_s;
        let before = (
            self.particles.positions.clone(),
            self.time,
            self.capture.clone(),
        );
        let result = self.advance(dt, 0);
        if result.is_err() {
            (self.particles.positions, self.time, self.capture) = before;
        }
        result
    }

    fn advance(&mut self, dt: f64, depth: u32) -> Result<()> {
        let n = self.particles.len();
        let a = self.particles.radius;
        let (f, f_field) = self.forces_and_field_part()?;
        let mu0 = stokes_mobility(self.fluid.viscosity_pa_s(), a)?;
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
                self.fluid.viscosity_pa_s(),
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
                self.advance(0.5 * dt, depth + 1)?;
                return self.advance(0.5 * dt, depth + 1);
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
        let kt = self.fluid.kt();
        if kt > 0.0 {
            let rng = &mut self.rng;
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

    fn water() -> Fluid {
        Fluid::new(298.0, 1e-3).unwrap()
    }

    #[test]
    fn trap_force_is_minus_k_r() {
        let k = 3e-7;
        let p = vec![
            Vector3::new(1e-7, -2e-7, 3e-7),
            Vector3::new(-4e-7, 0.0, 5e-8),
        ];
        let mut setup =
            Setup::new(Particles::new(p.clone(), 1e-8).unwrap(), water(), 1e-6).unwrap();
        setup.magnetic = Some(Magnetic::harmonic_trap(k).unwrap());
        let sim = Simulation::new(setup, run_rng(0, 0)).unwrap();
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
        let setup = Setup::new(p, water(), 1e-6).unwrap();
        let e = Simulation::new(setup, run_rng(0, 0))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("particles 0 and 2"), "{e}");
    }

    #[test]
    fn big_step_refused_or_substepped() {
        let fluid = water();
        let pair_setup = |fluid: Fluid, guard: StepGuard| {
            let mut s = Setup::new(pair(2.0e-7 * 1.001), fluid, 1e-3).unwrap();
            s.repulsion = Some(Mie::thesis_default(water().kt(), 1e-7).unwrap());
            s.guard = guard;
            Simulation::new(s, run_rng(1, 0)).unwrap()
        };
        let mut s = pair_setup(fluid, StepGuard::default());
        let before = s.particles().clone();
        let e = s.step().unwrap_err().to_string();
        assert!(e.contains("time step too large"), "{e}");
        assert_eq!(s.particles(), &before);
        let substep = StepGuard::Substep {
            max_fraction: 0.1,
            max_halvings: 30,
        };
        let mut s = pair_setup(Fluid::new(0.0, 1e-3).unwrap(), substep);
        s.step().unwrap();
        let p = &s.particles().positions;
        let r = (p[1] - p[0]).norm();
        assert!(r > 2e-7 && r.is_finite(), "{r}");
        assert!((s.time_s() - 1e-3).abs() < 1e-15);
    }
}
