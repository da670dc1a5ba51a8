//! The LBM scene file: its schema (serde; every key refused where it does not belong, by name)
//! and the checks that turn it into a [`Plan`]: a flow as one of the engine's problems in
//! lattice units with its SI conversion, or a packing's configuration with the options of its
//! permeability run.
//!
//! The file is flat: `flow = "channel"` stands beside the keys every flow has ([`Common`]) and
//! the flow's own keys. The common keys are read first; the flow's keys are then nested under
//! its name, so that serde's enum [`Flow`] picks the flow and the flow's struct refuses the
//! keys of the others, every error naming its key (an internally tagged enum would buffer the
//! keys and lose their names in type errors).

use crate::error::{invalid, require_positive, Error, Result};
use crate::io::xyz::{self, Cell, XyzParticle};
use crate::lbm::driver::SteadyControl;
use crate::lbm::memory::check_memory;
use crate::lbm::pore::PoreOptions;
use crate::lbm::pore::DEFAULT_WALLS;
use crate::lbm::problems::{Channel, DrivenChannel, Inlet, NodeCouette};
use crate::lbm::units::{check_mach, Units};
use crate::lbm::voxels::voxel_dims;
use crate::lbm::{CollisionKind, CollisionModel, Dims, LatticeKind, Tau, WallRule};
use crate::scene::keys::{collision_kind, lattice_kind, rename_old_keys};
use crate::scene::read_configuration;
use serde::Deserialize;

/// The keys every flow has: the fields of [`Common`].
const COMMON_KEYS: [&str; 12] = [
    "kind",
    "title",
    "lattice",
    "collision",
    "tau",
    "nu_m2_s",
    "density_kg_m3",
    "length_m",
    "cells",
    "tol",
    "check_every",
    "max_steps",
];

fn default_lattice() -> LatticeKind {
    LatticeKind::D3Q19
}
fn default_collision() -> CollisionKind {
    CollisionKind::Trt
}
fn one() -> f64 {
    1.0
}
fn tol() -> f64 {
    1e-9
}
fn check() -> u64 {
    200
}
fn max_steps() -> u64 {
    1_000_000
}

/// The keys every flow has ([`COMMON_KEYS`]). The fluid on a lattice of its own (`nu_m2_s`,
/// `density_kg_m3`, `length_m`, `cells`) is refused for a packing, whose lattice follows from
/// its configuration.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Common {
    #[allow(dead_code)]
    kind: String,
    #[allow(dead_code)]
    #[serde(default)]
    title: String,
    #[serde(default = "default_lattice", deserialize_with = "lattice_kind")]
    lattice: LatticeKind,
    #[serde(default = "default_collision", deserialize_with = "collision_kind")]
    collision: CollisionKind,
    #[serde(default = "one")]
    tau: f64,
    nu_m2_s: Option<f64>,
    density_kg_m3: Option<f64>,
    length_m: Option<f64>,
    cells: Option<usize>,
    #[serde(default = "tol")]
    tol: f64,
    #[serde(default = "check")]
    check_every: u64,
    #[serde(default = "max_steps")]
    max_steps: u64,
}

/// The flow and its own keys.
#[derive(Debug, Clone, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum Flow {
    Channel(ChannelKeys),
    PorousChannel(PorousChannelKeys),
    PorousCouette(PorousCouetteKeys),
    PressureChannel(PressureChannelKeys),
    SphereArray(SphereArrayKeys),
    Packing(PackingKeys),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ChannelKeys {
    acceleration_m_s2: Option<f64>,
    wall_velocity_m_s: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PorousChannelKeys {
    acceleration_m_s2: Option<f64>,
    porosity: f64,
    permeability_m2: f64,
    forchheimer: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PorousCouetteKeys {
    wall_velocity_m_s: f64,
    porosity: f64,
    permeability_m2: f64,
    forchheimer: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PressureChannelKeys {
    channel_length_m: f64,
    pressure_drop_pa: Option<f64>,
    inlet_velocity_m_s: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereArrayKeys {
    acceleration_m_s2: Option<f64>,
    solid_fraction: f64,
    walls: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PackingKeys {
    xyz: String,
    resolution: usize,
    unit_m: Option<f64>,
    force_lattice: Option<f64>,
    walls: Option<String>,
}

/// The wall rule of the key `walls` ("staircase" or "interpolated"), [`DEFAULT_WALLS`] where
/// absent (the default of `porelab permeability --walls` too).
fn wall_rule(walls: &Option<String>) -> Result<WallRule> {
    walls
        .as_deref()
        .map_or(Ok(DEFAULT_WALLS), |w| WallRule::parse(w, "walls"))
}

/// What a scene runs: a flow on a lattice of its own, or the permeability of a configuration.
pub(super) enum Plan {
    Flow(Box<FlowPlan>),
    Packing(Box<PackingPlan>),
}

/// The engine's problem a flow scene runs (lattice units).
pub(super) enum Problem {
    /// "channel" and "porous-channel".
    Channel(Channel),
    /// "porous-couette".
    Couette(NodeCouette),
    /// "pressure-channel".
    Driven(DrivenChannel),
    /// "sphere-array": the simple cubic array of this solid fraction under body force `g`,
    /// with the walls `walls`.
    SphereArray {
        solid_fraction: f64,
        g: f64,
        walls: WallRule,
    },
}

/// A flow scene checked and converted: everything the run fixes before it builds a lattice.
pub(super) struct FlowPlan {
    /// The value of `flow`.
    pub flow: String,
    pub lattice: LatticeKind,
    pub collision: CollisionModel,
    pub units: Units,
    /// Cells across `length_m`.
    pub n: usize,
    pub length_m: f64,
    pub problem: Problem,
    pub ctl: SteadyControl,
    /// A-priori velocity scale (lattice units), for the Mach check and the log.
    pub u_est: f64,
}

/// A packing scene: the configuration read and checked, and the options of its run.
pub(super) struct PackingPlan {
    pub flow: String,
    /// Where the configuration was read from, and its text.
    pub source: String,
    pub text: String,
    pub cell: Cell,
    pub parts: Vec<XyzParticle>,
    pub resolution: usize,
    pub unit_m: Option<f64>,
    pub options: PoreOptions,
}

/// Bytes per cell a scene holds besides the solver's populations and mask: the steady
/// fields (velocity, density), their SI copies, the solid and porosity fields of the output,
/// and the scene's own mask.
const SCENE_PER_CELL: usize = 32 + 32 + 16 + 2;
/// Bytes per cell of the Guo-Zhao porous medium (porosity, two drag coefficients, matrix
/// velocity).
const POROUS_PER_CELL: usize = 48;

/// Parses and checks a scene text (read from `origin`) into its plan, refusing a lattice
/// larger than the memory available and a flow whose estimated Mach number is too high
/// before anything is allocated.
pub(super) fn prepare(text: &str, origin: &str) -> Result<Plan> {
    let (common, name, flow) = parse(text, origin)?;
    let collision = CollisionModel::new(common.collision, Tau::new(common.tau)?);
    let ctl = SteadyControl {
        check_every: common.check_every,
        tol: common.tol,
        max_steps: common.max_steps,
    };
    match flow {
        Flow::Packing(keys) => prepare_packing(&common, name, keys, (collision, ctl), origin)
            .map(|p| Plan::Packing(Box::new(p))),
        flow => {
            prepare_flow(&common, name, flow, (collision, ctl)).map(|p| Plan::Flow(Box::new(p)))
        }
    }
}

/// The file's common keys, the value of `flow` and the flow with its keys (old key spellings
/// renamed, with a note).
fn parse(text: &str, origin: &str) -> Result<(Common, String, Flow)> {
    let refused = |msg: String| Error::File {
        path: origin.to_string(),
        msg: msg.trim_end().to_string(),
    };
    let mut table: toml::Table = toml::from_str(text).map_err(|e| refused(e.to_string()))?;
    rename_old_keys(&mut table, origin);
    let name = match table.remove("flow") {
        Some(toml::Value::String(s)) => s,
        Some(v) => {
            return Err(refused(format!(
                "flow = {v}: must be a string naming the flow"
            )))
        }
        None => return Err(refused("missing key `flow` (the flow to run)".into())),
    };
    let mut common = toml::Table::new();
    for key in COMMON_KEYS {
        if let Some(v) = table.remove(key) {
            common.insert(key.to_string(), v);
        }
    }
    let common = Common::deserialize(common).map_err(|e| refused(e.to_string()))?;
    let mut nested = toml::Table::new();
    nested.insert(name.clone(), toml::Value::Table(table));
    let flow = Flow::deserialize(nested).map_err(|e| refused(format!("flow = \"{name}\": {e}")))?;
    Ok((common, name, flow))
}

fn need<T>(v: Option<T>, key: &str, flow: &str) -> Result<T> {
    v.ok_or_else(|| Error::InvalidInput(format!("flow = \"{flow}\" needs key `{key}`")))
}

/// (eps, K in lattice units, Forchheimer on) of the porous flows' keys.
fn medium(u: &Units, eps: f64, k_si: f64, forchheimer: Option<bool>) -> Result<(f64, f64, bool)> {
    if !(eps > 0.0 && eps <= 1.0) {
        return invalid(format!("porosity = {eps}: must be in (0, 1]"));
    }
    if !(k_si > 0.0 && k_si.is_finite()) {
        return invalid(format!(
            "permeability_m2 = {k_si}: must be positive and finite"
        ));
    }
    Ok((eps, k_si / (u.dx * u.dx), forchheimer.unwrap_or(true)))
}

/// Refuses, before the run, a plain channel (no porous medium, which damps faster) whose
/// slowest diffusive mode across `h` cells, decaying as exp(-pi^2 nu t / h^2), needs more than
/// `max_steps` steps to decay once: such a run would step until max_steps and end unconverged
/// (a channel of 100000 cells at nu = 1/6 needs 6e9 steps).
fn check_diffusion_steps(problem: &Problem, h: f64, nu: f64, max_steps: u64) -> Result<()> {
    let plain = match problem {
        Problem::Channel(ch) => ch.porous.is_none(),
        Problem::Driven(_) => true,
        _ => false,
    };
    let steps = h * h / (std::f64::consts::PI.powi(2) * nu);
    if plain && steps > max_steps as f64 {
        return invalid(format!(
            "cells = {h}: the flow across {h} cells develops in about h^2 / (pi^2 nu) = \
             {steps:.3e} steps (nu = {nu:.4} in lattice units), more than max_steps = \
             {max_steps}: the run would end unconverged; use fewer cells or raise max_steps"
        ));
    }
    Ok(())
}

fn prepare_flow(
    c: &Common,
    name: String,
    flow: Flow,
    (collision, ctl): (CollisionModel, SteadyControl),
) -> Result<FlowPlan> {
    let cells = need(c.cells, "cells", &name)?;
    let length_m = need(c.length_m, "length_m", &name)?;
    if cells < 4 {
        return invalid(format!("cells = {cells}: must be >= 4"));
    }
    // the keys named before the lattice units derived from them (dx, nu, rho)
    for (key, v) in [
        ("length_m", Some(length_m)),
        ("nu_m2_s", c.nu_m2_s),
        ("density_kg_m3", c.density_kg_m3),
    ] {
        if let Some(v) = v {
            require_positive(v, || format!("{key} = {v}"))?;
        }
    }
    let u = Units::from_tau(
        length_m / cells as f64,
        c.nu_m2_s.unwrap_or(1e-6),
        c.density_kg_m3.unwrap_or(1000.0),
        c.tau,
    )?;
    let accel = |a: Option<f64>| u.accel_to_lattice(a.unwrap_or(0.0));
    let nu = u.nu_lattice();
    let h = cells as f64;
    // the problem and an a-priori velocity scale (lattice units) for the Mach check
    let (problem, u_est) = match flow {
        Flow::Channel(k) => {
            let (g, wall_u) = (
                accel(k.acceleration_m_s2),
                u.velocity_to_lattice(k.wall_velocity_m_s.unwrap_or(0.0)),
            );
            let ch = Channel {
                h: cells,
                g,
                wall_u,
                porous: None,
            };
            (
                Problem::Channel(ch),
                g.abs() * h * h / (8.0 * nu) + wall_u.abs(),
            )
        }
        Flow::PorousChannel(k) => {
            let g = accel(k.acceleration_m_s2);
            let porous = medium(&u, k.porosity, k.permeability_m2, k.forchheimer)?;
            let ch = Channel {
                h: cells,
                g,
                wall_u: 0.0,
                porous: Some(porous),
            };
            let est = (g.abs() * h * h / (8.0 * nu)).min(g.abs() * porous.1 / nu);
            (Problem::Channel(ch), est)
        }
        Flow::PorousCouette(k) => {
            let porous = medium(&u, k.porosity, k.permeability_m2, k.forchheimer)?;
            let u_wall = u.velocity_to_lattice(k.wall_velocity_m_s);
            let couette = NodeCouette {
                h: cells,
                u_wall,
                porous,
            };
            (Problem::Couette(couette), u_wall.abs())
        }
        Flow::PressureChannel(k) => driven_channel(&u, cells, k)?,
        Flow::SphereArray(k) => {
            let (phi, g) = (k.solid_fraction, accel(k.acceleration_m_s2));
            if !(phi > 0.0 && phi <= std::f64::consts::PI / 6.0) {
                return invalid(format!("solid_fraction = {phi}: must be in (0, pi/6]"));
            }
            if g <= 0.0 {
                return invalid("sphere-array: acceleration_m_s2 must be > 0 (it drives the flow)");
            }
            let array = Problem::SphereArray {
                solid_fraction: phi,
                g,
                walls: wall_rule(&k.walls)?,
            };
            (array, g * h * h / (8.0 * nu))
        }
        Flow::Packing(_) => return invalid("flow = \"packing\": not a lattice flow"),
    };
    // the lattice each flow builds, refused before anything is allocated
    let (dims, porous_fields) = match &problem {
        Problem::Channel(ch) => (ch.dims()?, ch.porous.map_or(0, |_| POROUS_PER_CELL)),
        Problem::Couette(couette) => (couette.dims()?, POROUS_PER_CELL),
        Problem::Driven(ch) => (ch.dims()?, 0),
        Problem::SphereArray { .. } => (Dims::new(cells, cells, cells)?, 0),
    };
    check_memory(dims, c.lattice.q(), SCENE_PER_CELL + porous_fields)?;
    check_diffusion_steps(&problem, h, nu, ctl.max_steps)?;
    check_mach(u_est, "estimated peak velocity")?;
    Ok(FlowPlan {
        flow: name,
        lattice: c.lattice,
        collision,
        units: u,
        n: cells,
        length_m,
        problem,
        ctl,
        u_est,
    })
}

/// The pressure-driven channel of `cells` cells across: its length a whole number of cells,
/// driven by exactly one of a pressure drop and a parabolic inlet.
fn driven_channel(u: &Units, cells: usize, k: PressureChannelKeys) -> Result<(Problem, f64)> {
    let (h, nu) = (cells as f64, u.nu_lattice());
    let len_m = k.channel_length_m;
    let along = len_m / u.dx;
    let length = along.round() as usize;
    if !(len_m.is_finite() && length >= 2 && (along - length as f64).abs() <= 1e-6 * along) {
        return invalid(format!(
            "channel_length_m = {len_m}: must be a whole number (>= 2) of cells of dx = {:e} m \
             (it is {along} cells)",
            u.dx
        ));
    }
    let (inlet, est) = match (k.pressure_drop_pa, k.inlet_velocity_m_s) {
        (Some(dp), None) => {
            // lattice pressure c_s^2 rho: drho = 3 dp dt^2 / (rho dx^2)
            let drho = 3.0 * dp * u.dt * u.dt / (u.rho * u.dx * u.dx);
            if !(drho.is_finite() && drho.abs() < 0.2) {
                return invalid(format!(
                    "pressure_drop_pa = {dp}: a density difference of {drho:.3e} (lattice \
                     units) must be finite and below 0.2 in magnitude (compressibility); lower \
                     the pressure drop or refine the lattice"
                ));
            }
            let grad = drho / (3.0 * length as f64);
            (
                Inlet::Density(1.0 + 0.5 * drho),
                grad.abs() * h * h / (8.0 * nu),
            )
        }
        (None, Some(v)) => {
            let ul = u.velocity_to_lattice(v);
            (Inlet::Parabola(ul), ul.abs())
        }
        _ => {
            return invalid(
                "flow = \"pressure-channel\" needs exactly one of pressure_drop_pa and \
                 inlet_velocity_m_s",
            )
        }
    };
    let rho_out = match inlet {
        Inlet::Density(rho_in) => 2.0 - rho_in,
        Inlet::Parabola(_) => 1.0,
    };
    let ch = DrivenChannel {
        h: cells,
        length,
        inlet,
        rho_out,
    };
    Ok((Problem::Driven(ch), est))
}

/// Configurations that built-in scenes name in `xyz` (a built-in has no folder of its own).
const BUILTIN_XYZ: [(&str, &str); 1] = [(
    "lbm-packing.xyz",
    include_str!("../builtin/lbm-packing.xyz"),
)];

/// (where, text) of the configuration `xyz` names ([`read_configuration`]).
fn read_xyz(xyz: &str, origin: &str) -> Result<(String, String)> {
    read_configuration(
        xyz,
        "xyz",
        origin,
        &BUILTIN_XYZ,
        " (a built-in scene's configuration is in its run folder as configuration.xyz)",
    )
}

fn prepare_packing(
    c: &Common,
    name: String,
    k: PackingKeys,
    (collision, ctl): (CollisionModel, SteadyControl),
    origin: &str,
) -> Result<PackingPlan> {
    for (key, given) in [
        ("nu_m2_s", c.nu_m2_s.is_some()),
        ("density_kg_m3", c.density_kg_m3.is_some()),
        ("length_m", c.length_m.is_some()),
        ("cells", c.cells.is_some()),
    ] {
        if given {
            return invalid(format!(
                "{key}: only the flows on a lattice of their own have it, not flow = \
                 \"packing\" (its lattice follows from the configuration and `resolution`)"
            ));
        }
    }
    if let Some(u) = k.unit_m {
        if !(u > 0.0 && u.is_finite()) {
            return invalid(format!("unit_m = {u}: must be positive and finite"));
        }
    }
    let (source, text) = read_xyz(&k.xyz, origin)?;
    let (cell, parts) = xyz::parse(&text, &source)?;
    let force = (k.force_lattice.unwrap_or(1e-6), "force_lattice");
    let options =
        PoreOptions::new(c.lattice, collision, force, ctl)?.with_walls(wall_rule(&k.walls)?);
    let (dims, _) = voxel_dims(&cell, k.resolution)?;
    check_memory(dims, c.lattice.q(), SCENE_PER_CELL)?;
    Ok(PackingPlan {
        flow: name,
        source,
        text,
        cell,
        parts,
        resolution: k.resolution,
        unit_m: k.unit_m,
        options,
    })
}
