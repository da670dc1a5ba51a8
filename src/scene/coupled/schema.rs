//! The coupled scene file: its schema (serde, unknown keys refused by name; the `[dem]` table
//! is a DEM scene file without its `kind`, read by the DEM scene's own schema; the overlap and
//! drag switch as tagged enums) and its reading into the engine's [`Setup`].

use crate::coupled::{Basesheet, Overlap, Setup, Switch};
use crate::error::{invalid, Error};
use crate::lbm::{CollisionKind, CollisionModel, LatticeKind, Tau};
use crate::scene::dem::{DemFile, DemScene};
use crate::scene::keys::{collision_kind, lattice_kind, parse_renamed};
use crate::Result;
use nalgebra::Vector3;
use serde::Deserialize;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    kind: String,
    #[serde(default)]
    title: String,
    dem: DemFile,
    fluid: FluidSpec,
    #[serde(default)]
    coupling: CouplingSpec,
    output: OutputSpec,
}

fn d3q15() -> LatticeKind {
    LatticeKind::D3Q15
}

fn bgk() -> CollisionKind {
    CollisionKind::Bgk
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct FluidSpec {
    dx_m: f64,
    #[serde(default = "d3q15", deserialize_with = "lattice_kind")]
    lattice: LatticeKind,
    #[serde(default = "bgk", deserialize_with = "collision_kind")]
    collision: CollisionKind,
    tau: Option<f64>,
    density_kg_m3: Option<f64>,
    viscosity_pa_s: Option<f64>,
    pressure_gradient_pa_m: Option<[f64; 3]>,
    balance_weight: Option<bool>,
    basesheet: Option<BasesheetSpec>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct BasesheetSpec {
    thickness_m: f64,
    permeability_m2: f64,
}

/// How a particle's solid volume is shared among the cells it overlaps.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum OverlapSpec {
    #[default]
    Exact,
    SeedLens,
}

/// The switch between the Ergun and Wen–Yu drag.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum SwitchSpec {
    #[default]
    Blend,
    Sharp,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct CouplingSpec {
    #[serde(default)]
    overlap: OverlapSpec,
    #[serde(default)]
    drag_switch: SwitchSpec,
    eps_min: Option<f64>,
    dem_steps_per_lbm_step: Option<u64>,
    max_move_cells: Option<f64>,
    max_relaxation: Option<f64>,
    frozen: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputSpec {
    time_s: f64,
    max_cell_updates: Option<f64>,
    frames_every_s: Option<f64>,
    profile_every_s: Option<f64>,
}

/// A parsed coupled scene: the engine's setup and the run's length and outputs.
pub struct CoupledScene {
    pub title: String,
    /// The `[dem]` table as a DEM scene (its setup is the coupled setup's `dem`).
    pub dem: DemScene,
    pub setup: Setup,
    pub time_s: f64,
    /// The work limit: lattice cells times LBM steps.
    pub max_cell_updates: f64,
    pub frames_every_s: f64,
    pub profile_every_s: f64,
}

fn positive(origin: &str, key: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        invalid(format!("{origin}: {key} = {v}: must be positive"))
    }
}

/// Parses a coupled scene; every error names the key, the value and the rule.
pub fn parse_scene(text: &str, origin: &str) -> Result<CoupledScene> {
    let f: SceneFile = parse_renamed(text, origin).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("coupled scene: {e}"),
    })?;
    if f.kind != "coupled" {
        return invalid(format!(
            "{origin}: kind = \"{}\": a coupled scene needs kind = \"coupled\"",
            f.kind
        ));
    }
    if let Some(kind) = f.dem.kind() {
        return invalid(format!(
            "{origin}: dem.kind = \"{kind}\": the [dem] table is a DEM scene without its kind"
        ));
    }
    if let Some(key) = f.dem.fluid_keys().first() {
        return invalid(format!(
            "{origin}: dem.{key}: not allowed in a coupled scene (the fluid is the [fluid] \
             table's lattice-Boltzmann flow)"
        ));
    }
    let rho_f = positive(
        origin,
        "fluid.density_kg_m3",
        f.fluid.density_kg_m3.unwrap_or(1000.0),
    )?;
    let fingerprint = format!("{:016x}", crate::io::fnv1a64(text.as_bytes()));
    let dem = f
        .dem
        .with_fluid_density(rho_f)
        .into_scene(&format!("{origin} [dem]"), fingerprint)?;
    let dx = positive(origin, "fluid.dx_m", f.fluid.dx_m)?;
    let tau = f.fluid.tau.unwrap_or(0.8);
    let tau =
        Tau::new(tau).map_err(|e| Error::InvalidInput(format!("{origin}: fluid.tau: {e}")))?;
    let time_s = positive(origin, "output.time_s", f.output.time_s)?;
    let frames = f.output.frames_every_s.unwrap_or(time_s);
    let prof = f.output.profile_every_s.unwrap_or(time_s / 20.0);
    positive(origin, "output.frames_every_s", frames)?;
    positive(origin, "output.profile_every_s", prof)?;
    let c = &f.coupling;
    let setup = Setup {
        dem: dem.setup.clone(),
        dx_m: dx,
        lattice: f.fluid.lattice,
        collision: CollisionModel::new(f.fluid.collision, tau),
        fluid_density_kg_m3: rho_f,
        viscosity_pa_s: f.fluid.viscosity_pa_s.unwrap_or(1e-3),
        overlap: match c.overlap {
            OverlapSpec::Exact => Overlap::Exact,
            OverlapSpec::SeedLens => Overlap::SeedLens,
        },
        switch: match c.drag_switch {
            SwitchSpec::Blend => Switch::Blend,
            SwitchSpec::Sharp => Switch::Sharp,
        },
        eps_min: c.eps_min.unwrap_or(0.1),
        grad_p_pa_m: Vector3::from(f.fluid.pressure_gradient_pa_m.unwrap_or([0.0; 3])),
        balance_weight: f.fluid.balance_weight.unwrap_or(false),
        dem_steps: c.dem_steps_per_lbm_step.unwrap_or(100),
        max_move_cells: c.max_move_cells.unwrap_or(0.1),
        max_relaxation: c.max_relaxation.unwrap_or(0.5),
        frozen: c.frozen.unwrap_or(false),
        basesheet: f.fluid.basesheet.as_ref().map(|b| Basesheet {
            thickness_m: b.thickness_m,
            permeability_m2: b.permeability_m2,
        }),
    };
    Ok(CoupledScene {
        title: f.title,
        dem,
        setup,
        time_s,
        max_cell_updates: positive(
            origin,
            "output.max_cell_updates",
            f.output.max_cell_updates.unwrap_or(super::MAX_CELL_UPDATES),
        )?,
        frames_every_s: frames,
        profile_every_s: prof,
    })
}
