//! Lattice-Boltzmann scenes (`kind = "lbm"`): steady flows of [`crate::lbm`] set up in SI.
//!
//! Schema (keys optional unless marked; defaults in brackets):
//!
//! ```toml
//! kind = "lbm"                    # required
//! title = "..."
//! flow = "channel"                # required: "channel" (plane Poiseuille; with
//!                                 # wall_velocity_m_s also Couette) | "porous-channel"
//!                                 # (Guo-Zhao Brinkman-Forchheimer medium between walls)
//!                                 # | "porous-couette" (the same medium between a resting
//!                                 # wall and one sliding at wall_velocity_m_s; walls on the
//!                                 # nodes y = 0 and H by non-equilibrium extrapolation)
//!                                 # | "sphere-array" (simple cubic, periodic)
//!                                 # | "pressure-channel" (plane channel driven through
//!                                 # its ends: inlet/outlet planes by non-equilibrium
//!                                 # extrapolation, Guo, Zheng & Shi 2002)
//!                                 # | "packing" (permeability of an extended XYZ
//!                                 # configuration, as `porelab permeability`)
//! lattice = "D3Q19"               # "D3Q15" | "D3Q19"  [D3Q19]
//! collision = "trt"               # "bgk" | "trt" (Lambda = 3/16)  [trt]
//! tau = 1.0                       # relaxation time (>= 0.505) [1.0]
//! nu_m2_s = 1e-6                  # kinematic viscosity (m^2/s) [1e-6, water]
//! rho_kg_m3 = 1000.0              # density (kg/m^3) [1000]
//! length_m = 1e-3                 # required: channel width H, or the array period L (m)
//! cells = 32                      # required: cells across length_m (>= 4)
//! acceleration_m_s2 = 1e-3        # body force per unit mass along x (m/s^2) [0]
//! wall_velocity_m_s = 0.0         # channel: velocity of the upper wall along x (m/s) [0];
//!                                 # porous-couette: required
//! porosity = 0.5                  # porous-channel, porous-couette: eps in (0, 1]
//! permeability_m2 = 1e-9          # porous-channel, porous-couette: K (m^2)
//! forchheimer = true              # porous-channel, porous-couette: Ergun's term [true]
//! solid_fraction = 0.125          # sphere-array: phi in (0, pi/6]
//! channel_length_m = 2e-3         # pressure-channel: inlet-to-outlet distance (m), a whole
//!                                 # number of cells
//! pressure_drop_pa = 1e-3         # pressure-channel: inlet minus outlet pressure (Pa), or
//! inlet_velocity_m_s = 1e-3       # pressure-channel: peak of a parabolic inlet profile (m/s)
//!                                 # (exactly one of the two; the outlet is at the reference
//!                                 # pressure)
//! xyz = "final.xyz"               # packing, required: porelab extended XYZ (periodic box),
//!                                 # relative to the scene file's folder, or
//!                                 # "builtin:lbm-packing.xyz" (the built-in's)
//! resolution = 32                 # packing, required: cells along the box's x edge
//! unit_m = 1e-3                   # packing: the file's length unit in metres (k in m^2)
//! force_lattice = 1e-6            # packing: body force in lattice units [1e-6]
//!                                 # (packing has no length_m, cells, nu_m2_s, rho_kg_m3)
//! tol = 1e-9                      # stop when <u> changes by less than this per check [1e-9]
//! check_every = 200               # steps between checks [200]
//! max_steps = 1000000             # [1e6]
//! ```
//!
//! Outputs: `fields.vtk` (velocity m/s, density kg/m^3, porosity, solid mask),
//! `profile.csv` for channels (y_m, u_m_s, u_exact_m_s where a closed form exists; for the
//! porous Couette flow with the Forchheimer term, the finite differences of
//! `reference::porous_couette`) and `summary.json` (tau, Mach, Re, steps, residual;
//! permeability for the sphere array). A keyed flow refuses the keys of the other flows by
//! name. `packing` writes `permeability.txt` (what `porelab permeability` prints for one
//! resolution), `summary.json`, `fields.vtk` (lattice units; spacing in m with unit_m) and
//! `configuration.xyz` (the configuration it read).

use super::{on_threads, Builtin, RunOptions};
use crate::error::{invalid, Error, Result};
use crate::io::plot::CsvPlot;
use crate::io::vtk::{write_image_data, CellField};
use crate::io::write_atomic;
use crate::io::xyz::{self, Cell, XyzParticle};
use crate::lbm::choice::{dispatch, CollisionKind, Job, LatticeKind};
use crate::lbm::flows::channel_mask;
use crate::lbm::flows::{
    brinkman_couette, brinkman_poiseuille, channel_coordinate, sphere_array_mask,
};
use crate::lbm::geometry::{Dims, Geometry};
use crate::lbm::pore::{
    self, kozeny_constant, pore_permeability, setup_line, voxel_dims, voxelise, PoreOptions,
};
use crate::lbm::problems::{node_couette, permeability, Channel, DrivenChannel, Inlet};
use crate::lbm::solver::check_memory;
use crate::lbm::steady::{Steady, SteadyControl, SteadyProgress};
use crate::lbm::units::{check_mach, describe, Units};
use crate::lbm::{Collision, Lattice};
use serde::Deserialize;
use std::path::Path;

pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "lbm-channel",
            about: "LBM: plane Poiseuille flow of water in a 1 mm channel (32 cells; seconds)",
            toml: include_str!("builtin/lbm-channel.toml"),
        },
        Builtin {
            name: "lbm-porous-channel",
            about: "LBM: Guo-Zhao porous channel, eps 0.5, Da 1e-3 (seconds)",
            toml: include_str!("builtin/lbm-porous-channel.toml"),
        },
        Builtin {
            name: "lbm-porous-couette",
            about: "LBM: Guo-Zhao porous Couette flow, eps 0.1, Da 1e-2, Re 10 (seed 002 Fig. 6a; seconds)",
            toml: include_str!("builtin/lbm-porous-couette.toml"),
        },
        Builtin {
            name: "lbm-packing",
            about: "LBM: permeability of a body-centred cubic sphere packing read from XYZ, 16^3 (seconds)",
            toml: include_str!("builtin/lbm-packing.toml"),
        },
        Builtin {
            name: "lbm-pressure-channel",
            about: "LBM: plane Poiseuille flow driven by a 0.03 Pa pressure drop (inlet/outlet planes; seconds)",
            toml: include_str!("builtin/lbm-pressure-channel.toml"),
        },
        Builtin {
            name: "lbm-sphere-array",
            about: "LBM: permeability of a simple cubic sphere array, phi 0.125, 32^3 (~1 min)",
            toml: include_str!("builtin/lbm-sphere-array.toml"),
        },
    ]
}

fn default_lattice() -> String {
    "D3Q19".into()
}
fn default_collision() -> String {
    "trt".into()
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

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LbmScene {
    pub kind: String,
    #[serde(default)]
    pub title: String,
    pub flow: String,
    #[serde(default = "default_lattice")]
    pub lattice: String,
    #[serde(default = "default_collision")]
    pub collision: String,
    #[serde(default = "one")]
    pub tau: f64,
    pub nu_m2_s: Option<f64>,
    pub rho_kg_m3: Option<f64>,
    pub length_m: Option<f64>,
    pub cells: Option<usize>,
    pub acceleration_m_s2: Option<f64>,
    pub wall_velocity_m_s: Option<f64>,
    pub porosity: Option<f64>,
    pub permeability_m2: Option<f64>,
    pub forchheimer: Option<bool>,
    pub solid_fraction: Option<f64>,
    pub channel_length_m: Option<f64>,
    pub pressure_drop_pa: Option<f64>,
    pub inlet_velocity_m_s: Option<f64>,
    pub xyz: Option<String>,
    pub resolution: Option<usize>,
    pub unit_m: Option<f64>,
    pub force_lattice: Option<f64>,
    #[serde(default = "tol")]
    pub tol: f64,
    #[serde(default = "check")]
    pub check_every: u64,
    #[serde(default = "max_steps")]
    pub max_steps: u64,
}

/// The flows and the keys only some of them have (every other key is common to all).
const FLOWS: [&str; 6] = [
    "channel",
    "porous-channel",
    "porous-couette",
    "pressure-channel",
    "sphere-array",
    "packing",
];

impl LbmScene {
    /// (key, given, the flows that have it) for every key that is not common to all flows.
    fn flow_keys(&self) -> [(&'static str, bool, &'static [&'static str]); 17] {
        const LATTICE: &[&str] = &[
            "channel",
            "porous-channel",
            "porous-couette",
            "pressure-channel",
            "sphere-array",
        ];
        const POROUS: &[&str] = &["porous-channel", "porous-couette"];
        const PRESSURE: &[&str] = &["pressure-channel"];
        const PACKING: &[&str] = &["packing"];
        [
            ("nu_m2_s", self.nu_m2_s.is_some(), LATTICE),
            ("rho_kg_m3", self.rho_kg_m3.is_some(), LATTICE),
            ("length_m", self.length_m.is_some(), LATTICE),
            ("cells", self.cells.is_some(), LATTICE),
            (
                "acceleration_m_s2",
                self.acceleration_m_s2.is_some(),
                &["channel", "porous-channel", "sphere-array"],
            ),
            (
                "wall_velocity_m_s",
                self.wall_velocity_m_s.is_some(),
                &["channel", "porous-couette"],
            ),
            ("porosity", self.porosity.is_some(), POROUS),
            ("permeability_m2", self.permeability_m2.is_some(), POROUS),
            ("forchheimer", self.forchheimer.is_some(), POROUS),
            (
                "solid_fraction",
                self.solid_fraction.is_some(),
                &["sphere-array"],
            ),
            (
                "channel_length_m",
                self.channel_length_m.is_some(),
                PRESSURE,
            ),
            (
                "pressure_drop_pa",
                self.pressure_drop_pa.is_some(),
                PRESSURE,
            ),
            (
                "inlet_velocity_m_s",
                self.inlet_velocity_m_s.is_some(),
                PRESSURE,
            ),
            ("xyz", self.xyz.is_some(), PACKING),
            ("resolution", self.resolution.is_some(), PACKING),
            ("unit_m", self.unit_m.is_some(), PACKING),
            ("force_lattice", self.force_lattice.is_some(), PACKING),
        ]
    }

    /// Refuses an unknown flow, and a key given to a flow that does not have it, by name.
    fn check_flow_and_keys(&self) -> Result<()> {
        if !FLOWS.contains(&self.flow.as_str()) {
            return invalid(format!(
                "flow = \"{}\": must be one of \"{}\"",
                self.flow,
                FLOWS.join("\", \"")
            ));
        }
        for (key, given, flows) in self.flow_keys() {
            if given && !flows.contains(&self.flow.as_str()) {
                return invalid(format!(
                    "{key}: only flow = \"{}\" has it (flow = \"{}\")",
                    flows.join("\" or \""),
                    self.flow
                ));
            }
        }
        Ok(())
    }
}

fn need<T>(v: Option<T>, key: &str, flow: &str) -> Result<T> {
    v.ok_or_else(|| Error::InvalidInput(format!("flow = \"{flow}\" needs key `{key}`")))
}

/// The steady run of a scene, in lattice units.
struct SceneRun {
    scene: LbmScene,
    /// Cells across the channel or the array period.
    n: usize,
    /// pressure-channel: (length in cells, inlet, outlet density).
    driven: Option<(usize, Inlet, f64)>,
    g: f64,
    wall_u: f64,
    porous: Option<(f64, f64, bool)>,
    ctl: SteadyControl,
    /// No progress display.
    quiet: bool,
}

struct Outcome {
    steady: Steady,
    solid: Vec<bool>,
    porosity_field: Vec<f64>,
    dims: Dims,
    /// Sphere array: k (lattice units).
    k: Option<f64>,
    /// The x index of the section written to profile.csv.
    profile_x: usize,
    /// The rows of profile.csv: (y index, distance from the lower wall in cells).
    rows: Vec<(usize, f64)>,
}

impl Job for SceneRun {
    type Out = Result<Outcome>;
    fn run<L: Lattice, C: Collision>(self, coll: C) -> Result<Outcome> {
        let mut bar = SteadyProgress::new(self.ctl.tol, self.quiet);
        let out = self.solve::<L, C>(coll, &mut |s, r| bar.update(s, r));
        bar.finish();
        out
    }
}

impl SceneRun {
    fn solve<L: Lattice, C: Collision>(
        self,
        coll: C,
        progress: &mut dyn FnMut(u64, f64),
    ) -> Result<Outcome> {
        let n = self.n;
        let walls = (1..=n).map(|y| (y, channel_coordinate(y))).collect();
        if self.scene.flow == "porous-couette" {
            let porous = need(self.porous, "porosity", "porous-couette")?;
            let (_, st) = node_couette::<L, C>(n, self.wall_u, porous, coll, self.ctl, progress)?;
            return Ok(Outcome {
                steady: st,
                solid: vec![false; n + 1],
                porosity_field: vec![porous.0; n + 1],
                dims: Dims::new(1, n + 1, 1)?,
                k: None,
                profile_x: 0,
                rows: (0..=n).map(|y| (y, y as f64)).collect(),
            });
        }
        if self.scene.flow == "sphere-array" {
            let phi = self.scene.solid_fraction.unwrap_or(0.0);
            let radius = n as f64 * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
            let d = Dims::new(n, n, n)?;
            let mask = sphere_array_mask(n, radius);
            let geom = Geometry::new::<L>(d, mask.clone(), |_| [0.0; 3])?;
            let p = permeability::<L, C>(geom, coll, self.g, self.ctl, progress)?;
            let porosity_field = mask.iter().map(|&s| if s { 0.0 } else { 1.0 }).collect();
            return Ok(Outcome {
                k: Some(p.k),
                steady: p.steady,
                solid: mask,
                porosity_field,
                dims: d,
                profile_x: 0,
                rows: Vec::new(),
            });
        }
        if let Some((length, inlet, rho_out)) = self.driven {
            let ch = DrivenChannel {
                h: n,
                length,
                inlet,
                rho_out,
            };
            let st = ch.steady::<L, C>(coll, self.ctl, progress)?;
            let d = ch.dims()?;
            let solid = channel_mask(d);
            let porosity_field = solid.iter().map(|&s| if s { 0.0 } else { 1.0 }).collect();
            return Ok(Outcome {
                steady: st,
                solid,
                porosity_field,
                dims: d,
                k: None,
                profile_x: length / 2,
                rows: walls,
            });
        }
        let ch = Channel {
            h: n,
            g: self.g,
            wall_u: self.wall_u,
            porous: self.porous,
        };
        let (_, st) = ch.steady::<L, C>(coll, self.ctl, progress)?;
        let d = Dims::new(1, n + 2, 1)?;
        let solid: Vec<bool> = (0..n + 2).map(|y| y == 0 || y == n + 1).collect();
        let eps = self.porous.map_or(1.0, |p| p.0);
        let porosity_field = solid.iter().map(|&s| if s { 0.0 } else { eps }).collect();
        Ok(Outcome {
            steady: st,
            solid,
            porosity_field,
            dims: d,
            k: None,
            profile_x: 0,
            rows: walls,
        })
    }
}

/// A parsed and checked LBM scene: its units, driving and a-priori velocity scale, everything
/// [`run_scene`] fixes before it builds a lattice.
struct Prepared {
    sc: LbmScene,
    /// Cells across length_m.
    n: usize,
    length_m: f64,
    lat: LatticeKind,
    coll: CollisionKind,
    u: Units,
    g: f64,
    wall_u: f64,
    nu: f64,
    h: f64,
    porous: Option<(f64, f64, bool)>,
    driven: Option<(usize, Inlet, f64)>,
    u_est: f64,
}

/// Bytes per cell a scene holds besides the solver's populations and mask: the steady
/// fields (velocity, density), their SI copies, the solid and porosity fields of the output,
/// and the scene's own mask.
const SCENE_PER_CELL: usize = 32 + 32 + 16 + 2;
/// Bytes per cell of the Guo-Zhao porous medium (porosity, two drag coefficients, matrix
/// velocity).
const POROUS_PER_CELL: usize = 48;

/// What a scene runs: a flow on a lattice of its own, or the permeability of a configuration.
enum Plan {
    Flow(Box<Prepared>),
    Packing(Box<PackingPlan>),
}

fn prepare(text: &str, origin: &str) -> Result<Plan> {
    let sc: LbmScene = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: e.to_string().trim_end().to_string(),
    })?;
    let lat = LatticeKind::parse(&sc.lattice, "lattice")?;
    let coll = CollisionKind::parse(&sc.collision, "collision")?;
    sc.check_flow_and_keys()?;
    if sc.flow == "packing" {
        return prepare_packing(sc, lat, coll, origin).map(|p| Plan::Packing(Box::new(p)));
    }
    let cells = need(sc.cells, "cells", &sc.flow)?;
    let length_m = need(sc.length_m, "length_m", &sc.flow)?;
    if cells < 4 {
        return invalid(format!("cells = {cells}: must be >= 4"));
    }
    let u = Units::from_tau(
        length_m / cells as f64,
        sc.nu_m2_s.unwrap_or(1e-6),
        sc.rho_kg_m3.unwrap_or(1000.0),
        sc.tau,
    )?;
    let g = u.accel_to_lattice(sc.acceleration_m_s2.unwrap_or(0.0));
    let wall_u = u.velocity_to_lattice(sc.wall_velocity_m_s.unwrap_or(0.0));
    let nu = u.nu_lattice();
    let h = cells as f64;
    let mut porous = None;
    let mut driven = None;
    // a-priori velocity scale (lattice units) for the Mach check
    let u_est = match sc.flow.as_str() {
        "channel" => g.abs() * h * h / (8.0 * nu) + wall_u.abs(),
        "porous-channel" | "porous-couette" => {
            let eps = need(sc.porosity, "porosity", &sc.flow)?;
            let k_si = need(sc.permeability_m2, "permeability_m2", &sc.flow)?;
            if !(eps > 0.0 && eps <= 1.0) {
                return invalid(format!("porosity = {eps}: must be in (0, 1]"));
            }
            if !(k_si > 0.0 && k_si.is_finite()) {
                return invalid(format!(
                    "permeability_m2 = {k_si}: must be positive and finite"
                ));
            }
            let k = k_si / (u.dx * u.dx);
            porous = Some((eps, k, sc.forchheimer.unwrap_or(true)));
            if sc.flow == "porous-couette" {
                need(sc.wall_velocity_m_s, "wall_velocity_m_s", &sc.flow)?;
                wall_u.abs()
            } else {
                (g.abs() * h * h / (8.0 * nu)).min(g.abs() * k / nu)
            }
        }
        "pressure-channel" => {
            let len_m = need(sc.channel_length_m, "channel_length_m", &sc.flow)?;
            let cells = len_m / u.dx;
            let length = cells.round() as usize;
            if !(len_m.is_finite() && length >= 2 && (cells - length as f64).abs() <= 1e-6 * cells)
            {
                return invalid(format!(
                    "channel_length_m = {len_m}: must be a whole number (>= 2) of cells of \
                     dx = {:e} m (it is {cells} cells)",
                    u.dx
                ));
            }
            let (inlet, est) =
                match (sc.pressure_drop_pa, sc.inlet_velocity_m_s) {
                    (Some(dp), None) => {
                        // lattice pressure c_s^2 rho: drho = 3 dp dt^2 / (rho dx^2)
                        let drho = 3.0 * dp * u.dt * u.dt / (u.rho * u.dx * u.dx);
                        if !(drho.is_finite() && drho.abs() < 0.2) {
                            return invalid(format!(
                                "pressure_drop_pa = {dp}: a density difference of {drho:.3e} \
                             (lattice units) must be finite and below 0.2 in magnitude \
                             (compressibility); lower the pressure drop or refine the lattice"
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
                    _ => return invalid(
                        "flow = \"pressure-channel\" needs exactly one of pressure_drop_pa and \
                         inlet_velocity_m_s",
                    ),
                };
            let rho_out = match inlet {
                Inlet::Density(rho_in) => 2.0 - rho_in,
                Inlet::Parabola(_) => 1.0,
            };
            driven = Some((length, inlet, rho_out));
            est
        }
        "sphere-array" => {
            let phi = need(sc.solid_fraction, "solid_fraction", &sc.flow)?;
            if !(phi > 0.0 && phi <= std::f64::consts::PI / 6.0) {
                return invalid(format!("solid_fraction = {phi}: must be in (0, pi/6]"));
            }
            if g <= 0.0 {
                return invalid("sphere-array: acceleration_m_s2 must be > 0 (it drives the flow)");
            }
            g * h * h / (8.0 * nu)
        }
        other => return invalid(format!("flow = \"{other}\": not a lattice flow")),
    };
    // the lattice each flow builds, refused before anything is allocated
    let n = cells;
    let dims = match (&sc.flow[..], driven) {
        ("sphere-array", _) => Dims::new(n, n, n)?,
        ("porous-couette", _) => Dims::new(1, n + 1, 1)?,
        (_, Some((length, _, _))) => Dims::new(length + 1, n + 2, 1)?,
        _ => Dims::new(1, n + 2, 1)?,
    };
    let porous_fields = if porous.is_some() { POROUS_PER_CELL } else { 0 };
    check_memory(dims, lat.q(), SCENE_PER_CELL + porous_fields)?;
    check_mach(u_est, "estimated peak velocity")?;
    Ok(Plan::Flow(Box::new(Prepared {
        sc,
        n,
        length_m,
        lat,
        coll,
        u,
        g,
        wall_u,
        nu,
        h,
        porous,
        driven,
        u_est,
    })))
}

/// The porous Couette profile at the nodes y = 0..=n (lattice units) for a wall at `u_wall`
/// and the medium (eps, K, Forchheimer on): without the Forchheimer term the closed form
/// [`brinkman_couette`]; with it, the finite differences of `reference::porous_couette` (the
/// oracle of validation case 809) on grids of at least 4096 and twice as many intervals,
/// Richardson-extrapolated at the nodes.
fn couette_reference(
    n: usize,
    u_wall: f64,
    nu: f64,
    (eps, k, forch): (f64, f64, bool),
) -> Vec<f64> {
    let h = n as f64;
    if !forch {
        return (0..=n)
            .map(|y| brinkman_couette(y as f64, h, u_wall, eps, k))
            .collect();
    }
    use crate::reference::porous_couette::solve;
    let m = 4096usize.div_ceil(n);
    let (re, da) = (u_wall.abs() * h / nu, k / (h * h));
    let (a, b) = (solve(n * m, eps, re, da), solve(2 * n * m, eps, re, da));
    (0..=n)
        .map(|y| u_wall * (4.0 * b[2 * m * y] - a[m * y]) / 3.0)
        .collect()
}

/// A packing scene: the configuration read and checked, and the options of its run.
struct PackingPlan {
    sc: LbmScene,
    /// Where the configuration was read from, and its text.
    source: String,
    text: String,
    cell: Cell,
    parts: Vec<XyzParticle>,
    resolution: usize,
    o: PoreOptions,
}

/// Configurations that built-in scenes name in `xyz` (a built-in has no folder of its own).
const BUILTIN_XYZ: [(&str, &str); 1] =
    [("lbm-packing.xyz", include_str!("builtin/lbm-packing.xyz"))];

/// (where, text) of the configuration `xyz` names: a path relative to the scene file's folder,
/// or absolute; `builtin:NAME` is one of [`BUILTIN_XYZ`], wherever the scene is (a built-in
/// scene, its sweep jobs, or a scene file started from `--show`).
fn read_xyz(xyz: &str, origin: &str) -> Result<(String, String)> {
    if let Some(wanted) = xyz.strip_prefix("builtin:") {
        return BUILTIN_XYZ
            .iter()
            .find(|(name, _)| *name == wanted)
            .map(|(_, text)| (xyz.to_string(), text.to_string()))
            .ok_or_else(|| {
                let known: Vec<_> = BUILTIN_XYZ.iter().map(|(n, _)| *n).collect();
                Error::InvalidInput(format!(
                    "xyz = \"{xyz}\": no built-in configuration of that name (known: {})",
                    known.join(", ")
                ))
            });
    }
    let path = Path::new(xyz);
    let full = match Path::new(origin).parent() {
        Some(dir) if path.is_relative() => dir.join(path),
        _ => path.to_path_buf(),
    };
    let text = std::fs::read_to_string(&full).map_err(|e| Error::File {
        path: full.display().to_string(),
        msg: format!(
            "xyz = \"{xyz}\" (relative to the scene file's folder): {e} (a built-in scene's \
             configuration is in its run folder as configuration.xyz)"
        ),
    })?;
    Ok((full.display().to_string(), text))
}

fn prepare_packing(
    sc: LbmScene,
    lat: LatticeKind,
    coll: CollisionKind,
    origin: &str,
) -> Result<PackingPlan> {
    let xyz = need(sc.xyz.clone(), "xyz", &sc.flow)?;
    let resolution = need(sc.resolution, "resolution", &sc.flow)?;
    if let Some(u) = sc.unit_m {
        if !(u > 0.0 && u.is_finite()) {
            return invalid(format!("unit_m = {u}: must be positive and finite"));
        }
    }
    let (source, text) = read_xyz(&xyz, origin)?;
    let (cell, parts) = xyz::parse(&text, &source)?;
    let o = PoreOptions {
        lattice: lat,
        collision: coll,
        tau: sc.tau,
        g: sc.force_lattice.unwrap_or(1e-6),
        ctl: SteadyControl {
            check_every: sc.check_every,
            tol: sc.tol,
            max_steps: sc.max_steps,
        },
        quiet: false,
    };
    o.check("force_lattice")?;
    let (dims, _) = voxel_dims(&cell, resolution)?;
    check_memory(dims, lat.q(), SCENE_PER_CELL)?;
    Ok(PackingPlan {
        sc,
        source,
        text,
        cell,
        parts,
        resolution,
        o,
    })
}

/// The permeability of a configuration: what `porelab permeability` does at one resolution.
fn run_packing(mut p: PackingPlan, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    p.o.quiet = opts.quiet;
    let (sc, o, resolution, source, cell) = (&p.sc, &p.o, p.resolution, &p.source, &p.cell);
    println!("lbm scene {origin}: packing {source}, resolution {resolution}");
    let mut report = setup_line(cell, &p.parts, o);
    print!("{report}");
    let v = voxelise(cell, &p.parts, resolution)?;
    let r = on_threads(opts.threads, || pore_permeability(&v, o))?;
    let lines = pore::report(&v, &r, o, sc.unit_m);
    print!("{lines}");
    report += &lines;
    std::fs::create_dir_all(out)?;
    write_atomic(&out.join("permeability.txt"), report.as_bytes())?;
    write_atomic(&out.join("configuration.xyz"), p.text.as_bytes())?;
    let fields = &r.run.steady.fields;
    let solid: Vec<f64> = v.solid.iter().map(|&s| if s { 1.0 } else { 0.0 }).collect();
    let unit = sc.unit_m.unwrap_or(1.0);
    write_image_data(
        &out.join("fields.vtk"),
        "porelab lbm packing (lattice units)",
        [v.dims.nx, v.dims.ny, v.dims.nz],
        v.dx * unit,
        cell.origin.map(|c| c * unit),
        &[
            CellField::Vector("velocity_lattice", &fields.u),
            CellField::Scalar("density_lattice", &fields.rho),
            CellField::Scalar("solid", &solid),
        ],
    )?;
    let kozeny = |phi: f64| v.v_over_s.map(|vs| kozeny_constant(r.k, phi, vs));
    let summary = serde_json::json!({
        "flow": sc.flow, "xyz": source, "lattice": o.lattice.name(),
        "collision": o.collision.name(), "tau": o.tau, "force_lattice": o.g,
        "resolution": resolution, "dims": [v.dims.nx, v.dims.ny, v.dims.nz], "dx_unit": v.dx,
        "k_unit2": r.k, "k_m2": sc.unit_m.map(|u| r.k * u * u),
        "porosity": r.porosity, "porosity_particles": 1.0 - v.phi_particles, "re": r.re,
        "v_over_s_unit": v.v_over_s,
        "kozeny_constant": kozeny(v.phi_particles),
        "kozeny_constant_voxel_phi": kozeny(1.0 - r.porosity),
        "steps": r.run.steps, "residual": r.run.residual, "converged": r.run.converged,
        "mach": r.run.u_max * 3f64.sqrt(),
    });
    write_summary(out, &summary)
}

fn write_summary(out: &Path, summary: &serde_json::Value) -> Result<()> {
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(summary)
            .map_err(|e| Error::InvalidInput(e.to_string()))?
            .as_bytes(),
    )?;
    println!("  wrote {}", out.display());
    Ok(())
}

/// Checks an LBM scene as [`run_scene`] does before it runs (`porelab sweep plan`).
pub fn check_scene(text: &str, origin: &str) -> Result<()> {
    prepare(text, origin).map(|_| ())
}

pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    match prepare(text, origin)? {
        Plan::Flow(p) => run_flow(*p, origin, out, opts),
        Plan::Packing(p) => run_packing(*p, origin, out, opts),
    }
}

fn run_flow(p: Prepared, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let Prepared {
        sc,
        n,
        length_m,
        lat,
        coll,
        u,
        g,
        wall_u,
        nu,
        h,
        porous,
        driven,
        u_est,
    } = p;
    println!(
        "lbm scene {origin}: {} {} {}, {} cells across {} m (dx = {:e} m, dt = {:e} s)",
        sc.flow,
        lat.name(),
        coll.name(),
        n,
        length_m,
        u.dx,
        u.dt
    );
    println!("  estimate: {}", describe(sc.tau, u_est, h));
    let ctl = SteadyControl {
        check_every: sc.check_every,
        tol: sc.tol,
        max_steps: sc.max_steps,
    };
    let tau = sc.tau;
    let run = SceneRun {
        scene: sc.clone(),
        n,
        driven,
        g,
        wall_u,
        porous,
        ctl,
        quiet: opts.quiet,
    };
    let o = on_threads(opts.threads, || dispatch(lat, coll, tau, run))?;
    let st = &o.steady;
    println!(
        "  steady after {} steps (residual {:.2e}{}); measured: {}",
        st.steps,
        st.residual,
        if st.converged { "" } else { ", NOT converged" },
        describe(tau, st.u_max, h)
    );
    std::fs::create_dir_all(out)?;
    let vel: Vec<[f64; 3]> = st
        .fields
        .u
        .iter()
        .map(|v| v.map(|c| u.velocity_to_si(c)))
        .collect();
    let rho: Vec<f64> = st.fields.rho.iter().map(|r| r * u.rho).collect();
    let solid: Vec<f64> = o.solid.iter().map(|&s| if s { 1.0 } else { 0.0 }).collect();
    let d = o.dims;
    write_image_data(
        &out.join("fields.vtk"),
        &format!("porelab lbm {}", sc.flow),
        [d.nx, d.ny, d.nz],
        u.dx,
        [0.0; 3],
        &[
            CellField::Vector("velocity_m_s", &vel),
            CellField::Scalar("density_kg_m3", &rho),
            CellField::Scalar("porosity", &o.porosity_field),
            CellField::Scalar("solid", &solid),
        ],
    )?;
    let mut summary = serde_json::json!({
        "flow": sc.flow, "lattice": lat.name(), "collision": coll.name(), "tau": tau,
        "dx_m": u.dx, "dt_s": u.dt, "steps": st.steps, "residual": st.residual,
        "converged": st.converged, "mach": st.u_max * 3f64.sqrt(),
        "u_max_m_s": u.velocity_to_si(st.u_max), "re": st.u_max * h / nu,
    });
    if let Some(k) = o.k {
        let phi = sc.solid_fraction.unwrap_or(0.0);
        let a = h * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
        summary["permeability_m2"] = serde_json::json!(u.area_to_si(k));
        summary["drag_coefficient_K"] =
            serde_json::json!(crate::lbm::flows::drag_coefficient(k, a, phi));
        println!(
            "  permeability k = {:.6e} m^2 (= {:.6e} cells^2), drag coefficient K = {:.4}",
            u.area_to_si(k),
            k,
            crate::lbm::flows::drag_coefficient(k, a, phi)
        );
    } else {
        let couette = (sc.flow == "porous-couette")
            .then(|| porous.map(|p| couette_reference(n, wall_u, nu, p)))
            .flatten();
        let mut csv = String::from("y_m,u_m_s,u_exact_m_s\n");
        // largest |u - exact| and |exact| (m/s)
        let (mut err, mut peak) = (0.0f64, 0.0f64);
        for &(y, yc) in &o.rows {
            let v = vel[d.cell(o.profile_x, y, 0)];
            let exact = match (driven, porous) {
                _ if couette.is_some() => couette.as_ref().map(|c| c[y]),
                (Some((len, Inlet::Density(rho_in), rho_out)), _) => {
                    Some((rho_in - rho_out) / (3.0 * len as f64) * yc * (h - yc) / (2.0 * nu))
                }
                (Some((_, Inlet::Parabola(um), _)), _) => Some(4.0 * um * yc * (h - yc) / (h * h)),
                (None, None) => Some(g * yc * (h - yc) / (2.0 * nu) + wall_u * yc / h),
                (None, Some((eps, k, false))) => Some(brinkman_poiseuille(yc, h, g, nu, eps, k)),
                (None, Some(_)) => None,
            };
            if let Some(e) = exact {
                err = err.max((v[0] - u.velocity_to_si(e)).abs());
                peak = peak.max(u.velocity_to_si(e).abs());
            }
            csv += &format!(
                "{},{},{}\n",
                yc * u.dx,
                v[0],
                exact.map_or(String::new(), |e| u.velocity_to_si(e).to_string())
            );
        }
        write_atomic(&out.join("profile.csv"), csv.as_bytes())?;
        let reference = match (&couette, porous) {
            (Some(_), Some((_, _, true))) => "finite differences",
            _ => "closed form",
        };
        if peak > 0.0 {
            summary["profile_max_error_rel"] = serde_json::json!(err / peak);
            summary["profile_reference"] = serde_json::json!(reference);
            println!(
                "  profile: largest |u - u_exact| = {:.3e} of the peak ({reference})",
                err / peak
            );
        }
        let column = |y: &'static str| CsvPlot {
            title: "Velocity profile across the channel",
            x: "y_m",
            y,
            x_label: "y (m)",
            y_label: "u (m/s)",
            ..Default::default()
        };
        // the lattice profile and the reference as two labelled series of one picture
        let mut series = Vec::new();
        for (y, label) in [("u_m_s", "lattice Boltzmann"), ("u_exact_m_s", reference)] {
            let built = column(y).build(&csv)?;
            series.extend(built.series.into_iter().map(|mut s| {
                s.label = label.into();
                s
            }));
        }
        let plot = crate::io::plot::Plot {
            series,
            ..column("u_m_s").build("y_m,u_m_s\n")?
        };
        if let Err(e) = crate::io::plot::write_svg(&out.join("profile.svg"), &plot) {
            eprintln!("warning: profile.svg not written: {e}");
        }
    }
    write_summary(out, &summary)
}

/// `kind = "lbm"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "lbm"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        None
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        check_scene(text, origin)
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Asserts that `toml` is refused before it runs with a message containing `words`.
    fn refused(toml: &str, words: &str) {
        let e = check_scene(toml, "t").unwrap_err().to_string();
        assert!(e.contains(words), "{e}");
    }

    fn builtin(name: &str) -> Builtin {
        builtins().into_iter().find(|b| b.name == name).unwrap()
    }

    #[test]
    fn builtins_parse_and_unknown_keys_are_named() {
        for b in builtins() {
            let s: LbmScene = toml::from_str(b.toml).unwrap_or_else(|e| panic!("{}: {e}", b.name));
            assert_eq!(s.kind, "lbm");
        }
        let bad = format!("{}\nviscosity = 1.0\n", builtins()[0].toml);
        let e = toml::from_str::<LbmScene>(&bad).unwrap_err().to_string();
        assert!(e.contains("viscosity"), "{e}");
        let tmp = std::env::temp_dir().join(format!("porelab-lbm-scene-{}", std::process::id()));
        let e = run_scene(
            &builtins()[0]
                .toml
                .replace("flow = \"channel\"", "flow = \"pipe\""),
            "test",
            &tmp,
            &RunOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("flow = \"pipe\""), "{e}");
        let e = run_scene(
            &builtins()[0]
                .toml
                .replace("acceleration_m_s2 = 1e-3", "acceleration_m_s2 = 10.0"),
            "test",
            &tmp,
            &RunOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("Mach"), "{e}");
    }

    /// A lattice too large for the machine is refused at preparation, naming its size,
    /// before the mask or the populations are built (it took 100 s and 2 GB before).
    #[test]
    fn oversized_lattice_is_refused_before_allocating() {
        let b = builtin("lbm-sphere-array");
        let need = crate::lbm::solver::bytes_needed(1_000_000_000, 19, 0);
        match crate::lbm::solver::memory_available() {
            Some(avail) if avail < need => {}
            _ => return eprintln!("skipped: this machine has room for a 1000^3 lattice"),
        }
        let big = b.toml.replace("cells = 32", "cells = 1000");
        let t = std::time::Instant::now();
        let tmp = std::env::temp_dir().join(format!("porelab-lbm-big-{}", std::process::id()));
        let e = run_scene(&big, "t", &tmp, &RunOptions::default())
            .unwrap_err()
            .to_string();
        assert!(t.elapsed().as_secs_f64() < 1.0, "{:?}", t.elapsed());
        assert!(e.contains("1000 x 1000 x 1000") && e.contains("GiB"), "{e}");
        assert!(!tmp.exists());
    }

    fn run_builtin_toml(toml: &str, tag: &str) -> std::path::PathBuf {
        let tmp = std::env::temp_dir().join(format!("porelab-lbm-{tag}-{}", std::process::id()));
        let quiet = RunOptions {
            quiet: true,
            ..Default::default()
        };
        run_scene(toml, "builtin:t", &tmp, &quiet).unwrap();
        tmp
    }

    fn summary(dir: &Path) -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
    }

    /// The porous Couette builtin (Forchheimer term on) follows the finite-difference
    /// reference; with the term off, the profile follows u = U sinh(r y) / sinh(r H), r =
    /// sqrt(eps / K) (the Brinkman equation nu u'' = (eps nu / K) u, u(0) = 0, u(H) = U, walls
    /// on the nodes), evaluated here from the SI keys, and the error falls with resolution
    /// (measured 1.8e-4 of U at 16 cells, 5.4e-5 at 32: second order). Keys of other flows
    /// and a missing wall velocity are refused by name.
    #[test]
    fn porous_couette_builtin_and_brinkman_couette_closed_form() {
        let b = builtin("lbm-porous-couette");
        let dir = run_builtin_toml(b.toml, "pc");
        let s = summary(&dir);
        assert_eq!(s["profile_reference"], "finite differences");
        assert!(s["profile_max_error_rel"].as_f64().unwrap() < 1e-3, "{s}");
        let _ = std::fs::remove_dir_all(&dir);
        let (u_wall, h, r) = (1e-2, 1e-3, (0.1f64 / 1e-8).sqrt());
        let err = |cells: usize| {
            let toml = b
                .toml
                .replace("cells = 32", &format!("cells = {cells}"))
                .replace("forchheimer = true", "forchheimer = false");
            let dir = run_builtin_toml(&toml, &format!("pc{cells}"));
            let text = std::fs::read_to_string(dir.join("profile.csv")).unwrap();
            let _ = std::fs::remove_dir_all(&dir);
            let mut worst: f64 = 0.0;
            for l in text.lines().skip(1) {
                let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
                let exact = u_wall * (r * v[0]).sinh() / (r * h).sinh();
                worst = worst.max((v[1] - exact).abs() / u_wall);
            }
            assert_eq!(text.lines().count(), cells + 2);
            worst
        };
        let (e16, e32) = (err(16), err(32));
        eprintln!(
            "porous Couette, Forchheimer off: max error / U = {e16:.3e} (16), {e32:.3e} (32)"
        );
        assert!(e16 < 5e-4 && e32 < e16 / 2.5, "{e16:e} {e32:e}");
        let stray = format!("{}solid_fraction = 0.1\n", b.toml);
        refused(&stray, "solid_fraction: only flow = \"sphere-array\"");
        refused(
            &b.toml.replace("wall_velocity_m_s = 1e-2", ""),
            "needs key `wall_velocity_m_s`",
        );
    }

    /// The packing builtin runs from its built-in configuration and reports what `porelab
    /// permeability` prints; a simple cubic configuration in a scene folder (relative `xyz`)
    /// gives the permeability of the sphere-array flow of the same geometry (the same mask);
    /// lattice keys are refused for packing and packing keys for the lattice flows.
    #[test]
    fn packing_builtin_and_sphere_array_agree() {
        let b = builtin("lbm-packing");
        let dir = run_builtin_toml(b.toml, "pk");
        let s = summary(&dir);
        let k = s["k_unit2"].as_f64().unwrap();
        assert!(k > 0.0 && (s["k_m2"].as_f64().unwrap() / (k * 1e-6) - 1.0).abs() < 1e-12);
        assert!(s["kozeny_constant"].as_f64().unwrap() > 0.0, "{s}");
        let text = std::fs::read_to_string(dir.join("permeability.txt")).unwrap();
        assert!(text.contains("resolution 16 (16 x 16 x 16") && text.contains("Kozeny"));
        assert!(dir.join("fields.vtk").is_file() && dir.join("configuration.xyz").is_file());
        let _ = std::fs::remove_dir_all(&dir);

        let folder = std::env::temp_dir().join(format!("porelab-lbm-sc-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        let phi: f64 = 0.125;
        let r = (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
        let sphere = XyzParticle {
            species: "sphere".into(),
            position: nalgebra::Vector3::new(0.5, 0.5, 0.5),
            orientation: nalgebra::UnitQuaternion::identity(),
            aspherical_shape: [r; 3],
            radius: r,
            cylinder_length: 0.0,
            roundness: [1.0, 1.0],
        };
        xyz::write(&folder.join("sc.xyz"), &Cell::cubic(1.0), &[sphere], &[]).unwrap();
        let scene = folder.join("sc.toml");
        let toml = "kind = \"lbm\"\nflow = \"packing\"\nxyz = \"sc.xyz\"\nresolution = 16\n\
                    unit_m = 1e-4\ntol = 1e-10\ncheck_every = 100\n";
        let quiet = RunOptions {
            quiet: true,
            ..Default::default()
        };
        run_scene(
            toml,
            &scene.display().to_string(),
            &folder.join("a"),
            &quiet,
        )
        .unwrap();
        let array = builtin("lbm-sphere-array")
            .toml
            .replace("cells = 32", "cells = 16")
            .replace("tol = 1e-7", "tol = 1e-10");
        run_scene(&array, "t", &folder.join("b"), &quiet).unwrap();
        let (ka, kb) = (
            summary(&folder.join("a"))["k_m2"].as_f64().unwrap(),
            summary(&folder.join("b"))["permeability_m2"]
                .as_f64()
                .unwrap(),
        );
        let _ = std::fs::remove_dir_all(&folder);
        assert!((ka / kb - 1.0).abs() < 1e-6, "{ka:e} {kb:e}");
        refused(&format!("{toml}cells = 16\n"), "cells: only flow = ");
        refused(
            &format!("{}resolution = 16\n", builtins()[0].toml),
            "resolution: only flow = \"packing\"",
        );
    }

    /// The channel builtin reproduces its own closed-form column (TRT: exact parabola).
    #[test]
    fn channel_builtin_profile_matches_poiseuille() {
        let tmp = std::env::temp_dir().join(format!("porelab-lbm-ch-{}", std::process::id()));
        run_scene(
            builtins()[0].toml,
            "builtin:lbm-channel",
            &tmp,
            &RunOptions::default(),
        )
        .unwrap();
        let text = std::fs::read_to_string(tmp.join("profile.csv")).unwrap();
        for l in text.lines().skip(1) {
            let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
            assert!((v[1] - v[2]).abs() < 1e-8 * v[2].abs(), "{l}");
        }
        assert!(tmp.join("fields.vtk").is_file() && tmp.join("summary.json").is_file());
        let _ = std::fs::remove_dir_all(&tmp);
    }

    /// The pressure-driven builtin reproduces the parabola of its pressure gradient at the
    /// mid-length section (TRT walls are exact; what is left is the compressibility of a
    /// 2.5e-3 density drop), and its keys are refused where they do not belong.
    #[test]
    fn pressure_channel_builtin_and_keys() {
        let b = builtin("lbm-pressure-channel");
        let tmp = std::env::temp_dir().join(format!("porelab-lbm-pch-{}", std::process::id()));
        run_scene(b.toml, "builtin", &tmp, &RunOptions::default()).unwrap();
        let text = std::fs::read_to_string(tmp.join("profile.csv")).unwrap();
        let peak = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(2).unwrap().parse::<f64>().unwrap())
            .fold(0.0, f64::max);
        for l in text.lines().skip(1) {
            let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
            assert!((v[1] - v[2]).abs() < 1e-3 * peak, "{l}");
        }
        let _ = std::fs::remove_dir_all(&tmp);
        let both = format!("{}inlet_velocity_m_s = 1e-3\n", b.toml);
        refused(&both, "exactly one of pressure_drop_pa");
        refused(&b.toml.replace("0.03", "300.0"), "pressure_drop_pa = 300");
        refused(&b.toml.replace("2e-3", "2.01e-3"), "whole number");
        let stray = format!("{}pressure_drop_pa = 1.0\n", builtins()[0].toml);
        refused(&stray, "only flow = \"pressure-channel\"");
    }
}
