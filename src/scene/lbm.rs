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
//!                                 # | "sphere-array" (simple cubic, periodic)
//!                                 # | "pressure-channel" (plane channel driven through
//!                                 # its ends: inlet/outlet planes by non-equilibrium
//!                                 # extrapolation, Guo, Zheng & Shi 2002)
//! lattice = "D3Q19"               # "D3Q15" | "D3Q19"  [D3Q19]
//! collision = "trt"               # "bgk" | "trt" (Lambda = 3/16)  [trt]
//! tau = 1.0                       # relaxation time (>= 0.505) [1.0]
//! nu_m2_s = 1e-6                  # kinematic viscosity (m^2/s) [1e-6, water]
//! rho_kg_m3 = 1000.0              # density (kg/m^3) [1000]
//! length_m = 1e-3                 # required: channel width H, or the array period L (m)
//! cells = 32                      # required: cells across length_m (>= 4)
//! acceleration_m_s2 = 1e-3        # body force per unit mass along x (m/s^2) [0]
//! wall_velocity_m_s = 0.0         # channel: velocity of the upper wall along x (m/s) [0]
//! porosity = 0.5                  # porous-channel: eps in (0, 1]
//! permeability_m2 = 1e-9          # porous-channel: K (m^2)
//! forchheimer = true              # porous-channel: Ergun's Forchheimer term [true]
//! solid_fraction = 0.125          # sphere-array: phi in (0, pi/6]
//! channel_length_m = 2e-3         # pressure-channel: inlet-to-outlet distance (m), a whole
//!                                 # number of cells
//! pressure_drop_pa = 1e-3         # pressure-channel: inlet minus outlet pressure (Pa), or
//! inlet_velocity_m_s = 1e-3       # pressure-channel: peak of a parabolic inlet profile (m/s)
//!                                 # (exactly one of the two; the outlet is at the reference
//!                                 # pressure)
//! tol = 1e-9                      # stop when <u> changes by less than this per check [1e-9]
//! check_every = 200               # steps between checks [200]
//! max_steps = 1000000             # [1e6]
//! ```
//!
//! Outputs: `fields.vtk` (velocity m/s, density kg/m^3, porosity, solid mask),
//! `profile.csv` for channels (y_m, u_m_s, u_exact_m_s where a closed form exists) and
//! `summary.json` (tau, Mach, Re, steps, residual; permeability for the sphere array).

use super::{on_threads, Builtin, RunOptions};
use crate::error::{invalid, Error, Result};
use crate::io::plot::CsvPlot;
use crate::io::vtk::{write_image_data, CellField};
use crate::io::write_atomic;
use crate::lbm::choice::{dispatch, CollisionKind, Job, LatticeKind};
use crate::lbm::flows::channel_mask;
use crate::lbm::flows::{brinkman_poiseuille, channel_coordinate, sphere_array_mask};
use crate::lbm::geometry::{Dims, Geometry};
use crate::lbm::problems::{permeability, Channel, DrivenChannel, Inlet};
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
fn water_nu() -> f64 {
    1e-6
}
fn water_rho() -> f64 {
    1000.0
}
fn yes() -> bool {
    true
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
    #[serde(default = "water_nu")]
    pub nu_m2_s: f64,
    #[serde(default = "water_rho")]
    pub rho_kg_m3: f64,
    pub length_m: f64,
    pub cells: usize,
    #[serde(default)]
    pub acceleration_m_s2: f64,
    #[serde(default)]
    pub wall_velocity_m_s: f64,
    pub porosity: Option<f64>,
    pub permeability_m2: Option<f64>,
    #[serde(default = "yes")]
    pub forchheimer: bool,
    pub solid_fraction: Option<f64>,
    pub channel_length_m: Option<f64>,
    pub pressure_drop_pa: Option<f64>,
    pub inlet_velocity_m_s: Option<f64>,
    #[serde(default = "tol")]
    pub tol: f64,
    #[serde(default = "check")]
    pub check_every: u64,
    #[serde(default = "max_steps")]
    pub max_steps: u64,
}

fn need(v: Option<f64>, key: &str, flow: &str) -> Result<f64> {
    v.ok_or_else(|| Error::InvalidInput(format!("flow = \"{flow}\" needs key `{key}`")))
}

/// The steady run of a scene, in lattice units.
struct SceneRun {
    scene: LbmScene,
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
        let n = self.scene.cells;
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
        })
    }
}

/// A parsed and checked LBM scene: its units, driving and a-priori velocity scale, everything
/// [`run_scene`] fixes before it builds a lattice.
struct Prepared {
    sc: LbmScene,
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

fn prepare(text: &str, origin: &str) -> Result<Prepared> {
    let sc: LbmScene = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: e.to_string().trim_end().to_string(),
    })?;
    let lat = LatticeKind::parse(&sc.lattice, "lattice")?;
    let coll = CollisionKind::parse(&sc.collision, "collision")?;
    if sc.cells < 4 {
        return invalid(format!("cells = {}: must be >= 4", sc.cells));
    }
    let u = Units::from_tau(
        sc.length_m / sc.cells as f64,
        sc.nu_m2_s,
        sc.rho_kg_m3,
        sc.tau,
    )?;
    let g = u.accel_to_lattice(sc.acceleration_m_s2);
    let wall_u = u.velocity_to_lattice(sc.wall_velocity_m_s);
    let nu = u.nu_lattice();
    let h = sc.cells as f64;
    let mut porous = None;
    let mut driven = None;
    if sc.flow != "pressure-channel" {
        for (key, v) in [
            ("channel_length_m", sc.channel_length_m),
            ("pressure_drop_pa", sc.pressure_drop_pa),
            ("inlet_velocity_m_s", sc.inlet_velocity_m_s),
        ] {
            if v.is_some() {
                return invalid(format!(
                    "{key}: only flow = \"pressure-channel\" has it (flow = \"{}\")",
                    sc.flow
                ));
            }
        }
    }
    // a-priori velocity scale (lattice units) for the Mach check
    let u_est = match sc.flow.as_str() {
        "channel" => g.abs() * h * h / (8.0 * nu) + wall_u.abs(),
        "porous-channel" => {
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
            if sc.wall_velocity_m_s != 0.0 {
                return invalid("wall_velocity_m_s: only flow = \"channel\" has a moving wall");
            }
            let k = k_si / (u.dx * u.dx);
            porous = Some((eps, k, sc.forchheimer));
            (g.abs() * h * h / (8.0 * nu)).min(g.abs() * k / nu)
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
            if g != 0.0 || sc.wall_velocity_m_s != 0.0 {
                return invalid(
                    "pressure-channel: acceleration_m_s2 and wall_velocity_m_s must be 0 (the \
                     ends drive the flow)",
                );
            }
            let (inlet, est) =
                match (sc.pressure_drop_pa, sc.inlet_velocity_m_s) {
                    (Some(dp), None) => {
                        // lattice pressure c_s^2 rho: drho = 3 dp dt^2 / (rho dx^2)
                        let drho = 3.0 * dp * u.dt * u.dt / (sc.rho_kg_m3 * u.dx * u.dx);
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
        other => {
            return invalid(format!(
                "flow = \"{other}\": must be \"channel\", \"porous-channel\", \"sphere-array\" \
                 or \"pressure-channel\""
            ))
        }
    };
    // the lattice each flow builds, refused before anything is allocated
    let n = sc.cells;
    let dims = match (&sc.flow[..], driven) {
        ("sphere-array", _) => Dims::new(n, n, n)?,
        (_, Some((length, _, _))) => Dims::new(length + 1, n + 2, 1)?,
        _ => Dims::new(1, n + 2, 1)?,
    };
    let porous_fields = if porous.is_some() { POROUS_PER_CELL } else { 0 };
    check_memory(dims, lat.q(), SCENE_PER_CELL + porous_fields)?;
    check_mach(u_est, "estimated peak velocity")?;
    Ok(Prepared {
        sc,
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
    })
}

/// Checks an LBM scene as [`run_scene`] does before it runs (`porelab sweep plan`).
pub fn check_scene(text: &str, origin: &str) -> Result<()> {
    prepare(text, origin).map(|_| ())
}

pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let Prepared {
        sc,
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
    } = prepare(text, origin)?;
    println!(
        "lbm scene {origin}: {} {} {}, {} cells across {} m (dx = {:e} m, dt = {:e} s)",
        sc.flow,
        lat.name(),
        coll.name(),
        sc.cells,
        sc.length_m,
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
        let mut csv = String::from("y_m,u_m_s,u_exact_m_s\n");
        for y in 1..=sc.cells {
            let v = vel[d.cell(o.profile_x, y, 0)];
            let yc = channel_coordinate(y);
            let exact = match (driven, porous) {
                (Some((len, Inlet::Density(rho_in), rho_out)), _) => {
                    Some((rho_in - rho_out) / (3.0 * len as f64) * yc * (h - yc) / (2.0 * nu))
                }
                (Some((_, Inlet::Parabola(um), _)), _) => Some(4.0 * um * yc * (h - yc) / (h * h)),
                (None, None) => Some(g * yc * (h - yc) / (2.0 * nu) + wall_u * yc / h),
                (None, Some((eps, k, false))) => Some(brinkman_poiseuille(yc, h, g, nu, eps, k)),
                (None, Some(_)) => None,
            };
            csv += &format!(
                "{},{},{}\n",
                yc * u.dx,
                v[0],
                exact.map_or(String::new(), |e| u.velocity_to_si(e).to_string())
            );
        }
        write_atomic(&out.join("profile.csv"), csv.as_bytes())?;
        let column = |y: &'static str| CsvPlot {
            title: "Velocity profile across the channel",
            x: "y_m",
            y,
            x_label: "y (m)",
            y_label: "u (m/s)",
            ..Default::default()
        };
        // the lattice profile and the closed form as two labelled series of one picture
        let mut series = Vec::new();
        for (y, label) in [
            ("u_m_s", "lattice Boltzmann"),
            ("u_exact_m_s", "closed form"),
        ] {
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
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .map_err(|e| Error::InvalidInput(e.to_string()))?
            .as_bytes(),
    )?;
    println!("  wrote {}", out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let e = check_scene(&both, "t").unwrap_err().to_string();
        assert!(e.contains("exactly one of pressure_drop_pa"), "{e}");
        let e = check_scene(&b.toml.replace("0.03", "300.0"), "t")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pressure_drop_pa = 300"), "{e}");
        let e = check_scene(&b.toml.replace("2e-3", "2.01e-3"), "t")
            .unwrap_err()
            .to_string();
        assert!(e.contains("whole number"), "{e}");
        let stray = format!("{}pressure_drop_pa = 1.0\n", builtins()[0].toml);
        let e = check_scene(&stray, "t").unwrap_err().to_string();
        assert!(e.contains("only flow = \"pressure-channel\""), "{e}");
    }
}
