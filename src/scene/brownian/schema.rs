//! The Brownian scene file: its schema (serde, unknown keys refused by name, every choice an
//! enum) and the [`CaptureExperiment`] of each point of its sweep, checked before anything
//! runs, with errors that name the file, the key, the value and the rule.

use crate::brownian::experiment::{
    table_6_1_moment, CaptureExperiment, CylinderSetup, MagnetizationLaw, Placement, RegionShape,
};
use crate::brownian::{Fluid, Hydrodynamics, LangevinMoment, NoiseMethod, StepGuard};
use crate::consts::MU0;
use crate::error::{invalid, Error, Result};
use crate::scene::keys::parse_renamed;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Scene {
    #[allow(dead_code)]
    pub(super) kind: String,
    #[serde(default)]
    pub(super) title: String,
    #[serde(default = "d_experiment")]
    pub(super) experiment: ExperimentKind,
    #[serde(default)]
    pub(super) run: RunSection,
    #[serde(default)]
    pub(super) fluid: FluidSection,
    #[serde(default)]
    pub(super) particles: ParticlesSection,
    #[serde(default)]
    pub(super) cylinder: CylinderSection,
    #[serde(default)]
    pub(super) field: FieldSection,
    #[serde(default)]
    pub(super) forces: ForcesSection,
    #[serde(default)]
    pub(super) hydrodynamics: HydroSection,
    #[serde(default)]
    pub(super) sweep: Sweep,
    #[serde(default)]
    pub(super) cascade: CascadeSection,
    #[serde(default)]
    pub(super) capture_volume: VolumeSection,
}

fn d_experiment() -> ExperimentKind {
    ExperimentKind::Capture
}

/// String choices of the schema: serde rejects any other value, naming it and the choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum ExperimentKind {
    Capture,
    Cascade,
    CaptureVolume,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum GuardKind {
    Refuse,
    Substep,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum MomentLaw {
    Fixed,
    Langevin,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum PlacementKind {
    TopSide,
    Uniform,
    Block,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum MagnetizationKind {
    StonerWohlfarth,
    FixedAngle,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum MobilityKind {
    FreeDraining,
    Oseen,
    Rpy,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum NoiseKind {
    Cholesky,
    TeaHi,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum CascadeKind {
    Random,
    Optimal,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RunSection {
    pub(super) seed: u64,
    pub(super) runs: u64,
    pub(super) t_max_s: f64,
    pub(super) dt_s: f64,
    pub(super) sample_every_s: f64,
    pub(super) guard: GuardKind,
    pub(super) max_step_radii: f64,
    pub(super) max_halvings: u32,
}

impl Default for RunSection {
    fn default() -> Self {
        RunSection {
            seed: 2013,
            runs: 30,
            t_max_s: 50.0,
            dt_s: 5e-5,
            sample_every_s: 0.5,
            guard: GuardKind::Substep,
            max_step_radii: 0.5,
            max_halvings: 20,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct FluidSection {
    pub(super) temperature_K: f64,
    /// Read also as `viscosity_Pa_s` (its earlier spelling, with a note).
    pub(super) viscosity_pa_s: f64,
}

impl Default for FluidSection {
    fn default() -> Self {
        FluidSection {
            temperature_K: 298.0,
            viscosity_pa_s: 1.0e-3,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct ParticlesSection {
    pub(super) radius_m: f64,
    /// Moment magnitude (A m^2); default: Table 6.1 for the radius.
    pub(super) moment_A_m2: Option<f64>,
    /// Fixed (Table 6.1) or Langevin (eq. 6.22, needs domain_moment_A_m2).
    pub(super) moment_law: MomentLaw,
    pub(super) domain_moment_A_m2: Option<f64>,
    pub(super) placement: PlacementKind,
    pub(super) n_top: usize,
    pub(super) n_side: usize,
    pub(super) region_gap_m: f64,
    pub(super) region_thickness_m: f64,
    /// Particles of the "uniform" (default 100) and "block" (default 500) placements.
    pub(super) n: Option<usize>,
    pub(super) concentration_g_per_mL: f64,
    pub(super) density_g_per_cm3: f64,
    pub(super) block_distance_m: f64,
    pub(super) chain_bond_factor: f64,
}

impl Default for ParticlesSection {
    fn default() -> Self {
        ParticlesSection {
            radius_m: 75e-9,
            moment_A_m2: None,
            moment_law: MomentLaw::Fixed,
            domain_moment_A_m2: None,
            placement: PlacementKind::TopSide,
            n_top: 50,
            n_side: 50,
            region_gap_m: 1e-6,
            region_thickness_m: 300e-6,
            n: None,
            concentration_g_per_mL: 1.0,
            density_g_per_cm3: 5.0,
            block_distance_m: 100e-6,
            chain_bond_factor: 1.1,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct CylinderSection {
    pub(super) diameter_m: f64,
    pub(super) aspect_ratio: f64,
    pub(super) alpha_deg: f64,
    pub(super) magnetization: MagnetizationKind,
    pub(super) magnetization_angle_deg: Option<f64>,
    pub(super) saturation_a_per_m: f64,
}

impl Default for CylinderSection {
    fn default() -> Self {
        CylinderSection {
            diameter_m: 600e-6,
            aspect_ratio: 20.0,
            alpha_deg: 90.0,
            magnetization: MagnetizationKind::StonerWohlfarth,
            magnetization_angle_deg: None,
            saturation_a_per_m: 985e3,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct FieldSection {
    /// Applied flux density mu0 H0 (T), along +x.
    pub(super) b_T: f64,
}

impl Default for FieldSection {
    fn default() -> Self {
        FieldSection { b_T: 1.0 }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct ForcesSection {
    pub(super) mie: bool,
    pub(super) mie_n: i32,
    pub(super) mie_m: i32,
    pub(super) mie_epsilon_kT: f64,
    pub(super) dipole_pairs: bool,
    pub(super) dipole_cutoff_radii: f64,
}

impl Default for ForcesSection {
    fn default() -> Self {
        ForcesSection {
            mie: true,
            mie_n: 30,
            mie_m: 15,
            mie_epsilon_kT: 100.0,
            dipole_pairs: true,
            dipole_cutoff_radii: 30.0,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct HydroSection {
    pub(super) mobility: MobilityKind,
    pub(super) noise: NoiseKind,
}

impl Default for HydroSection {
    fn default() -> Self {
        HydroSection {
            mobility: MobilityKind::Rpy,
            noise: NoiseKind::TeaHi,
        }
    }
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub(super) struct Sweep {
    pub(super) alpha_deg: Vec<f64>,
    pub(super) radius_m: Vec<f64>,
    pub(super) aspect_ratio: Vec<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct CascadeSection {
    pub(super) modes: Vec<CascadeKind>,
    pub(super) stages: usize,
    pub(super) stage_time_s: f64,
}

impl Default for CascadeSection {
    fn default() -> Self {
        CascadeSection {
            modes: vec![CascadeKind::Random, CascadeKind::Optimal],
            stages: 20,
            stage_time_s: 0.5,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct VolumeSection {
    pub(super) force_cutoff_N: f64,
    pub(super) margin_m: f64,
    pub(super) plane_points: usize,
    pub(super) grid: usize,
}

impl Default for VolumeSection {
    fn default() -> Self {
        VolumeSection {
            force_cutoff_N: 0.5e-15,
            margin_m: 4e-3,
            plane_points: 101,
            grid: 64,
        }
    }
}

/// Parses a Brownian scene (old key spellings renamed, with a note); unknown keys and bad
/// values are errors naming them.
pub(super) fn parse(text: &str, origin: &str) -> Result<Scene> {
    let scene: Scene = parse_renamed(text, origin).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: e.to_string(),
    })?;
    scene.check_positive(origin)?;
    Ok(scene)
}

impl Scene {
    /// Refuses a size, time or count of the file that must be positive, naming its key (the
    /// engine would meet some of them only deep in a run: a cascade's stage, the capture map).
    fn check_positive(&self, origin: &str) -> Result<()> {
        let p = &self.particles;
        let keys = [
            ("run.max_step_radii", self.run.max_step_radii),
            ("particles.region_thickness_m", p.region_thickness_m),
            ("particles.concentration_g_per_mL", p.concentration_g_per_mL),
            ("particles.density_g_per_cm3", p.density_g_per_cm3),
            ("particles.block_distance_m", p.block_distance_m),
            ("particles.chain_bond_factor", p.chain_bond_factor),
            ("cylinder.diameter_m", self.cylinder.diameter_m),
            ("cylinder.aspect_ratio", self.cylinder.aspect_ratio),
            ("cascade.stage_time_s", self.cascade.stage_time_s),
            (
                "capture_volume.force_cutoff_N",
                self.capture_volume.force_cutoff_N,
            ),
            ("capture_volume.margin_m", self.capture_volume.margin_m),
        ];
        for (key, v) in keys {
            if !(v.is_finite() && v > 0.0) {
                return invalid(format!(
                    "{origin}: {key} = {v}: must be positive and finite"
                ));
            }
        }
        let gap = p.region_gap_m;
        if !(gap.is_finite() && gap >= 0.0) {
            return invalid(format!(
                "{origin}: particles.region_gap_m = {gap}: must be finite and not negative"
            ));
        }
        Ok(())
    }
}

/// One point of the sweep.
#[derive(Debug, Clone, Copy)]
pub(super) struct Combo {
    pub(super) alpha_deg: f64,
    pub(super) radius_m: f64,
    pub(super) aspect_ratio: f64,
}

impl Scene {
    /// Particles of one run.
    pub(super) fn particle_count(&self) -> usize {
        let p = &self.particles;
        match p.placement {
            PlacementKind::TopSide => p.n_top + p.n_side,
            PlacementKind::Uniform => p.n.unwrap_or(100),
            PlacementKind::Block => p.n.unwrap_or(500),
        }
    }

    /// Estimated memory of the runs in flight: with hydrodynamic interactions the 3N x 3N
    /// mobility and its factor (2 x 72 N^2 bytes), plus about 1 kB a particle, per parallel run.
    pub(super) fn memory_estimate_bytes(&self, threads: usize) -> f64 {
        let n = self.particle_count() as f64;
        let hi = if self.hydrodynamics.mobility == MobilityKind::FreeDraining {
            0.0
        } else {
            2.0 * 72.0 * n * n
        };
        let parallel = (self.run.runs as f64).min(threads.max(1) as f64);
        parallel * (hi + 1024.0 * n)
    }

    pub(super) fn combos(&self) -> Vec<Combo> {
        let or = |v: &Vec<f64>, d: f64| if v.is_empty() { vec![d] } else { v.clone() };
        let mut out = Vec::new();
        for ar in or(&self.sweep.aspect_ratio, self.cylinder.aspect_ratio) {
            for r in or(&self.sweep.radius_m, self.particles.radius_m) {
                for al in or(&self.sweep.alpha_deg, self.cylinder.alpha_deg) {
                    out.push(Combo {
                        alpha_deg: al,
                        radius_m: r,
                        aspect_ratio: ar,
                    });
                }
            }
        }
        out
    }

    /// The experiment for one sweep point.
    pub(super) fn experiment(&self, c: Combo) -> Result<CaptureExperiment> {
        let r = &self.run;
        let p = &self.particles;
        // Checked here by key, before a derived quantity (the Mie energy in J, the Table 6.1
        // lookup, an empty mobility matrix) could report the problem under another name.
        let t = self.fluid.temperature_K;
        if self.forces.mie && !(t.is_finite() && t > 0.0) {
            return invalid(format!(
                "fluid.temperature_K = {t}: must be positive and finite (the Mie repulsion's \
                 strength forces.mie_epsilon_kT is in units of kB T; or set forces.mie = false)"
            ));
        }
        let key = if self.sweep.radius_m.is_empty() {
            "particles.radius_m"
        } else {
            "sweep.radius_m"
        };
        if !(c.radius_m.is_finite() && c.radius_m > 0.0) {
            return invalid(format!(
                "{key} = {:e} m: must be positive and finite",
                c.radius_m
            ));
        }
        let count = self.particle_count();
        if count == 0 {
            return invalid(match p.placement {
                PlacementKind::TopSide => {
                    "particles.n_top = 0 and particles.n_side = 0: need at least one particle"
                }
                _ => "particles.n = 0: need at least one particle",
            });
        }
        let fluid = Fluid::new(t, self.fluid.viscosity_pa_s)?;
        if !(r.dt_s.is_finite() && r.dt_s > 0.0) {
            return invalid(format!(
                "run.dt_s = {}: the time step must be positive and finite (s)",
                r.dt_s
            ));
        }
        let moment = p.moment(c.radius_m)?;
        let placement = p.placement(c.radius_m, self.experiment)?;
        let cy = &self.cylinder;
        let (hydrodynamics, noise) = self.hydrodynamics.terms();
        let f = &self.forces;
        let exp = CaptureExperiment {
            fluid,
            dt_s: r.dt_s,
            particle_radius_m: c.radius_m,
            moment,
            placement,
            cylinder: CylinderSetup {
                diameter_m: cy.diameter_m,
                aspect_ratio: c.aspect_ratio,
                saturation_a_per_m: cy.saturation_a_per_m,
                law: cy.law(c.alpha_deg),
            },
            alpha: c.alpha_deg.to_radians(),
            h0: Vector3::new(self.field.b_T / MU0, 0.0, 0.0),
            hydrodynamics,
            noise,
            mie: f.mie.then_some((f.mie_n, f.mie_m, f.mie_epsilon_kT)),
            dipole_cutoff_m: f.dipole_pairs.then_some(f.dipole_cutoff_radii * c.radius_m),
            guard: r.guard(),
            t_max_s: r.t_max_s,
            sample_every_s: r.sample_every_s,
            bond_factor: p.chain_bond_factor,
        };
        exp.validate()?;
        if r.runs == 0 {
            return invalid("run.runs = 0: need at least one run");
        }
        Ok(exp)
    }
}

impl ParticlesSection {
    /// The moment law of particles of radius `radius_m`: `moment_A_m2`, or Table 6.1's.
    fn moment(&self, radius_m: f64) -> Result<LangevinMoment> {
        let magnitude = match self.moment_A_m2 {
            Some(m) => m,
            None => table_6_1_moment(radius_m)?,
        };
        match self.moment_law {
            MomentLaw::Fixed => LangevinMoment::fixed(magnitude),
            MomentLaw::Langevin => LangevinMoment::langevin(
                magnitude,
                self.domain_moment_A_m2.ok_or_else(|| {
                    Error::InvalidInput(
                        "particles.moment_law = \"langevin\" needs particles.domain_moment_A_m2"
                            .into(),
                    )
                })?,
            ),
        }
    }

    /// Where particles of radius `radius_m` start in an `experiment`.
    fn placement(&self, radius_m: f64, experiment: ExperimentKind) -> Result<Placement> {
        Ok(match self.placement {
            PlacementKind::TopSide => Placement::TopSide {
                n_top: self.n_top,
                n_side: self.n_side,
                shape: RegionShape::new(self.region_gap_m, self.region_thickness_m)?,
            },
            PlacementKind::Uniform => {
                // Capture runs report TOP and SIDE separately and average them by volume; a
                // uniform population would leave a run's TOP empty at random.
                if experiment != ExperimentKind::Cascade {
                    return invalid(
                        "particles.placement = \"uniform\" is for experiment = \"cascade\"; \
                         capture runs use \"top-side\" (TOP and SIDE reported separately and \
                         averaged by volume) or \"block\"",
                    );
                }
                Placement::Uniform {
                    n: self.n.unwrap_or(100),
                    shape: RegionShape::new(self.region_gap_m, self.region_thickness_m)?,
                }
            }
            PlacementKind::Block => {
                crate::error::require_positive(self.concentration_g_per_mL, || {
                    format!(
                        "particles.concentration_g_per_mL = {}",
                        self.concentration_g_per_mL
                    )
                })?;
                let vp = 4.0 / 3.0 * std::f64::consts::PI * radius_m.powi(3);
                // Spacing d = (rho V_p / c)^(1/3) (section 6.4.6); g/cm^3 and g/mL cancel.
                let spacing_m = (self.density_g_per_cm3 * vp / self.concentration_g_per_mL).cbrt();
                Placement::Block {
                    n: self.n.unwrap_or(500),
                    spacing_m,
                    distance_m: self.block_distance_m,
                }
            }
        })
    }
}

impl CylinderSection {
    /// How the cylinder at `alpha_deg` from the field is magnetized.
    fn law(&self, alpha_deg: f64) -> MagnetizationLaw {
        match self.magnetization {
            MagnetizationKind::StonerWohlfarth => MagnetizationLaw::StonerWohlfarth,
            // Default angle of M from the axis: alpha, the axis' angle from the field (so M is
            // along the field, saturated; section 6.4.1 fixes M at alpha from the axis).
            MagnetizationKind::FixedAngle => MagnetizationLaw::FixedAngle(
                self.magnetization_angle_deg
                    .unwrap_or(alpha_deg)
                    .to_radians(),
            ),
        }
    }
}

impl HydroSection {
    /// The mobility tensor and the noise method.
    fn terms(&self) -> (Hydrodynamics, NoiseMethod) {
        let mobility = match self.mobility {
            MobilityKind::FreeDraining => Hydrodynamics::FreeDraining,
            MobilityKind::Oseen => Hydrodynamics::Oseen,
            MobilityKind::Rpy => Hydrodynamics::Rpy,
        };
        let noise = match self.noise {
            NoiseKind::Cholesky => NoiseMethod::Cholesky,
            NoiseKind::TeaHi => NoiseMethod::TeaHi,
        };
        (mobility, noise)
    }
}

impl RunSection {
    /// The step guard, in particle radii.
    fn guard(&self) -> StepGuard {
        match self.guard {
            GuardKind::Refuse => StepGuard::Refuse {
                max_fraction: self.max_step_radii,
            },
            GuardKind::Substep => StepGuard::Substep {
                max_fraction: self.max_step_radii,
                max_halvings: self.max_halvings,
            },
        }
    }
}

/// Parses a Brownian scene and builds (and so validates) the experiment of every point of
/// its size/angle sweep, without running anything.
pub(super) fn prepare(
    text: &str,
    origin: &str,
) -> Result<(Scene, Vec<Combo>, Vec<CaptureExperiment>)> {
    let scene = parse(text, origin)?;
    let combos = scene.combos();
    let exps = combos
        .iter()
        .map(|c| scene.experiment(*c))
        .collect::<Result<Vec<_>>>()
        .and_then(|exps| {
            // the cylinder's magnet of every point, as the run builds it first
            for exp in &exps {
                exp.magnet(crate::brownian::experiment::axis_at_angle(exp.alpha))?;
            }
            Ok(exps)
        })
        .map_err(|e| match e {
            Error::InvalidInput(m) if !m.starts_with(origin) => {
                Error::InvalidInput(format!("{origin}: {m}"))
            }
            other => other,
        })?;
    Ok((scene, combos, exps))
}
