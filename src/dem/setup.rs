//! What a DEM run is made of, typed: the box, the contact model (normal, damping and
//! tangential sub-models chosen separately, [`ContactModel::new`]), the materials, the drivers
//! (gravity with buoyancy, a uniform Stokes drag, a fixed or pressure-controlled top wall), the
//! time step, the neighbour-list skin and the start. [`crate::dem::Dem::new`] checks a setup
//! once ([`Setup::check`]) and takes from it the values that follow (the time step, the skin):
//! this file is the one place where those are derived.

use super::model::{rayleigh_time, ContactModel, Material, PairMaterial};
use super::particles::Particles;
use super::start;
use crate::error::{invalid, require_positive};
use crate::Result;
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Uniform Stokes drag F = 6 pi mu a (U_F - v) (seed 002, "Fluid-solid coupling model").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drag {
    pub(super) viscosity_pa_s: f64,
    pub(super) fluid_velocity_m_s: Vector3<f64>,
}

impl Drag {
    /// The drag of a fluid of viscosity `viscosity_pa_s` (positive) moving at
    /// `fluid_velocity_m_s` (finite).
    pub fn new(viscosity_pa_s: f64, fluid_velocity_m_s: Vector3<f64>) -> Result<Drag> {
        require_positive(viscosity_pa_s, || {
            format!("viscosity {viscosity_pa_s} Pa s")
        })?;
        if !fluid_velocity_m_s.iter().all(|u| u.is_finite()) {
            return invalid(format!(
                "fluid velocity {:?} m/s: must be finite",
                fluid_velocity_m_s.as_slice()
            ));
        }
        Ok(Drag {
            viscosity_pa_s,
            fluid_velocity_m_s,
        })
    }

    pub fn viscosity_pa_s(&self) -> f64 {
        self.viscosity_pa_s
    }

    pub fn fluid_velocity_m_s(&self) -> Vector3<f64> {
        self.fluid_velocity_m_s
    }
}

/// The top wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TopWall {
    /// A fixed plane at height z (m).
    Fixed { z_m: f64 },
    /// A plane starting at z0 and driven by pressure control: each step the wall's contact
    /// pressure P (the particles' force on it over lx ly) is compared with the target and the
    /// wall moves down at v_max while it touches nothing; in contact it takes a relaxed Newton
    /// step on the elastic part F_el of its contact force each step, dz = -0.05 (F_target -
    /// F_el) / K_top with K_top the summed contact stiffness S_n of its contacts, capped at
    /// v_max dt (down when the pressure is too low, up when too high; the gain is bounded by
    /// the stiffness, so it cannot bang-bang). A purely proportional rule v = -v_max (1 -
    /// P/P_target), and the same Newton step on the total force (whose damping part follows
    /// the wall's own velocity), alternated between +-v_max every step.
    Pressure {
        z0_m: f64,
        target_pa: f64,
        speed_max_m_s: f64,
    },
}

impl TopWall {
    /// Its height at the start (m).
    pub fn z0_m(&self) -> f64 {
        match *self {
            TopWall::Fixed { z_m } => z_m,
            TopWall::Pressure { z0_m, .. } => z0_m,
        }
    }

    /// The speed limit of a pressure-controlled wall (m/s; 0 for a fixed wall).
    pub fn speed_max_m_s(&self) -> f64 {
        match *self {
            TopWall::Fixed { .. } => 0.0,
            TopWall::Pressure { speed_max_m_s, .. } => speed_max_m_s,
        }
    }

    /// The rules of its values: a positive height, target pressure and speed limit.
    pub fn check(&self) -> Result<()> {
        if let TopWall::Pressure {
            target_pa,
            speed_max_m_s,
            ..
        } = *self
        {
            require_positive(target_pa, || format!("target pressure {target_pa} Pa"))?;
            require_positive(speed_max_m_s, || {
                format!("top wall speed limit {speed_max_m_s} m/s")
            })?;
        }
        let z0 = self.z0_m();
        require_positive(z0, || format!("top wall height {z0} m"))?;
        Ok(())
    }
}

/// The time step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// min(0.2 t_Rayleigh, t_c / 50) (see [`auto_time_step`]).
    Automatic,
    /// A given step (s), refused above t_c / 10 or the Rayleigh time.
    Given { dt_s: f64 },
}

/// The relative impact speed that the Hertz contact-time rule of the time step assumes (the
/// contact time shortens as the impact speed grows); at least the top wall's speed limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ImpactSpeed {
    /// The speeds the drivers can give: a free fall over the top wall's start height,
    /// sqrt(2 |g_z| h), plus twice the drag's fluid speed and twice the wall's speed limit.
    FromDrivers,
    /// A given speed (m/s, >= 0).
    Given { m_s: f64 },
}

/// The particles at the start.
#[derive(Debug, Clone)]
pub enum Start {
    /// Spheres of these radii (m) at rest, dispersed at random without overlap between the floor
    /// and the top wall's start height ([`start::random_dispersion`], a ChaCha8 stream of
    /// `seed`), then numbered cell by cell ([`start::cell_order`]), so that neighbours sit near
    /// each other in memory.
    Dispersed { radius: Vec<f64>, seed: u64 },
    /// These particles as they are (positions between the walls, any velocities and spins).
    Given(Particles),
}

impl Start {
    /// The radii in the order given (the dispersion's draw order, or the particles').
    pub fn radii(&self) -> &[f64] {
        match self {
            Start::Dispersed { radius, .. } => radius,
            Start::Given(p) => &p.radius,
        }
    }

    /// Mean diameter (m) of the start's spheres, summed in the order given.
    pub fn mean_diameter_m(&self) -> f64 {
        let r = self.radii();
        2.0 * r.iter().sum::<f64>() / r.len() as f64
    }
}

/// Everything a DEM run is made of (SI).
#[derive(Debug, Clone)]
pub struct Setup {
    /// Periodic lengths in x and y (m).
    pub lx_m: f64,
    pub ly_m: f64,
    pub contact: ContactModel,
    pub particle_material: Material,
    pub wall_material: Material,
    pub density_kg_m3: f64,
    pub gravity_m_s2: Vector3<f64>,
    /// Fluid density for buoyancy, m' = m (1 - rho_f / rho_p) (0: none).
    pub fluid_density_kg_m3: f64,
    pub drag: Option<Drag>,
    pub top: TopWall,
    pub time_step: TimeStep,
    pub impact_speed: ImpactSpeed,
    /// Neighbour-list skin (m); `None`: 0.3 times the smallest diameter.
    pub skin_m: Option<f64>,
    pub start: Start,
}

/// Relaxation of the pressure wall's Newton step on its force.
pub const WALL_RELAXATION: f64 = 0.05;

/// Safety factor on the Rayleigh time (Hertz) and fraction of the contact time.
pub const RAYLEIGH_SAFETY: f64 = 0.2;
pub const CONTACT_TIME_FRACTION: f64 = 1.0 / 50.0;
/// A given time step above this fraction of the contact time (or above the Rayleigh time) is
/// refused.
pub const MAX_CONTACT_TIME_FRACTION: f64 = 1.0 / 10.0;

/// The shortest contact time of the setup's particles at relative speed `v_scale`: that of the
/// lightest pair (m* = m_min / 2, R* = r_min / 2) against the stiffer of the particle and wall
/// moduli ([`ContactModel::contact_time`]), and for Hertz the Rayleigh time of the smallest
/// sphere. Returns (t_contact, t_rayleigh or +inf).
pub fn contact_times(setup: &Setup, r_min: f64, v_scale: f64) -> (f64, f64) {
    let m_min = setup.density_kg_m3 * 4.0 / 3.0 * PI * r_min.powi(3);
    let m_eff = 0.5 * m_min;
    let pp = PairMaterial::new(&setup.particle_material, &setup.particle_material);
    let pw = PairMaterial::new(&setup.particle_material, &setup.wall_material);
    let e_star = pp.e_star_pa.max(pw.e_star_pa);
    let t_c = setup
        .contact
        .contact_time(m_eff, 0.5 * r_min, e_star, v_scale);
    if setup.contact.normal().is_hertz() {
        let t_r = rayleigh_time(r_min, setup.density_kg_m3, &setup.particle_material);
        (t_c, t_r)
    } else {
        (t_c, f64::INFINITY)
    }
}

/// Automatic time step: min(0.2 t_Rayleigh, t_c / 50) (see [`contact_times`]).
pub fn auto_time_step(setup: &Setup, r_min: f64, v_scale: f64) -> f64 {
    let (tc, tr) = contact_times(setup, r_min, v_scale);
    (RAYLEIGH_SAFETY * tr).min(CONTACT_TIME_FRACTION * tc)
}

impl Setup {
    /// Spheres starting as `start` (density `density_kg_m3`, one `material` for particles and
    /// walls, contact law `contact`) in a box `l` = [lx, ly, h] periodic in x and y under a
    /// fixed top wall at h, with no drivers, the automatic time step at the drivers' impact
    /// speed and the default skin; set the other fields for more.
    pub fn in_box(
        l: [f64; 3],
        contact: ContactModel,
        material: Material,
        density_kg_m3: f64,
        start: Start,
    ) -> Setup {
        Setup {
            lx_m: l[0],
            ly_m: l[1],
            contact,
            particle_material: material,
            wall_material: material,
            density_kg_m3,
            gravity_m_s2: Vector3::zeros(),
            fluid_density_kg_m3: 0.0,
            drag: None,
            top: TopWall::Fixed { z_m: l[2] },
            time_step: TimeStep::Automatic,
            impact_speed: ImpactSpeed::FromDrivers,
            skin_m: None,
            start,
        }
    }

    /// The rules of the setup as a whole: a positive box and density, a fluid lighter than the
    /// particles, finite gravity, a valid drag and top wall (the contact model was checked when
    /// it was built, [`ContactModel::new`]).
    pub fn check(&self) -> Result<()> {
        require_positive(self.lx_m, || format!("box lx {} m", self.lx_m))?;
        require_positive(self.ly_m, || format!("box ly {} m", self.ly_m))?;
        require_positive(self.density_kg_m3, || {
            format!("particle density {} kg/m^3", self.density_kg_m3)
        })?;
        if !(self.fluid_density_kg_m3.is_finite()
            && self.fluid_density_kg_m3 >= 0.0
            && self.fluid_density_kg_m3 < self.density_kg_m3)
        {
            return invalid(format!(
                "fluid density {} kg/m^3: must be >= 0 and below the particle density {}",
                self.fluid_density_kg_m3, self.density_kg_m3
            ));
        }
        if !self.gravity_m_s2.iter().all(|g| g.is_finite()) {
            return invalid("gravity: must be finite");
        }
        self.top.check()?;
        if let ImpactSpeed::Given { m_s } = self.impact_speed {
            if !(m_s.is_finite() && m_s >= 0.0) {
                return invalid(format!("impact speed {m_s} m/s: must be >= 0 and finite"));
            }
        }
        if let Some(skin) = self.skin_m {
            require_positive(skin, || format!("neighbour skin {skin} m"))?;
        }
        Ok(())
    }

    /// The particles at the start: the dispersion made (see [`Start::Dispersed`]) or a copy of
    /// the given ones.
    pub fn start_particles(&self) -> Result<Particles> {
        match &self.start {
            Start::Dispersed { radius, seed } => start::dispersed(
                radius,
                self.lx_m,
                self.ly_m,
                self.top.z0_m(),
                self.density_kg_m3,
                *seed,
            ),
            Start::Given(p) => Ok(p.clone()),
        }
    }

    /// Smallest radius of the start (1 m without particles).
    pub fn r_min_m(&self) -> f64 {
        let r = self.start.radii();
        if r.is_empty() {
            1.0
        } else {
            r.iter().cloned().fold(f64::INFINITY, f64::min)
        }
    }

    /// The relative impact speed of the time-step rule (m/s; see [`ImpactSpeed`]).
    pub fn impact_speed_m_s(&self) -> f64 {
        let wall = self.top.speed_max_m_s();
        let v = match self.impact_speed {
            ImpactSpeed::Given { m_s } => m_s,
            ImpactSpeed::FromDrivers => {
                let fall = (2.0 * self.gravity_m_s2.z.abs() * self.top.z0_m()).sqrt();
                let fluid = self.drag.map_or(0.0, |d| d.fluid_velocity_m_s.norm());
                fall + 2.0 * fluid + 2.0 * wall
            }
        };
        v.max(wall)
    }

    /// The time step (s): automatic, or the given one once checked ([`Setup::check_time_step`]).
    pub fn time_step_s(&self) -> Result<f64> {
        match self.time_step {
            TimeStep::Automatic => Ok(auto_time_step(
                self,
                self.r_min_m(),
                self.impact_speed_m_s(),
            )),
            TimeStep::Given { dt_s } => self.check_time_step(dt_s, self.impact_speed_m_s()),
        }
    }

    /// `dt_s` when it is positive and at most t_c / 10 at impact speed `v_scale` and the
    /// Rayleigh time (see [`contact_times`]); an error naming both otherwise.
    pub fn check_time_step(&self, dt_s: f64, v_scale: f64) -> Result<f64> {
        require_positive(dt_s, || format!("time step dt {dt_s} s"))?;
        let r_min = self.r_min_m();
        let (tc, tr) = contact_times(self, r_min, v_scale);
        if dt_s > MAX_CONTACT_TIME_FRACTION * tc || dt_s > tr {
            let dt_auto = auto_time_step(self, r_min, v_scale);
            return invalid(format!(
                "time step dt = {dt_s:e} s: too large for the stiffness; the contact time of the \
                 lightest pair is {tc:e} s (limit t_c/10 = {:e} s){}; the automatic step would \
                 be {dt_auto:e} s",
                MAX_CONTACT_TIME_FRACTION * tc,
                if tr.is_finite() {
                    format!(" and the Rayleigh time {tr:e} s")
                } else {
                    String::new()
                }
            ));
        }
        Ok(dt_s)
    }

    /// The neighbour-list skin (m): the given one, or 0.3 times the smallest diameter.
    pub fn skin_or_default_m(&self) -> f64 {
        self.skin_m.unwrap_or(0.6 * self.r_min_m())
    }
}

#[cfg(test)]
pub(super) mod testing {
    //! Setups for the engine's own tests.
    use super::*;
    use crate::dem::model::{DampingModel, NormalModel, TangentialModel};

    /// A bed like the built-in scene `dem-small` with `n` spheres d = 400 um (2500 kg/m^3,
    /// Hertz–Mindlin E = 1e7 Pa, nu = 0.3, e = 0.5, mu = 0.3, gravity) dispersed at `porosity`
    /// in a 1.59 x 1.59 mm periodic box.
    pub(crate) fn small_bed(n: usize, porosity: f64) -> Setup {
        let (d, l) = (4e-4, 1.59e-3);
        let radius: Vec<f64> = vec![0.5 * d; n];
        let solid: f64 = radius.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
        let contact = ContactModel::new(
            NormalModel::Hertz,
            DampingModel::restitution(0.5).unwrap(),
            TangentialModel::mindlin(0.3, 1.0).unwrap(),
        )
        .unwrap();
        let h = solid / ((1.0 - porosity) * l * l);
        // the stream the scene draws its dispersion from (seed 1)
        let start = Start::Dispersed {
            radius,
            seed: 1 ^ 0x5eed_d15c,
        };
        let material = Material::new(1e7, 0.3).unwrap();
        let mut s = Setup::in_box([l, l, h], contact, material, 2500.0, start);
        s.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
        s
    }
}
