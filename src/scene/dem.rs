//! DEM scenes (`kind = "dem"`): soft spheres settled, compressed or dragged into a bed by the
//! engine of [`crate::dem`]. SI units; z is the vertical (the seed's x).
//!
//! Schema (defaults in brackets):
//!
//! ```toml
//! kind = "dem"
//! title = "..."
//! seed = 1                           # ChaCha8 seed of the sizes and the dispersion [1]
//! [particles]
//! n = 300                            # number of spheres (required, >= 1)
//! density_kg_m3 = 2500.0             # [2500]
//! size = "mono"                      # "mono" | "lognormal" | "table" [mono]
//! diameter_m = 4e-4                  # mono (required for mono)
//! median_diameter_m = 4e-4           # lognormal: median, sigma of ln d, clipped to [min, max]
//! sigma_ln = 0.2
//! min_diameter_m = 2e-4
//! max_diameter_m = 8e-4
//! diameters_m = [3e-4, 4e-4]         # table: diameters and their number fractions
//! number_fractions = [0.5, 0.5]
//! [box]
//! lx_m = 1.6e-3                      # periodic lengths (required)
//! ly_m = 1.6e-3
//! height_m = 1.6e-2                  # top wall height; or give `porosity` instead
//! porosity = 0.75                    # initial porosity of the dispersion (sets the height)
//! [contact]
//! model = "hertz-mindlin"            # "hertz-mindlin" | "hertz" (frictionless) | "linear" | "zhou2002"
//! young_pa = 1e7                     # Hertz models (required there)
//! poisson = 0.3                      # [0.3]
//! wall_young_pa = 1e7                # [young_pa]
//! wall_poisson = 0.3                 # [poisson]
//! k_n_n_per_m = 1e3                  # linear (required there)
//! kt_over_kn = 0.2857                # linear tangential spring [2/7]
//! restitution = 0.5                  # normal damping by restitution, (0, 1] [0.5]
//! friction = 0.5                     # Coulomb mu (hertz-mindlin, linear) [0.5]
//! tangential_damping_ratio = 1.0     # eta_t / eta_n [1]
//! c_n = 0.3                          # zhou2002: normal damping coefficient [0.3]
//! c_t = 0.3                          # zhou2002: tangential damping coefficient [c_n]
//! [drivers]
//! gravity_m_s2 = 9.81                # along -z [0]
//! fluid_density_kg_m3 = 0.0          # buoyancy [0]
//! viscosity_pa_s = 1e-3              # uniform Stokes drag on (with fluid_velocity_m_s)
//! fluid_velocity_m_s = [0, 0, -0.2]  # U_F [0, 0, 0]
//! top_pressure_pa = 184.0            # pressure-controlled top wall on
//! top_speed_max_m_s = 0.05           # its speed limit [0.05]
//! [run]
//! dt_s = 1e-6                        # [automatic: min(0.2 t_Rayleigh, t_contact / 50)]
//! skin_m = 1.2e-4                    # [0.3 d_min]
//! max_time_s = 1.0                   # guard on simulated time [1]
//! check_every_s = 0.01               # stop test and history interval [0.01]
//! ke_fraction = 1e-6                 # stop when KE < ke_fraction * peak KE ... [1e-6]
//!                                    # (KE without the spin of spheres touching nothing)
//! height_tol_over_d = 1e-3           # ... and the bed top moved < this * <d> since last check
//! profile_bins = 60                  # slabs of the porosity profile [60]
//! trajectory_every_s = 0.05          # a trajectory frame at this interval [none]
//! rdf_max_over_d = 3.0               # g(r) range in <d> [3, or half the narrower side]
//! rdf_bins = 150                     # [150]
//! pore_voxels_per_d = 10.0           # pore-size grid resolution, 0: none [10]
//! ```
//!
//! Outputs (README, "Output formats"): `final.xyz`, `trajectory/frame_NNNNNN.xyz`,
//! `profile.csv`, `history.csv`, `rdf.csv`, `pore_sizes.csv`, `summary.json`, and while running
//! `checkpoint.json`, from which an interrupted run resumes bitwise.

use super::parse_checkpoint;
use super::{on_threads, Builtin, RunOptions};
use crate::analysis::{pore_size, rdf, rdf::Bed};
use crate::dem::checkpoint::DemState;
use crate::dem::{
    observe, start, ContactModel, DampingModel, Dem, DemSetup, Drag, Material, NormalModel,
    Particles, TangentialModel, TopWall,
};
use crate::error::{invalid, Error};
use crate::io::plot::CsvPlot;
use crate::io::{write_atomic, xyz};
use crate::Result;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use serde::Deserialize;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// The built-in DEM scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "dem-small",
            about:
                "DEM: 300 spheres d = 400 um settling under gravity, seed 002 proportions (seconds)",
            toml: include_str!("builtin/dem-small.toml"),
        },
        Builtin {
            name: "dem-seed-gravity",
            about: "DEM: seed 002's 2014 spheres d = 400 um in 3 x 3 x 30 mm, gravity-driven",
            toml: include_str!("builtin/dem-seed-gravity.toml"),
        },
        Builtin {
            name: "dem-seed-compression",
            about: "DEM: seed 002's 2014 spheres, pressure-controlled top wall, no gravity",
            toml: include_str!("builtin/dem-seed-compression.toml"),
        },
        Builtin {
            name: "dem-seed-drag",
            about: "DEM: seed 002's 2014 spheres, uniform Stokes drag towards the floor",
            toml: include_str!("builtin/dem-seed-drag.toml"),
        },
    ]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    kind: String,
    #[serde(default)]
    title: String,
    #[serde(default = "one")]
    seed: u64,
    particles: ParticlesSpec,
    #[serde(rename = "box")]
    box_: BoxSpec,
    contact: ContactSpec,
    #[serde(default)]
    drivers: DriversSpec,
    #[serde(default)]
    run: RunSpec,
}

fn one() -> u64 {
    1
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParticlesSpec {
    n: usize,
    density_kg_m3: Option<f64>,
    size: Option<String>,
    diameter_m: Option<f64>,
    median_diameter_m: Option<f64>,
    sigma_ln: Option<f64>,
    min_diameter_m: Option<f64>,
    max_diameter_m: Option<f64>,
    diameters_m: Option<Vec<f64>>,
    number_fractions: Option<Vec<f64>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct BoxSpec {
    lx_m: f64,
    ly_m: f64,
    height_m: Option<f64>,
    porosity: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactSpec {
    model: String,
    young_pa: Option<f64>,
    poisson: Option<f64>,
    wall_young_pa: Option<f64>,
    wall_poisson: Option<f64>,
    k_n_n_per_m: Option<f64>,
    kt_over_kn: Option<f64>,
    restitution: Option<f64>,
    friction: Option<f64>,
    tangential_damping_ratio: Option<f64>,
    c_n: Option<f64>,
    c_t: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct DriversSpec {
    gravity_m_s2: Option<f64>,
    fluid_density_kg_m3: Option<f64>,
    viscosity_pa_s: Option<f64>,
    fluid_velocity_m_s: Option<[f64; 3]>,
    top_pressure_pa: Option<f64>,
    top_speed_max_m_s: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RunSpec {
    dt_s: Option<f64>,
    skin_m: Option<f64>,
    max_time_s: Option<f64>,
    check_every_s: Option<f64>,
    ke_fraction: Option<f64>,
    height_tol_over_d: Option<f64>,
    profile_bins: Option<usize>,
    trajectory_every_s: Option<f64>,
    rdf_max_over_d: Option<f64>,
    rdf_bins: Option<usize>,
    pore_voxels_per_d: Option<f64>,
}

/// Default normal damping coefficient of `model = "zhou2002"` (a choice of this code, not a
/// value of the source: a head-on impact then rebounds at e = 0.25, case 713; above
/// c_n ~ 0.7 the law captures, e = 0).
pub const ZHOU_C_N_DEFAULT: f64 = 0.3;

/// A parsed DEM scene: the engine setup, the radii and the run controls.
pub struct DemScene {
    pub title: String,
    pub seed: u64,
    pub setup: DemSetup,
    pub radius: Vec<f64>,
    pub height_m: f64,
    pub max_time_s: f64,
    pub check_every_s: f64,
    pub ke_fraction: f64,
    pub height_tol_over_d: f64,
    pub profile_bins: usize,
    /// Relative impact speed scale for the time-step rule (m/s).
    pub v_scale: f64,
    /// A trajectory frame every this many checks (`None`: no trajectory).
    pub frame_every_checks: Option<u64>,
    /// g(r) out to this many mean diameters (`None`: 3, or half the narrower lateral side).
    pub rdf_max_over_d: Option<f64>,
    pub rdf_bins: usize,
    /// Voxels per mean diameter of the pore-size grid (0: no pore sizes).
    pub pore_voxels_per_d: f64,
    /// FNV-1a hash of the scene text: a checkpoint resumes only the scene that wrote it.
    pub fingerprint: String,
}

fn positive(origin: &str, key: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        invalid(format!(
            "{origin}: {key} = {v}: must be positive and finite"
        ))
    }
}

fn need(origin: &str, key: &str, v: Option<f64>, when: &str) -> Result<f64> {
    match v {
        Some(x) => positive(origin, key, x),
        None => invalid(format!("{origin}: {key} is required {when}")),
    }
}

fn refuse(origin: &str, key: &str, present: bool, why: &str) -> Result<()> {
    if present {
        invalid(format!("{origin}: {key}: {why}"))
    } else {
        Ok(())
    }
}

/// Parses a DEM scene; every error names the key, the value and the rule.
pub fn parse_scene(text: &str, origin: &str) -> Result<DemScene> {
    let f: SceneFile = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("dem scene: {e}"),
    })?;
    if f.kind != "dem" {
        return invalid(format!(
            "{origin}: kind = \"{}\": a DEM scene needs kind = \"dem\"",
            f.kind
        ));
    }
    let p = &f.particles;
    if p.n == 0 {
        return invalid(format!("{origin}: particles.n = 0: must be at least 1"));
    }
    let rho = positive(
        origin,
        "particles.density_kg_m3",
        p.density_kg_m3.unwrap_or(2500.0),
    )?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(f.seed);
    let size = p.size.clone().unwrap_or_else(|| "mono".into());
    let diameters: Vec<f64> = match size.as_str() {
        "mono" => {
            let d = need(
                origin,
                "particles.diameter_m",
                p.diameter_m,
                "for size = \"mono\"",
            )?;
            vec![d; p.n]
        }
        "lognormal" => {
            let med = need(
                origin,
                "particles.median_diameter_m",
                p.median_diameter_m,
                "for size = \"lognormal\"",
            )?;
            let s = need(
                origin,
                "particles.sigma_ln",
                p.sigma_ln,
                "for size = \"lognormal\"",
            )?;
            let lo = positive(
                origin,
                "particles.min_diameter_m",
                p.min_diameter_m.unwrap_or(med * (-3.0 * s).exp()),
            )?;
            let hi = positive(
                origin,
                "particles.max_diameter_m",
                p.max_diameter_m.unwrap_or(med * (3.0 * s).exp()),
            )?;
            if lo >= hi {
                return invalid(format!(
                    "{origin}: particles.min_diameter_m = {lo} must be below max_diameter_m = {hi}"
                ));
            }
            (0..p.n)
                .map(|_| {
                    // Box-Muller normal, then clipped
                    let (u1, u2): (f64, f64) = (1.0 - rng.gen::<f64>(), rng.gen::<f64>());
                    let z = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                    (med * (s * z).exp()).clamp(lo, hi)
                })
                .collect()
        }
        "table" => {
            let (Some(ds), Some(fr)) = (&p.diameters_m, &p.number_fractions) else {
                return invalid(format!("{origin}: size = \"table\" needs particles.diameters_m and particles.number_fractions"));
            };
            if ds.is_empty() || ds.len() != fr.len() {
                return invalid(format!("{origin}: particles.diameters_m ({} values) and number_fractions ({} values): must be non-empty and of equal length", ds.len(), fr.len()));
            }
            for (k, d) in ds.iter().enumerate() {
                positive(origin, &format!("particles.diameters_m[{k}]"), *d)?;
            }
            let total: f64 = fr.iter().sum();
            if fr.iter().any(|x| !(x.is_finite() && *x >= 0.0)) || total.is_nan() || total <= 0.0 {
                return invalid(format!("{origin}: particles.number_fractions = {fr:?}: must be >= 0 with a positive sum"));
            }
            // deterministic counts by largest remainder, then shuffled by the scene's stream
            let mut counts: Vec<usize> = fr
                .iter()
                .map(|x| (x / total * p.n as f64).floor() as usize)
                .collect();
            let mut left = p.n - counts.iter().sum::<usize>();
            let mut order: Vec<usize> = (0..fr.len()).collect();
            order.sort_by(|&a, &b| {
                let ra = fr[a] / total * p.n as f64 - counts[a] as f64;
                let rb = fr[b] / total * p.n as f64 - counts[b] as f64;
                rb.total_cmp(&ra)
            });
            for &k in order.iter().cycle() {
                if left == 0 {
                    break;
                }
                counts[k] += 1;
                left -= 1;
            }
            let mut v: Vec<f64> = counts
                .iter()
                .zip(ds)
                .flat_map(|(c, d)| std::iter::repeat_n(*d, *c))
                .collect();
            for i in (1..v.len()).rev() {
                let j = rng.gen_range(0..=i);
                v.swap(i, j);
            }
            v
        }
        other => {
            return invalid(format!(
            "{origin}: particles.size = \"{other}\": must be \"mono\", \"lognormal\" or \"table\""
        ))
        }
    };
    let radius: Vec<f64> = diameters.iter().map(|d| 0.5 * d).collect();
    let solid: f64 = radius.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
    let b = &f.box_;
    let lx = positive(origin, "box.lx_m", b.lx_m)?;
    let ly = positive(origin, "box.ly_m", b.ly_m)?;
    let height = match (b.height_m, b.porosity) {
        (Some(h), None) => positive(origin, "box.height_m", h)?,
        (None, Some(e)) => {
            if !(e > 0.0 && e < 1.0) {
                return invalid(format!("{origin}: box.porosity = {e}: must lie in (0, 1)"));
            }
            solid / ((1.0 - e) * lx * ly)
        }
        (Some(_), Some(_)) => {
            return invalid(format!(
                "{origin}: box: give height_m or porosity, not both"
            ))
        }
        (None, None) => return invalid(format!("{origin}: box: height_m or porosity is required")),
    };
    let c = &f.contact;
    let zhou = c.model == "zhou2002";
    refuse(
        origin,
        "contact.c_n",
        c.c_n.is_some() && !zhou,
        "only model = \"zhou2002\" has it",
    )?;
    refuse(
        origin,
        "contact.c_t",
        c.c_t.is_some() && !zhou,
        "only model = \"zhou2002\" has it",
    )?;
    let restitution = c.restitution.unwrap_or(0.5);
    let mut damping = DampingModel::restitution(restitution)
        .map_err(|e| Error::InvalidInput(format!("{origin}: contact.restitution: {e}")))?;
    let mu = c.friction.unwrap_or(0.5);
    if !(mu.is_finite() && mu >= 0.0) {
        return invalid(format!(
            "{origin}: contact.friction = {mu}: must be >= 0 and finite"
        ));
    }
    let damp_ratio = c.tangential_damping_ratio.unwrap_or(1.0);
    if !(damp_ratio.is_finite() && damp_ratio >= 0.0) {
        return invalid(format!(
            "{origin}: contact.tangential_damping_ratio = {damp_ratio}: must be >= 0 and finite"
        ));
    }
    let poisson = c.poisson.unwrap_or(0.3);
    let material = |key: &str, e: f64, nu: f64| {
        Material::new(e, nu)
            .map_err(|err| Error::InvalidInput(format!("{origin}: contact.{key}: {err}")))
    };
    let (normal, tangential, young) = match c.model.as_str() {
        "hertz-mindlin" | "hertz" => {
            refuse(origin, "contact.k_n_n_per_m", c.k_n_n_per_m.is_some(), "only the linear model has it")?;
            refuse(origin, "contact.kt_over_kn", c.kt_over_kn.is_some(), "only the linear model has it")?;
            let young = need(origin, "contact.young_pa", c.young_pa, "for Hertz models")?;
            let t = if c.model == "hertz" {
                refuse(origin, "contact.friction", c.friction.is_some(), "model \"hertz\" is frictionless (use \"hertz-mindlin\")")?;
                TangentialModel::None
            } else {
                TangentialModel::Mindlin { mu, damp_ratio }
            };
            (NormalModel::Hertz, t, young)
        }
        "linear" => {
            let k = need(origin, "contact.k_n_n_per_m", c.k_n_n_per_m, "for model = \"linear\"")?;
            let kt = positive(origin, "contact.kt_over_kn", c.kt_over_kn.unwrap_or(2.0 / 7.0))?;
            let t = if mu > 0.0 {
                TangentialModel::Linear { kt_over_kn: kt, mu, damp_ratio }
            } else {
                TangentialModel::None
            };
            (NormalModel::Linear { k_n_n_per_m: k }, t, c.young_pa.unwrap_or(1e7))
        }
        "zhou2002" => {
            for (key, present) in [
                ("contact.k_n_n_per_m", c.k_n_n_per_m.is_some()),
                ("contact.kt_over_kn", c.kt_over_kn.is_some()),
                ("contact.restitution", c.restitution.is_some()),
                ("contact.tangential_damping_ratio", c.tangential_damping_ratio.is_some()),
            ] {
                refuse(origin, key, present, "model \"zhou2002\" damps by contact.c_n and contact.c_t")?;
            }
            let young = need(origin, "contact.young_pa", c.young_pa, "for model = \"zhou2002\"")?;
            let c_n = c.c_n.unwrap_or(ZHOU_C_N_DEFAULT);
            let c_t = c.c_t.unwrap_or(c_n);
            for (key, v) in [("contact.c_n", c_n), ("contact.c_t", c_t)] {
                if !(v.is_finite() && v >= 0.0) {
                    return invalid(format!("{origin}: {key} = {v}: must be >= 0 and finite"));
                }
            }
            damping = if c_n > 0.0 { DampingModel::Zhou { c_n } } else { DampingModel::None };
            let t = if mu > 0.0 { TangentialModel::Zhou { mu, c_t } } else { TangentialModel::None };
            (NormalModel::Hertz, t, young)
        }
        other => return invalid(format!("{origin}: contact.model = \"{other}\": must be \"hertz-mindlin\", \"hertz\", \"linear\" or \"zhou2002\"")),
    };
    let pm = material("young_pa/poisson", young, poisson)?;
    let wm = material(
        "wall_young_pa/wall_poisson",
        c.wall_young_pa.unwrap_or(young),
        c.wall_poisson.unwrap_or(poisson),
    )?;
    let d = &f.drivers;
    let g = d.gravity_m_s2.unwrap_or(0.0);
    if !(g.is_finite() && g >= 0.0) {
        return invalid(format!(
            "{origin}: drivers.gravity_m_s2 = {g}: must be >= 0 (it points along -z)"
        ));
    }
    let rho_f = d.fluid_density_kg_m3.unwrap_or(0.0);
    if !(rho_f.is_finite() && rho_f >= 0.0 && rho_f < rho) {
        return invalid(format!("{origin}: drivers.fluid_density_kg_m3 = {rho_f}: must be >= 0 and below the particle density {rho}"));
    }
    let u = d.fluid_velocity_m_s.unwrap_or([0.0; 3]);
    if u.iter().any(|x| !x.is_finite()) {
        return invalid(format!(
            "{origin}: drivers.fluid_velocity_m_s = {u:?}: must be finite"
        ));
    }
    let drag = match d.viscosity_pa_s {
        Some(mu_f) => Some(Drag {
            viscosity_pa_s: positive(origin, "drivers.viscosity_pa_s", mu_f)?,
            fluid_velocity_m_s: Vector3::from(u),
        }),
        None => {
            refuse(
                origin,
                "drivers.fluid_velocity_m_s",
                d.fluid_velocity_m_s.is_some(),
                "needs drivers.viscosity_pa_s",
            )?;
            None
        }
    };
    let top = match d.top_pressure_pa {
        Some(pt) => TopWall::Pressure {
            z0_m: height,
            target_pa: positive(origin, "drivers.top_pressure_pa", pt)?,
            speed_max_m_s: positive(
                origin,
                "drivers.top_speed_max_m_s",
                d.top_speed_max_m_s.unwrap_or(0.05),
            )?,
        },
        None => {
            refuse(
                origin,
                "drivers.top_speed_max_m_s",
                d.top_speed_max_m_s.is_some(),
                "needs drivers.top_pressure_pa",
            )?;
            TopWall::Fixed { z_m: height }
        }
    };
    let r = &f.run;
    let d_min = diameters.iter().cloned().fold(f64::INFINITY, f64::min);
    let setup = DemSetup {
        lx_m: lx,
        ly_m: ly,
        contact: ContactModel {
            normal,
            damping,
            tangential,
        },
        particle_material: pm,
        wall_material: wm,
        density_kg_m3: rho,
        gravity_m_s2: Vector3::new(0.0, 0.0, -g),
        fluid_density_kg_m3: rho_f,
        drag,
        top,
        dt_s: r
            .dt_s
            .map(|x| positive(origin, "run.dt_s", x))
            .transpose()?,
        skin_m: Some(positive(
            origin,
            "run.skin_m",
            r.skin_m.unwrap_or(0.3 * d_min),
        )?),
    };
    let ke_fraction = positive(origin, "run.ke_fraction", r.ke_fraction.unwrap_or(1e-6))?;
    let bins = r.profile_bins.unwrap_or(60);
    if bins == 0 {
        return invalid(format!(
            "{origin}: run.profile_bins = 0: must be at least 1"
        ));
    }
    let check_every_s = positive(origin, "run.check_every_s", r.check_every_s.unwrap_or(0.01))?;
    let frame_every_checks = match r.trajectory_every_s {
        None => None,
        Some(t) => {
            let t = positive(origin, "run.trajectory_every_s", t)?;
            if t < check_every_s * (1.0 - 1e-9) {
                return invalid(format!(
                    "{origin}: run.trajectory_every_s = {t}: must be at least run.check_every_s = \
                     {check_every_s} (frames are written at checks)"
                ));
            }
            Some((t / check_every_s).round() as u64)
        }
    };
    let rdf_max_over_d = r
        .rdf_max_over_d
        .map(|x| positive(origin, "run.rdf_max_over_d", x))
        .transpose()?;
    let rdf_bins = r.rdf_bins.unwrap_or(150);
    if rdf_bins == 0 {
        return invalid(format!("{origin}: run.rdf_bins = 0: must be at least 1"));
    }
    let pore_voxels_per_d = r.pore_voxels_per_d.unwrap_or(10.0);
    if !(pore_voxels_per_d.is_finite() && pore_voxels_per_d >= 0.0) {
        return invalid(format!(
            "{origin}: run.pore_voxels_per_d = {pore_voxels_per_d}: must be >= 0 and finite (0: \
             no pore sizes)"
        ));
    }
    let v_wall = match top {
        TopWall::Pressure { speed_max_m_s, .. } => speed_max_m_s,
        TopWall::Fixed { .. } => 0.0,
    };
    Ok(DemScene {
        title: f.title,
        seed: f.seed,
        setup,
        radius,
        height_m: height,
        max_time_s: positive(origin, "run.max_time_s", r.max_time_s.unwrap_or(1.0))?,
        check_every_s,
        ke_fraction,
        height_tol_over_d: positive(
            origin,
            "run.height_tol_over_d",
            r.height_tol_over_d.unwrap_or(1e-3),
        )?,
        profile_bins: bins,
        v_scale: (2.0 * g * height).sqrt() + 2.0 * Vector3::from(u).norm() + 2.0 * v_wall,
        frame_every_checks,
        rdf_max_over_d,
        rdf_bins,
        pore_voxels_per_d,
        fingerprint: format!("{:016x}", crate::io::fnv1a64(text.as_bytes())),
    })
}

/// The result of a scene run (also written as summary.json).
#[derive(Debug, Clone, serde::Serialize)]
pub struct DemSummary {
    pub title: String,
    pub n: usize,
    pub active_terms: Vec<&'static str>,
    pub dt_s: f64,
    pub steps: u64,
    pub simulated_time_s: f64,
    pub seconds: f64,
    pub neighbour_share: f64,
    pub neighbour_builds: usize,
    pub stop: String,
    pub bed_top_m: f64,
    pub porosity_below_top: f64,
    pub bulk_region_m: Option<(f64, f64)>,
    pub porosity_bulk: Option<f64>,
    pub mean_coordination: f64,
    /// Mean sphere–sphere contacts of the spheres with centres in the bulk region.
    pub coordination_bulk: Option<f64>,
    pub max_overlap_over_diameter: f64,
    pub floor_force_over_weight: Option<f64>,
    pub top_wall_z_m: f64,
    pub top_pressure_pa: f64,
    pub kinetic_energy_j: f64,
    /// r / <D> of the highest bin of g(r) (the nearest-neighbour peak), when g was computed.
    pub rdf_peak_r_over_d: Option<f64>,
    /// Pore sizes (local thickness) between the lowest and highest centres, when computed.
    pub pores: Option<PoreSummary>,
}

/// The pore-size part of the summary.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PoreSummary {
    pub voxel_m: [f64; 3],
    pub grid: [usize; 3],
    pub z_range_m: (f64, f64),
    pub grid_porosity: f64,
    /// Pore-volume-weighted mean and median of the pore diameter 2 LT over <D>.
    pub mean_diameter_over_d: f64,
    pub median_diameter_over_d: f64,
}

/// Builds the engine of a parsed scene from the random dispersion.
pub fn build(scene: &DemScene) -> Result<Dem> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(scene.seed ^ 0x5eed_d15c);
    let pos = start::random_dispersion(
        &scene.radius,
        scene.setup.lx_m,
        scene.setup.ly_m,
        scene.height_m,
        &mut rng,
    )?;
    // numbered cell by cell (cells of the largest diameter), the radii with their spheres
    let d_max = scene.radius.iter().cloned().fold(0.0, f64::max) * 2.0;
    let order = start::cell_order(&pos, d_max);
    let pos = order.iter().map(|&i| pos[i]).collect();
    let radius = order.iter().map(|&i| scene.radius[i]).collect();
    let p = Particles::at_rest(pos, radius, scene.setup.density_kg_m3);
    Dem::new(scene.setup.clone(), p, scene.v_scale)
}

/// What the stop test remembers between checks (kept in checkpoints).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunProgress {
    /// Largest kinetic energy seen at a check (J).
    pub ke_peak_j: f64,
    /// Bed top at the previous check (m).
    pub top_prev_m: f64,
    /// Checks done since the start.
    pub checks: u64,
}

impl RunProgress {
    pub fn start(dem: &Dem) -> RunProgress {
        let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
        RunProgress {
            ke_peak_j: 0.0,
            top_prev_m: observe::bed_top(&z, &dem.p.radius),
            checks: 0,
        }
    }
}

/// Runs a parsed scene to its stop criterion; `on_check` sees every check (history rows).
pub fn run(
    scene: &DemScene,
    dem: &mut Dem,
    mut on_check: impl FnMut(&Dem, f64),
) -> Result<(String, f64)> {
    let start = Instant::now();
    let mut progress = RunProgress::start(dem);
    let stop = run_checks(scene, dem, &mut progress, None, |d, ke, _| {
        on_check(d, ke);
        Ok(())
    })?;
    Ok((stop.unwrap_or_default(), start.elapsed().as_secs_f64()))
}

/// Advances check by check from `progress` until the stop criterion (returns its reason) or,
/// with `max_checks`, until that many checks are done (returns `None`, as an interrupted run).
/// `on_check` sees every check after the stop test, with the updated progress.
pub fn run_checks(
    scene: &DemScene,
    dem: &mut Dem,
    progress: &mut RunProgress,
    max_checks: Option<u64>,
    mut on_check: impl FnMut(&Dem, f64, &RunProgress) -> Result<()>,
) -> Result<Option<String>> {
    let steps_per_check = ((scene.check_every_s / dem.dt_s).round() as u64).max(1);
    let d_mean = 2.0 * scene.radius.iter().sum::<f64>() / scene.radius.len() as f64;
    let mut done = 0u64;
    loop {
        if max_checks.is_some_and(|m| done >= m) {
            return Ok(None);
        }
        dem.run(steps_per_check)?;
        done += 1;
        progress.checks += 1;
        let ke = dem.kinetic_energy();
        // the stop rule's energy leaves out the free spin of spheres touching nothing
        let ke_settling = dem.settling_kinetic_energy();
        progress.ke_peak_j = progress.ke_peak_j.max(ke_settling);
        let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
        let top = observe::bed_top(&z, &dem.p.radius);
        let ratio = dem.max_overlap_ratio();
        if ratio > 0.1 {
            on_check(dem, ke, progress)?;
            return invalid(format!(
                "overlap {ratio:.3} of a diameter at t = {:e} s: the contacts are too soft for the load \
                 (raise contact.young_pa or lower the driving force)",
                dem.time_s
            ));
        }
        let stop = if progress.ke_peak_j > 0.0
            && ke_settling < scene.ke_fraction * progress.ke_peak_j
            && (top - progress.top_prev_m).abs() < scene.height_tol_over_d * d_mean
        {
            Some(format!(
                "settled: KE < {} of its peak and bed top steady",
                scene.ke_fraction
            ))
        } else if dem.time_s >= scene.max_time_s {
            Some(format!(
                "time limit {} s reached before settling",
                scene.max_time_s
            ))
        } else {
            None
        };
        progress.top_prev_m = top;
        on_check(dem, ke, progress)?;
        if stop.is_some() {
            return Ok(stop);
        }
    }
}

/// g(r) of a bed over its bulk region (`None`, with the reason, when it cannot be formed).
pub fn bed_rdf(scene: &DemScene, dem: &Dem) -> std::result::Result<Vec<(f64, f64)>, String> {
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let top = observe::bed_top(&z, &dem.p.radius);
    let bed = Bed {
        pos: &dem.p.pos,
        radius: &dem.p.radius,
        lx_m: scene.setup.lx_m,
        ly_m: scene.setup.ly_m,
    };
    let half_side = 0.5 * scene.setup.lx_m.min(scene.setup.ly_m) / bed.mean_diameter();
    let r_max = scene.rdf_max_over_d.unwrap_or(half_side.min(3.0));
    let (a, b) = observe::bulk_region(&z, &dem.p.radius, top)
        .ok_or_else(|| "no bulk region (the bed is thinner than 4 <d>)".to_string())?;
    rdf::slab_rdf(&bed, a, b, r_max, scene.rdf_bins).map_err(|e| e.to_string())
}

/// The pore-size distribution of a bed between its lowest and highest centres: rows (pore
/// diameter 2 LT in m, pore volume fraction) and the grid (`Err` with the reason when not
/// computed).
pub fn bed_pore_sizes(
    scene: &DemScene,
    dem: &Dem,
) -> std::result::Result<(Vec<(f64, f64)>, PoreSummary), String> {
    if scene.pore_voxels_per_d == 0.0 {
        return Err("run.pore_voxels_per_d = 0".into());
    }
    let bed = Bed {
        pos: &dem.p.pos,
        radius: &dem.p.radius,
        lx_m: scene.setup.lx_m,
        ly_m: scene.setup.ly_m,
    };
    pore_sizes(&bed, scene.pore_voxels_per_d)
}

/// The pore-size distribution (local thickness, periodic laterally) of `bed` between its lowest
/// and highest centres (seed 002, Fig. 11: "between the centres of the lowest and highest
/// particles") on cubic voxels of edge <D> / `voxels_per_d`: rows (pore diameter 2 LT in m,
/// pore volume fraction), diameters increasing, and the summary.
pub fn pore_sizes(
    bed: &Bed,
    voxels_per_d: f64,
) -> std::result::Result<(Vec<(f64, f64)>, PoreSummary), String> {
    let d = bed.mean_diameter();
    let (lo, hi) = bed
        .pos
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.z), b.max(p.z))
        });
    let grid = pore_size::voxelize_bed(bed, lo, hi, d / voxels_per_d).map_err(|e| e.to_string())?;
    let rows: Vec<(f64, f64)> = pore_size::pore_size_distribution(&grid)
        .map_err(|e| e.to_string())?
        .into_iter()
        .map(|(r, f)| (2.0 * r, f))
        .collect();
    let mean = rows.iter().map(|(dp, f)| dp * f).sum::<f64>() / d;
    let summary = PoreSummary {
        voxel_m: grid.spacing_m,
        grid: grid.n,
        z_range_m: (lo, hi),
        grid_porosity: grid.porosity(),
        mean_diameter_over_d: mean,
        median_diameter_over_d: pore_size::distribution_quantile(&rows, 0.5) / d,
    };
    Ok((rows, summary))
}

/// The summary of a finished run (without g(r) and pore sizes, which [`run_scene`] adds).
pub fn summarize(scene: &DemScene, dem: &Dem, stop: String, seconds: f64) -> DemSummary {
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let r = &dem.p.radius;
    let area = scene.setup.lx_m * scene.setup.ly_m;
    let top = observe::bed_top(&z, r);
    let bulk = observe::bulk_region(&z, r, top);
    let counts = dem.contact_counts();
    let w = dem.buoyant_weight_n();
    DemSummary {
        title: scene.title.clone(),
        n: dem.p.len(),
        active_terms: dem.active.names(),
        dt_s: dem.dt_s,
        steps: dem.steps,
        simulated_time_s: dem.time_s,
        seconds,
        neighbour_share: dem.neighbour_seconds / seconds.max(1e-12),
        neighbour_builds: dem.nl.builds,
        stop,
        bed_top_m: top,
        porosity_below_top: observe::slab_porosity(&z, r, area, 0.0, top),
        bulk_region_m: bulk,
        porosity_bulk: bulk.map(|(a, b)| observe::slab_porosity(&z, r, area, a, b)),
        mean_coordination: counts.iter().sum::<usize>() as f64 / counts.len().max(1) as f64,
        coordination_bulk: bulk
            .and_then(|(a, b)| rdf::mean_coordination_in(&dem.p.pos, &counts, a, b)),
        max_overlap_over_diameter: dem.max_overlap_ratio(),
        floor_force_over_weight: (w > 0.0).then(|| dem.floor_force_n / w),
        top_wall_z_m: dem.top_z_m,
        top_pressure_pa: dem.top_force_n / area,
        kinetic_energy_j: dem.kinetic_energy(),
        rdf_peak_r_over_d: None,
        pores: None,
    }
}

/// The checkpoint file: the scene's fingerprint, the run's progress and history so far, and
/// the engine state (floats as IEEE-754 bits).
#[derive(serde::Serialize, serde::Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: u64,
    ke_peak_j: u64,
    top_prev_m: u64,
    checks: u64,
    history: String,
    state: DemState,
}

/// Format 2: the neighbour-list pairs keep no forces (those are recomputed every step).
const CHECKPOINT_FORMAT: u32 = 2;

fn write_checkpoint(
    path: &Path,
    scene: &DemScene,
    dem: &Dem,
    progress: &RunProgress,
    history: &str,
    seconds: f64,
) -> Result<()> {
    let c = Checkpoint {
        format: CHECKPOINT_FORMAT,
        scene: scene.fingerprint.clone(),
        seconds: seconds.to_bits(),
        ke_peak_j: progress.ke_peak_j.to_bits(),
        top_prev_m: progress.top_prev_m.to_bits(),
        checks: progress.checks,
        history: history.to_string(),
        state: dem.save_state(),
    };
    let bytes = serde_json::to_vec(&c).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(path, &bytes)
}

/// Restores `dem` from the checkpoint at `path`: (progress, history so far, seconds so far).
fn read_checkpoint(
    path: &Path,
    scene: &DemScene,
    dem: &mut Dem,
) -> Result<(RunProgress, String, f64)> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let bytes =
        std::fs::read(path).map_err(|e| file_err(format!("cannot read the checkpoint: {e}")))?;
    let c: Checkpoint = parse_checkpoint(&bytes, CHECKPOINT_FORMAT, "DEM").map_err(file_err)?;
    if c.scene != scene.fingerprint {
        return Err(file_err(
            "written by a different scene (its text differs): delete it to start afresh, or \
             choose another output folder with --out"
                .into(),
        ));
    }
    dem.load_state(&c.state)
        .map_err(|e| file_err(e.to_string()))?;
    let f = f64::from_bits;
    Ok((
        RunProgress {
            ke_peak_j: f(c.ke_peak_j),
            top_prev_m: f(c.top_prev_m),
            checks: c.checks,
        },
        c.history,
        f(c.seconds),
    ))
}

/// The particles of a DEM system as extended-XYZ rows (radius per particle).
fn xyz_frame(scene: &DemScene, dem: &Dem) -> (xyz::Cell, Vec<xyz::XyzParticle>) {
    let parts = (0..dem.p.len())
        .map(|i| xyz::XyzParticle::sphere(dem.p.pos[i], dem.p.radius[i]))
        .collect();
    let cell = xyz::Cell {
        lengths: [scene.setup.lx_m, scene.setup.ly_m, dem.top_z_m],
        origin: [0.0; 3],
        pbc: [true, true, false],
    };
    (cell, parts)
}

/// Writes trajectory frame `k` (`trajectory/frame_NNNNNN.xyz`, atomically).
fn write_frame(out: &Path, scene: &DemScene, dem: &Dem, k: u64) -> Result<()> {
    let (cell, parts) = xyz_frame(scene, dem);
    xyz::write(
        &out.join("trajectory").join(format!("frame_{k:06}.xyz")),
        &cell,
        &parts,
        &[
            ("Time", format!("{}", dem.time_s)),
            ("Step", format!("{}", dem.steps)),
        ],
    )
}

/// `porelab run` on a DEM scene.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    run_scene_limited(text, origin, out, opts, None)
}

/// Runs (or resumes from `out/checkpoint.json`) a scene; with `max_checks` it stops after
/// that many checks, leaving the checkpoint behind as an interrupted run would (for tests).
fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_checks: Option<u64>,
) -> Result<()> {
    opts.check_checkpoint_interval()?;
    let scene = parse_scene(text, origin)?;
    let mut dem = build(&scene)?;
    let ckpt_path = out.join("checkpoint.json");
    let mut hist = String::from(
        "time_s,kinetic_energy_J,bed_top_m,top_wall_z_m,top_pressure_Pa,floor_force_N,max_overlap_over_diameter\n",
    );
    let (mut progress, base_seconds) = if ckpt_path.exists() {
        let (p, h, s) = read_checkpoint(&ckpt_path, &scene, &mut dem)?;
        hist = h;
        if !opts.quiet {
            eprintln!(
                "resuming {origin} from {} (step {}, t = {:e} s)",
                ckpt_path.display(),
                dem.steps,
                dem.time_s
            );
        }
        (p, s)
    } else {
        (RunProgress::start(&dem), 0.0)
    };
    crate::io::create_dir(out)?;
    eprintln!(
        "dem: {} spheres, dt = {:e} s, skin = {:e} m, active terms: {}",
        dem.p.len(),
        dem.dt_s,
        dem.nl.skin,
        dem.active.names().join(", ")
    );
    if let (Some(_), 0) = (scene.frame_every_checks, progress.checks) {
        write_frame(out, &scene, &dem, 0)?;
    }
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(1000);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} [{elapsed_precise}] {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    };
    let area = scene.setup.lx_m * scene.setup.ly_m;
    let t0 = Instant::now();
    let mut last_checkpoint = Instant::now();
    let run_it = || -> Result<Option<String>> {
        run_checks(&scene, &mut dem, &mut progress, max_checks, |d, ke, pr| {
            let z: Vec<f64> = d.p.pos.iter().map(|p| p.z).collect();
            let ov = d.max_overlap_ratio();
            let _ = writeln!(
                hist,
                "{},{},{},{},{},{},{}",
                d.time_s,
                ke,
                observe::bed_top(&z, &d.p.radius),
                d.top_z_m,
                d.top_force_n / area,
                d.floor_force_n,
                ov
            );
            if let Some(k) = scene.frame_every_checks {
                if pr.checks % k == 0 {
                    write_frame(out, &scene, d, pr.checks / k)?;
                }
            }
            let due = opts
                .checkpoint_every_seconds
                .is_none_or(|t| last_checkpoint.elapsed().as_secs_f64() >= t);
            if due {
                let seconds = base_seconds + t0.elapsed().as_secs_f64();
                write_checkpoint(&ckpt_path, &scene, d, pr, &hist, seconds)?;
                last_checkpoint = Instant::now();
            }
            bar.set_position(((d.time_s / scene.max_time_s) * 1000.0) as u64);
            bar.set_message(format!(
                "step {} t = {:.4} s KE = {ke:.2e} J overlap/d = {ov:.2e}",
                d.steps, d.time_s
            ));
            Ok(())
        })
    };
    let stop = on_threads(opts.threads, run_it)?;
    bar.finish_and_clear();
    let seconds = base_seconds + t0.elapsed().as_secs_f64();
    let Some(stop) = stop else {
        // interrupted: the checkpoint holds the state reached
        return write_checkpoint(&ckpt_path, &scene, &dem, &progress, &hist, seconds);
    };
    let mut summary = summarize(&scene, &dem, stop, seconds);
    write_atomic(&out.join("history.csv"), hist.as_bytes())?;
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let mut prof = String::from("z_lo_m,z_hi_m,porosity\n");
    for (a, b, e) in observe::porosity_profile(
        &z,
        &dem.p.radius,
        area,
        0.0,
        dem.top_z_m,
        scene.profile_bins,
    ) {
        let _ = writeln!(prof, "{a},{b},{e}");
    }
    write_atomic(&out.join("profile.csv"), prof.as_bytes())?;
    CsvPlot {
        title: "Porosity profile of the bed (exact sphere-slab volumes)",
        x: "z_lo_m",
        y: "porosity",
        x_label: "height of the slab's lower face (m)",
        y_label: "porosity",
        ..Default::default()
    }
    .write_or_warn(&out.join("profile.svg"), &prof);
    CsvPlot {
        title: "Kinetic energy of the particles",
        x: "time_s",
        y: "kinetic_energy_J",
        x_label: "time (s)",
        y_label: "kinetic energy (J)",
        log_y: true,
        ..Default::default()
    }
    .write_or_warn(&out.join("history.svg"), &hist);
    match bed_rdf(&scene, &dem) {
        Ok(g) => {
            let mut t = String::from("r_over_mean_d,g\n");
            for (r, v) in &g {
                let _ = writeln!(t, "{r},{v}");
            }
            write_atomic(&out.join("rdf.csv"), t.as_bytes())?;
            CsvPlot {
                title: "Radial distribution function of the bulk (seed 002 Fig. 3)",
                x: "r_over_mean_d",
                y: "g",
                x_label: "r / <D>",
                y_label: "g(r)",
                ..Default::default()
            }
            .write_or_warn(&out.join("rdf.svg"), &t);
            summary.rdf_peak_r_over_d = g.iter().max_by(|a, b| a.1.total_cmp(&b.1)).map(|x| x.0);
        }
        Err(why) => eprintln!("dem: g(r) not computed: {why}"),
    }
    match bed_pore_sizes(&scene, &dem) {
        Ok((rows, ps)) => {
            let d = 2.0 * scene.radius.iter().sum::<f64>() / scene.radius.len() as f64;
            let mut t =
                String::from("pore_diameter_m,pore_diameter_over_mean_d,pore_volume_fraction\n");
            for (dp, f) in &rows {
                let _ = writeln!(t, "{dp},{},{f}", dp / d);
            }
            write_atomic(&out.join("pore_sizes.csv"), t.as_bytes())?;
            CsvPlot {
                title: "Pore size distribution (local thickness, seed 002 Fig. 11)",
                x: "pore_diameter_over_mean_d",
                y: "pore_volume_fraction",
                x_label: "pore diameter / <D>",
                y_label: "fraction of the pore volume",
                ..Default::default()
            }
            .write_or_warn(&out.join("pore_sizes.svg"), &t);
            summary.pores = Some(ps);
        }
        Err(why) => eprintln!("dem: pore sizes not computed: {why}"),
    }
    let (cell, parts) = xyz_frame(&scene, &dem);
    xyz::write(
        &out.join("final.xyz"),
        &cell,
        &parts,
        &[("Time", format!("{}", dem.time_s))],
    )?;
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    // the outputs are complete: the checkpoint is no longer needed
    if ckpt_path.exists() {
        std::fs::remove_file(&ckpt_path).map_err(|e| Error::File {
            path: ckpt_path.display().to_string(),
            msg: format!("cannot remove the finished run's checkpoint: {e}"),
        })?;
    }
    println!(
        "{}: {} steps, dt = {:e} s, {:.1} s ({}); porosity below top {:.4}, bulk {}; coordination {:.2} (bulk {}); max overlap/d {:.2e}",
        origin,
        summary.steps,
        summary.dt_s,
        summary.seconds,
        summary.stop,
        summary.porosity_below_top,
        summary.porosity_bulk.map_or("-".into(), |e| format!("{e:.4}")),
        summary.mean_coordination,
        summary.coordination_bulk.map_or("-".into(), |c| format!("{c:.2}")),
        summary.max_overlap_over_diameter
    );
    println!("outputs in {}", out.display());
    Ok(())
}

/// `kind = "dem"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "dem"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        parse_scene(text, origin).map(|_| ())
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_parse() {
        for b in builtins() {
            parse_scene(b.toml, b.name).unwrap();
        }
    }

    fn quiet() -> RunOptions {
        RunOptions {
            out: None,
            threads: None,
            quiet: true,
            checkpoint_every_seconds: None,
        }
    }

    /// 100 spheres for 0.03 s of settling, a frame every 0.01 s, coarse pore grid.
    fn short_scene() -> String {
        include_str!("builtin/dem-small.toml")
            .replace("n = 300", "n = 100")
            .replace("porosity = 0.75", "porosity = 0.7")
            .replace("max_time_s = 1.0", "max_time_s = 0.03")
            .replace(
                "check_every_s = 0.01",
                "check_every_s = 0.005\ntrajectory_every_s = 0.01\npore_voxels_per_d = 6\nrdf_max_over_d = 1.0",
            )
    }

    /// A run stopped after two checks and resumed from its checkpoint writes bitwise the
    /// outputs of the uninterrupted run (all but the wall-clock figures of the summary).
    #[test]
    fn interrupted_run_resumes_to_the_same_result() {
        let base = std::env::temp_dir().join(format!("porelab-dem-resume-{}", std::process::id()));
        let (whole, killed) = (base.join("whole"), base.join("killed"));
        let text = short_scene();
        run_scene(&text, "test", &whole, &quiet()).unwrap();
        run_scene_limited(&text, "test", &killed, &quiet(), Some(2)).unwrap();
        assert!(killed.join("checkpoint.json").exists());
        assert!(!killed.join("final.xyz").exists());
        run_scene(&text, "test", &killed, &quiet()).unwrap();
        assert!(!killed.join("checkpoint.json").exists());
        let read = |d: &Path, f: &str| std::fs::read_to_string(d.join(f)).unwrap();
        for f in [
            "final.xyz",
            "history.csv",
            "profile.csv",
            "rdf.csv",
            "pore_sizes.csv",
            "trajectory/frame_000000.xyz",
            "trajectory/frame_000001.xyz",
            "trajectory/frame_000003.xyz",
        ] {
            assert!(read(&whole, f) == read(&killed, f), "{f} differs");
        }
        // every frame of the run is there and OVITO's reader sees radius per particle
        let (_, parts) = xyz::parse(&read(&whole, "trajectory/frame_000003.xyz"), "t").unwrap();
        assert_eq!(parts.len(), 100);
        assert!(parts.iter().all(|p| p.radius == 2e-4));
        let strip = |d: &Path| -> serde_json::Value {
            let mut v: serde_json::Value = serde_json::from_str(&read(d, "summary.json")).unwrap();
            for k in ["seconds", "neighbour_share"] {
                v.as_object_mut().unwrap().remove(k);
            }
            v
        };
        assert_eq!(strip(&whole), strip(&killed));
        // a checkpoint of another scene is refused, naming the file
        run_scene_limited(&text, "test", &killed, &quiet(), Some(1)).unwrap();
        let e = run_scene(
            &text.replace("seed = 1", "seed = 2"),
            "test",
            &killed,
            &quiet(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("checkpoint.json") && e.contains("different scene"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&base);
    }

    #[test]
    fn bad_keys_are_named() {
        let base = include_str!("builtin/dem-small.toml");
        let e = parse_scene(&base.replace("[run]", "[run]\nbogus_key = 1"), "t")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("bogus_key"), "{e}");
        let e = parse_scene(&base.replace("restitution = 0.5", "restitution = 1.5"), "t")
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("contact.restitution") && e.contains("1.5"),
            "{e}"
        );
        let e = parse_scene(&base.replace("young_pa = 1e7", "young_pa = -1"), "t")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("young_pa") && e.contains("-1"), "{e}");
    }
}
