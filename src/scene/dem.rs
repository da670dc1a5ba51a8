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
//! model = "hertz-mindlin"            # "hertz-mindlin" | "hertz" (frictionless) | "linear"
//! young_pa = 1e7                     # Hertz models (required there)
//! poisson = 0.3                      # [0.3]
//! wall_young_pa = 1e7                # [young_pa]
//! wall_poisson = 0.3                 # [poisson]
//! k_n_n_per_m = 1e3                  # linear (required there)
//! kt_over_kn = 0.2857                # linear tangential spring [2/7]
//! restitution = 0.5                  # normal damping by restitution, (0, 1] [0.5]
//! friction = 0.5                     # Coulomb mu (hertz-mindlin, linear) [0.5]
//! tangential_damping_ratio = 1.0     # eta_t / eta_n [1]
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
//! height_tol_over_d = 1e-3           # ... and the bed top moved < this * <d> since last check
//! profile_bins = 60                  # slabs of the porosity profile [60]
//! ```
//!
//! Outputs (README, "DEM outputs"): `final.xyz`, `profile.csv`, `history.csv`, `summary.json`.

use super::{Builtin, RunOptions};
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
}

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
    let restitution = c.restitution.unwrap_or(0.5);
    let damping = DampingModel::restitution(restitution)
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
        other => return invalid(format!("{origin}: contact.model = \"{other}\": must be \"hertz-mindlin\", \"hertz\" or \"linear\"")),
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
        check_every_s: positive(origin, "run.check_every_s", r.check_every_s.unwrap_or(0.01))?,
        ke_fraction,
        height_tol_over_d: positive(
            origin,
            "run.height_tol_over_d",
            r.height_tol_over_d.unwrap_or(1e-3),
        )?,
        profile_bins: bins,
        v_scale: (2.0 * g * height).sqrt() + 2.0 * Vector3::from(u).norm() + 2.0 * v_wall,
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
    pub max_overlap_over_diameter: f64,
    pub floor_force_over_weight: Option<f64>,
    pub top_wall_z_m: f64,
    pub top_pressure_pa: f64,
    pub kinetic_energy_j: f64,
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
    let p = Particles::at_rest(pos, scene.radius.clone(), scene.setup.density_kg_m3);
    Dem::new(scene.setup.clone(), p, scene.v_scale)
}

/// Runs a parsed scene to its stop criterion; `on_check` sees every check (history rows).
pub fn run(
    scene: &DemScene,
    dem: &mut Dem,
    mut on_check: impl FnMut(&Dem, f64),
) -> Result<(String, f64)> {
    let start = Instant::now();
    let steps_per_check = ((scene.check_every_s / dem.dt_s).round() as u64).max(1);
    let d_mean = 2.0 * scene.radius.iter().sum::<f64>() / scene.radius.len() as f64;
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let mut top_prev = observe::bed_top(&z, &dem.p.radius);
    let mut ke_peak: f64 = 0.0;
    let stop = loop {
        dem.run(steps_per_check)?;
        let ke = dem.kinetic_energy();
        ke_peak = ke_peak.max(ke);
        let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
        let top = observe::bed_top(&z, &dem.p.radius);
        on_check(dem, ke);
        let ratio = dem.max_overlap_ratio();
        if ratio > 0.1 {
            return invalid(format!(
                "overlap {ratio:.3} of a diameter at t = {:e} s: the contacts are too soft for the load \
                 (raise contact.young_pa or lower the driving force)",
                dem.time_s
            ));
        }
        if ke_peak > 0.0
            && ke < scene.ke_fraction * ke_peak
            && (top - top_prev).abs() < scene.height_tol_over_d * d_mean
        {
            break format!(
                "settled: KE < {} of its peak and bed top steady",
                scene.ke_fraction
            );
        }
        top_prev = top;
        if dem.time_s >= scene.max_time_s {
            break format!("time limit {} s reached before settling", scene.max_time_s);
        }
    };
    Ok((stop, start.elapsed().as_secs_f64()))
}

/// The summary of a finished run.
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
        max_overlap_over_diameter: dem.max_overlap_ratio(),
        floor_force_over_weight: (w > 0.0).then(|| dem.floor_force_n / w),
        top_wall_z_m: dem.top_z_m,
        top_pressure_pa: dem.top_force_n / area,
        kinetic_energy_j: dem.kinetic_energy(),
    }
}

/// `porelab run` on a DEM scene.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let scene = parse_scene(text, origin)?;
    let mut dem = build(&scene)?;
    eprintln!(
        "dem: {} spheres, dt = {:e} s, skin = {:e} m, active terms: {}",
        dem.p.len(),
        dem.dt_s,
        dem.nl.skin,
        dem.active.names().join(", ")
    );
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
    let mut hist = String::from(
        "time_s,kinetic_energy_J,bed_top_m,top_wall_z_m,top_pressure_Pa,floor_force_N,max_overlap_over_diameter\n",
    );
    let area = scene.setup.lx_m * scene.setup.ly_m;
    let mut run_it = || -> Result<(String, f64)> {
        run(&scene, &mut dem, |d, ke| {
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
            bar.set_position(((d.time_s / scene.max_time_s) * 1000.0) as u64);
            bar.set_message(format!(
                "step {} t = {:.4} s KE = {ke:.2e} J overlap/d = {ov:.2e}",
                d.steps, d.time_s
            ));
        })
    };
    let (stop, seconds) = match opts.threads {
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| Error::InvalidInput(format!("--threads {t}: {e}")))?
            .install(run_it)?,
        None => run_it()?,
    };
    bar.finish_and_clear();
    let summary = summarize(&scene, &dem, stop, seconds);
    std::fs::create_dir_all(out)?;
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
    let parts: Vec<xyz::XyzParticle> = (0..dem.p.len())
        .map(|i| xyz::XyzParticle::sphere(dem.p.pos[i], dem.p.radius[i]))
        .collect();
    let cell = xyz::Cell {
        lengths: [scene.setup.lx_m, scene.setup.ly_m, dem.top_z_m],
        origin: [0.0; 3],
        pbc: [true, true, false],
    };
    xyz::write(
        &out.join("final.xyz"),
        &cell,
        &parts,
        &[("Time", format!("{}", dem.time_s))],
    )?;
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    println!(
        "{}: {} steps, dt = {:e} s, {:.1} s ({}); porosity below top {:.4}, bulk {}; coordination {:.2}; max overlap/d {:.2e}",
        origin,
        summary.steps,
        summary.dt_s,
        summary.seconds,
        summary.stop,
        summary.porosity_below_top,
        summary.porosity_bulk.map_or("-".into(), |e| format!("{e:.4}")),
        summary.mean_coordination,
        summary.max_overlap_over_diameter
    );
    println!("outputs in {}", out.display());
    Ok(())
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
