//! The DEM scene file: its schema (serde, unknown keys refused by name; particle sizes and the
//! contact's normal, damping and tangential sub-models as tagged enums, the contact presets
//! of earlier files as a named enum) and its reading into the engine's [`Setup`], the stop rule
//! and the output settings of a [`DemScene`]. Every error names the file, the key, the value
//! and the rule.

use super::super::keys::parse_renamed;
use crate::dem::{
    Balance, ContactModel, CoulombLimit, DampingModel, Dem, Drag, Material, NormalModel, Rest,
    Setup, Start, StopRule, TangentialModel, TimeStep, TopWall,
};
use crate::error::{invalid, Error};
use crate::Result;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Deserializer};
use std::f64::consts::PI;

/// A DEM scene file; the coupled scene's `[dem]` table is one without its `kind`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemFile {
    kind: Option<String>,
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

/// `[particles]`: the number, the density and the sizes, chosen by `size` (absent: "mono").
#[derive(Debug, Clone)]
struct ParticlesSpec(Sizes);

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "size", rename_all = "kebab-case", deny_unknown_fields)]
enum Sizes {
    /// One diameter.
    Mono {
        n: usize,
        density_kg_m3: Option<f64>,
        diameter_m: f64,
    },
    /// Log-normal diameters (median, sigma of ln d), clipped to [min, max].
    Lognormal {
        n: usize,
        density_kg_m3: Option<f64>,
        median_diameter_m: f64,
        sigma_ln: f64,
        min_diameter_m: Option<f64>,
        max_diameter_m: Option<f64>,
    },
    /// Diameters with their number fractions.
    Table {
        n: usize,
        density_kg_m3: Option<f64>,
        diameters_m: Vec<f64>,
        number_fractions: Vec<f64>,
    },
}

impl<'de> Deserialize<'de> for ParticlesSpec {
    /// The table with `size = "mono"` where it names no size.
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let mut t = toml::Table::deserialize(d)?;
        t.entry("size")
            .or_insert_with(|| toml::Value::String("mono".into()));
        toml::Value::Table(t)
            .try_into()
            .map(ParticlesSpec)
            .map_err(serde::de::Error::custom)
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct BoxSpec {
    lx_m: f64,
    ly_m: f64,
    height_m: Option<f64>,
    porosity: Option<f64>,
}

/// `[contact]`: the elastic constants, and the contact law either as one of the presets of
/// earlier scene files (`model` with the preset's coefficients beside it) or as three
/// separately chosen sub-models (`[contact.normal]`, `[contact.damping]`,
/// `[contact.tangential]`, each with its own `model` and coefficients).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactSpec {
    model: Option<Preset>,
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
    normal: Option<NormalSpec>,
    damping: Option<DampingSpec>,
    tangential: Option<TangentialSpec>,
    coulomb_limit: Option<CoulombLimitSpec>,
}

/// `[contact] coulomb_limit`: see [`CoulombLimit`].
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum CoulombLimitSpec {
    NoTension,
    DashpotInLimit,
}

/// The contact presets: each names a normal, a damping and a tangential sub-model
/// ([`Preset::sub_models`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum Preset {
    HertzMindlin,
    Hertz,
    Linear,
    Zhou2002,
}

/// `[contact.normal]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case", deny_unknown_fields)]
enum NormalSpec {
    Hertz,
    Linear { k_n_n_per_m: f64 },
}

/// `[contact.damping]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case", deny_unknown_fields)]
enum DampingSpec {
    None,
    Restitution { restitution: f64 },
    Zhou2002 { c_n: f64 },
}

/// `[contact.tangential]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case", deny_unknown_fields)]
enum TangentialSpec {
    None,
    Mindlin {
        friction: f64,
        #[serde(default = "default_damping_ratio")]
        damping_ratio: f64,
    },
    Linear {
        friction: f64,
        #[serde(default = "default_kt_over_kn")]
        kt_over_kn: f64,
        #[serde(default = "default_damping_ratio")]
        damping_ratio: f64,
    },
    Zhou2002 {
        friction: f64,
        c_t: f64,
    },
}

/// Defaults of the contact coefficients (README, `[contact]`).
const DEFAULT_RESTITUTION: f64 = 0.5;
const DEFAULT_FRICTION: f64 = 0.5;
const DEFAULT_DAMPING_RATIO: f64 = 1.0;
const DEFAULT_KT_OVER_KN: f64 = 2.0 / 7.0;
const DEFAULT_POISSON: f64 = 0.3;

/// Default normal damping coefficient of `model = "zhou2002"` (a choice of this code, not a
/// value of the source: a head-on impact then rebounds at e = 0.25, case 713; above
/// c_n ~ 0.7 the law captures, e = 0).
pub const ZHOU_C_N_DEFAULT: f64 = 0.3;

fn default_damping_ratio() -> f64 {
    DEFAULT_DAMPING_RATIO
}

fn default_kt_over_kn() -> f64 {
    DEFAULT_KT_OVER_KN
}

/// Elastic constants handed to the engine when the contact laws read none (linear springs
/// carry their own stiffness): no force depends on them.
const UNREAD_MATERIAL: (f64, f64) = (1e7, 0.3);

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
    balance_tol: Option<f64>,
    balance_window_s: Option<f64>,
    max_particle_steps: Option<f64>,
    profile_bins: Option<usize>,
    trajectory_every_s: Option<f64>,
    rdf_max_over_d: Option<f64>,
    rdf_bins: Option<usize>,
    pore_voxels_per_d: Option<f64>,
}

/// What a run writes besides the history (README, "Output formats").
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSettings {
    /// Slabs of the porosity profile.
    pub profile_bins: usize,
    /// A trajectory frame every this many checks (`None`: no trajectory).
    pub frame_every_checks: Option<u64>,
    /// g(r) out to this many mean diameters (`None`: 3, or half the narrower lateral side).
    pub rdf_max_over_d: Option<f64>,
    pub rdf_bins: usize,
    /// Voxels per mean diameter of the pore-size grid (0: no pore sizes).
    pub pore_voxels_per_d: f64,
}

/// A parsed DEM scene: the engine's setup, the stop rule and the outputs.
#[derive(Debug, Clone)]
pub struct DemScene {
    pub title: String,
    pub seed: u64,
    /// The engine's setup; its start disperses the scene's spheres (radii in draw order).
    pub setup: Setup,
    /// The top wall's start height (m).
    pub height_m: f64,
    pub rule: StopRule,
    pub outputs: OutputSettings,
    /// FNV-1a hash of the scene text: a checkpoint resumes only the scene that wrote it.
    pub fingerprint: String,
}

impl DemScene {
    /// Mean diameter of the scene's spheres (m), in draw order.
    pub fn mean_diameter_m(&self) -> f64 {
        self.setup.start.mean_diameter_m()
    }
}

/// The work a DEM scene may ask for unless `run.max_particle_steps` says otherwise: spheres
/// times steps up to the time limit (the built-in dem-seed-gravity asks for 4.7e9).
pub const DEFAULT_MAX_PARTICLE_STEPS: f64 = 1e11;

/// The stream of the random dispersion: the scene's seed xor this (the sizes draw from the
/// seed itself).
const DISPERSION_STREAM: u64 = 0x5eed_d15c;

fn positive(origin: &str, key: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        invalid(format!(
            "{origin}: {key} = {v}: must be positive and finite"
        ))
    }
}

/// `Err` of `r` with its message after `{origin}: {key}: `.
fn keyed<T>(r: Result<T>, origin: &str, key: &str) -> Result<T> {
    r.map_err(|e| Error::InvalidInput(format!("{origin}: {key}: {e}")))
}

/// Parses a DEM scene; every error names the key, the value and the rule.
pub fn parse_scene(text: &str, origin: &str) -> Result<DemScene> {
    let f: DemFile = parse_renamed(text, origin).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("dem scene: {e}"),
    })?;
    if f.kind.as_deref() != Some("dem") {
        return invalid(format!(
            "{origin}: kind = \"{}\": a DEM scene needs kind = \"dem\"",
            f.kind.as_deref().unwrap_or("")
        ));
    }
    let fingerprint = format!("{:016x}", crate::io::fnv1a64(text.as_bytes()));
    f.into_scene(origin, fingerprint)
}

impl DemFile {
    /// The table's `kind`, if it names one.
    pub fn kind(&self) -> Option<&str> {
        self.kind.as_deref()
    }

    /// The keys of `[drivers]` that put the particles in a fluid of their own (drag and
    /// buoyancy), present in this file.
    pub fn fluid_keys(&self) -> Vec<&'static str> {
        let d = &self.drivers;
        [
            ("drivers.viscosity_pa_s", d.viscosity_pa_s.is_some()),
            ("drivers.fluid_velocity_m_s", d.fluid_velocity_m_s.is_some()),
            (
                "drivers.fluid_density_kg_m3",
                d.fluid_density_kg_m3.is_some(),
            ),
        ]
        .into_iter()
        .filter_map(|(k, given)| given.then_some(k))
        .collect()
    }

    /// The same file with the buoyancy fluid's density set (kg/m^3).
    pub fn with_fluid_density(mut self, density_kg_m3: f64) -> DemFile {
        self.drivers.fluid_density_kg_m3 = Some(density_kg_m3);
        self
    }

    /// Reads the file into the engine's setup, the stop rule and the outputs; `fingerprint`
    /// identifies the scene's text for its checkpoints.
    pub fn into_scene(self, origin: &str, fingerprint: String) -> Result<DemScene> {
        let f = self;
        let (diameters, rho) = f.particles.0.diameters(origin, f.seed)?;
        let radius: Vec<f64> = diameters.iter().map(|d| 0.5 * d).collect();
        let [lx, ly, height] = f.box_.sides(origin, &radius)?;
        let (contact, particle_material, wall_material) = f.contact.read(origin)?;
        let start = Start::Dispersed {
            radius,
            seed: f.seed ^ DISPERSION_STREAM,
        };
        let mut setup = Setup::in_box([lx, ly, height], contact, particle_material, rho, start);
        setup.wall_material = wall_material;
        f.drivers.apply(origin, &mut setup)?;
        f.run.apply(origin, &mut setup)?;
        setup
            .check()
            .map_err(|e| Error::InvalidInput(format!("{origin}: {e}")))?;
        let rule = f.run.stop_rule(origin)?;
        let outputs = f.run.outputs(origin, rule.check_every_s())?;
        f.run.check_work(origin, &setup, &rule)?;
        Ok(DemScene {
            title: f.title,
            seed: f.seed,
            setup,
            height_m: height,
            rule,
            outputs,
            fingerprint,
        })
    }
}

impl BoxSpec {
    /// [lx, ly, h] (m): the top wall's height given, or that of the dispersion of spheres of
    /// radii `radius` at the given porosity.
    fn sides(&self, origin: &str, radius: &[f64]) -> Result<[f64; 3]> {
        let lx = positive(origin, "box.lx_m", self.lx_m)?;
        let ly = positive(origin, "box.ly_m", self.ly_m)?;
        let height = match (self.height_m, self.porosity) {
            (Some(h), None) => positive(origin, "box.height_m", h)?,
            (None, Some(e)) => {
                if !(e > 0.0 && e < 1.0) {
                    return invalid(format!("{origin}: box.porosity = {e}: must lie in (0, 1)"));
                }
                let solid: f64 = radius.iter().map(|r| 4.0 / 3.0 * PI * r.powi(3)).sum();
                solid / ((1.0 - e) * lx * ly)
            }
            (Some(_), Some(_)) => {
                return invalid(format!(
                    "{origin}: box: give height_m or porosity, not both"
                ))
            }
            (None, None) => {
                return invalid(format!("{origin}: box: height_m or porosity is required"))
            }
        };
        Ok([lx, ly, height])
    }
}

impl DriversSpec {
    /// Sets the setup's gravity, buoyancy, drag and top wall (at the setup's box height).
    fn apply(&self, origin: &str, setup: &mut Setup) -> Result<()> {
        let g = self.gravity_m_s2.unwrap_or(0.0);
        if !(g.is_finite() && g >= 0.0) {
            return invalid(format!(
                "{origin}: drivers.gravity_m_s2 = {g}: must be >= 0 (it points along -z)"
            ));
        }
        setup.gravity_m_s2 = Vector3::new(0.0, 0.0, -g);
        setup.fluid_density_kg_m3 = self.fluid_density_kg_m3.unwrap_or(0.0);
        setup.drag = match self.viscosity_pa_s {
            Some(mu_f) => Some(keyed(
                Drag::new(
                    mu_f,
                    Vector3::from(self.fluid_velocity_m_s.unwrap_or([0.0; 3])),
                ),
                origin,
                "drivers.viscosity_pa_s/fluid_velocity_m_s",
            )?),
            None => {
                refuse(
                    origin,
                    "drivers.fluid_velocity_m_s",
                    self.fluid_velocity_m_s.is_some(),
                    "needs drivers.viscosity_pa_s",
                )?;
                None
            }
        };
        let height = setup.top.z0_m();
        setup.top = match self.top_pressure_pa {
            Some(target_pa) => TopWall::Pressure {
                z0_m: height,
                target_pa,
                speed_max_m_s: self.top_speed_max_m_s.unwrap_or(0.05),
            },
            None => {
                refuse(
                    origin,
                    "drivers.top_speed_max_m_s",
                    self.top_speed_max_m_s.is_some(),
                    "needs drivers.top_pressure_pa",
                )?;
                TopWall::Fixed { z_m: height }
            }
        };
        keyed(
            setup.top.check(),
            origin,
            "drivers.top_pressure_pa/top_speed_max_m_s",
        )
    }
}

fn refuse(origin: &str, key: &str, present: bool, why: &str) -> Result<()> {
    if present {
        invalid(format!("{origin}: {key}: {why}"))
    } else {
        Ok(())
    }
}

impl Sizes {
    /// The diameters (m) drawn from the ChaCha8 stream of `seed`, and the density.
    fn diameters(&self, origin: &str, seed: u64) -> Result<(Vec<f64>, f64)> {
        let (n, density) = match *self {
            Sizes::Mono {
                n, density_kg_m3, ..
            }
            | Sizes::Lognormal {
                n, density_kg_m3, ..
            }
            | Sizes::Table {
                n, density_kg_m3, ..
            } => (n, density_kg_m3),
        };
        if n == 0 {
            return invalid(format!("{origin}: particles.n = 0: must be at least 1"));
        }
        // refused before the diameters are drawn, which would allocate for every sphere
        crate::scene::check_memory(
            origin,
            &format!("particles.n = {n} (a DEM bed)"),
            Dem::estimated_bytes(n),
        )?;
        let rho = positive(origin, "particles.density_kg_m3", density.unwrap_or(2500.0))?;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let diameters = match self {
            Sizes::Mono { diameter_m, .. } => {
                vec![positive(origin, "particles.diameter_m", *diameter_m)?; n]
            }
            Sizes::Lognormal {
                median_diameter_m,
                sigma_ln,
                min_diameter_m,
                max_diameter_m,
                ..
            } => {
                let med = positive(origin, "particles.median_diameter_m", *median_diameter_m)?;
                let s = positive(origin, "particles.sigma_ln", *sigma_ln)?;
                let lo = positive(
                    origin,
                    "particles.min_diameter_m",
                    min_diameter_m.unwrap_or(med * (-3.0 * s).exp()),
                )?;
                let hi = positive(
                    origin,
                    "particles.max_diameter_m",
                    max_diameter_m.unwrap_or(med * (3.0 * s).exp()),
                )?;
                if lo >= hi {
                    return invalid(format!(
                        "{origin}: particles.min_diameter_m = {lo} must be below max_diameter_m = {hi}"
                    ));
                }
                (0..n)
                    .map(|_| {
                        // Box-Muller normal, then clipped
                        let (u1, u2): (f64, f64) = (1.0 - rng.gen::<f64>(), rng.gen::<f64>());
                        let z = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                        (med * (s * z).exp()).clamp(lo, hi)
                    })
                    .collect()
            }
            Sizes::Table {
                diameters_m: ds,
                number_fractions: fr,
                ..
            } => table_diameters(origin, n, ds, fr, &mut rng)?,
        };
        Ok((diameters, rho))
    }
}

/// `n` diameters of the table: counts by largest remainder of the number fractions, then
/// shuffled by the scene's stream.
fn table_diameters(
    origin: &str,
    n: usize,
    ds: &[f64],
    fr: &[f64],
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Vec<f64>> {
    if ds.is_empty() || ds.len() != fr.len() {
        return invalid(format!("{origin}: particles.diameters_m ({} values) and number_fractions ({} values): must be non-empty and of equal length", ds.len(), fr.len()));
    }
    for (k, d) in ds.iter().enumerate() {
        positive(origin, &format!("particles.diameters_m[{k}]"), *d)?;
    }
    let total: f64 = fr.iter().sum();
    if fr.iter().any(|x| !(x.is_finite() && *x >= 0.0)) || total.is_nan() || total <= 0.0 {
        return invalid(format!(
            "{origin}: particles.number_fractions = {fr:?}: must be >= 0 with a positive sum"
        ));
    }
    let mut counts: Vec<usize> = fr
        .iter()
        .map(|x| (x / total * n as f64).floor() as usize)
        .collect();
    let mut left = n - counts.iter().sum::<usize>();
    let mut order: Vec<usize> = (0..fr.len()).collect();
    order.sort_by(|&a, &b| {
        let ra = fr[a] / total * n as f64 - counts[a] as f64;
        let rb = fr[b] / total * n as f64 - counts[b] as f64;
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
    Ok(v)
}

impl Preset {
    fn name(self) -> &'static str {
        match self {
            Preset::HertzMindlin => "hertz-mindlin",
            Preset::Hertz => "hertz",
            Preset::Linear => "linear",
            Preset::Zhou2002 => "zhou2002",
        }
    }

    /// The presets' coefficient keys of `[contact]` and the presets that read each.
    const KEYS: [(&'static str, &'static [Preset]); 7] = [
        ("k_n_n_per_m", &[Preset::Linear]),
        ("kt_over_kn", &[Preset::Linear]),
        (
            "restitution",
            &[Preset::HertzMindlin, Preset::Hertz, Preset::Linear],
        ),
        (
            "friction",
            &[Preset::HertzMindlin, Preset::Linear, Preset::Zhou2002],
        ),
        (
            "tangential_damping_ratio",
            &[Preset::HertzMindlin, Preset::Linear],
        ),
        ("c_n", &[Preset::Zhou2002]),
        ("c_t", &[Preset::Zhou2002]),
    ];

    /// The sub-models the preset names, with its coefficients from `c` (defaults where
    /// absent); a coefficient the preset does not read is refused. The presets give exactly
    /// the laws of earlier scene files: "hertz-mindlin" Hertz + restitution + Mindlin;
    /// "hertz" Hertz + restitution, frictionless; "linear" linear spring + restitution +
    /// linear tangential spring (none at friction 0); "zhou2002" Hertz + Zhou's damping and
    /// tangential law (none at c_n = 0 or friction 0).
    fn sub_models(
        self,
        c: &ContactSpec,
        origin: &str,
    ) -> Result<(NormalSpec, DampingSpec, TangentialSpec)> {
        for ((key, readers), value) in Preset::KEYS.iter().zip(c.preset_values()) {
            if value.is_some() && !readers.contains(&self) {
                let names: Vec<String> = readers
                    .iter()
                    .map(|p| format!("\"{}\"", p.name()))
                    .collect();
                return invalid(format!(
                    "{origin}: contact.{key}: not read by model = \"{}\" (read by {})",
                    self.name(),
                    names.join(", ")
                ));
            }
        }
        let unread_without_friction = |keys: &[(&str, Option<f64>)]| -> Result<()> {
            for (key, v) in keys {
                refuse(
                    origin,
                    &format!("contact.{key}"),
                    v.is_some(),
                    "not read with friction = 0 (no tangential force)",
                )?;
            }
            Ok(())
        };
        let restitution = DampingSpec::Restitution {
            restitution: c.restitution.unwrap_or(DEFAULT_RESTITUTION),
        };
        let friction = c.friction.unwrap_or(DEFAULT_FRICTION);
        let damping_ratio = c.tangential_damping_ratio.unwrap_or(DEFAULT_DAMPING_RATIO);
        Ok(match self {
            Preset::HertzMindlin => (
                NormalSpec::Hertz,
                restitution,
                TangentialSpec::Mindlin {
                    friction,
                    damping_ratio,
                },
            ),
            Preset::Hertz => (NormalSpec::Hertz, restitution, TangentialSpec::None),
            Preset::Linear => {
                let Some(k_n_n_per_m) = c.k_n_n_per_m else {
                    return invalid(format!(
                        "{origin}: contact.k_n_n_per_m is required for model = \"linear\""
                    ));
                };
                let tangential = if friction == 0.0 {
                    unread_without_friction(&[
                        ("kt_over_kn", c.kt_over_kn),
                        ("tangential_damping_ratio", c.tangential_damping_ratio),
                    ])?;
                    TangentialSpec::None
                } else {
                    TangentialSpec::Linear {
                        friction,
                        kt_over_kn: c.kt_over_kn.unwrap_or(DEFAULT_KT_OVER_KN),
                        damping_ratio,
                    }
                };
                (NormalSpec::Linear { k_n_n_per_m }, restitution, tangential)
            }
            Preset::Zhou2002 => {
                let c_n = c.c_n.unwrap_or(ZHOU_C_N_DEFAULT);
                let tangential = if friction == 0.0 {
                    unread_without_friction(&[("c_t", c.c_t)])?;
                    TangentialSpec::None
                } else {
                    TangentialSpec::Zhou2002 {
                        friction,
                        c_t: c.c_t.unwrap_or(c_n),
                    }
                };
                (NormalSpec::Hertz, DampingSpec::Zhou2002 { c_n }, tangential)
            }
        })
    }
}

impl NormalSpec {
    fn model(&self) -> Result<NormalModel> {
        match *self {
            NormalSpec::Hertz => Ok(NormalModel::Hertz),
            NormalSpec::Linear { k_n_n_per_m } => NormalModel::linear(k_n_n_per_m),
        }
    }
}

impl DampingSpec {
    fn model(&self) -> Result<DampingModel> {
        match *self {
            DampingSpec::None => Ok(DampingModel::None),
            DampingSpec::Restitution { restitution } => DampingModel::restitution(restitution),
            DampingSpec::Zhou2002 { c_n } => DampingModel::zhou(c_n),
        }
    }
}

impl TangentialSpec {
    fn model(&self) -> Result<TangentialModel> {
        match *self {
            TangentialSpec::None => Ok(TangentialModel::None),
            TangentialSpec::Mindlin {
                friction,
                damping_ratio,
            } => TangentialModel::mindlin(friction, damping_ratio),
            TangentialSpec::Linear {
                friction,
                kt_over_kn,
                damping_ratio,
            } => TangentialModel::linear(kt_over_kn, friction, damping_ratio),
            TangentialSpec::Zhou2002 { friction, c_t } => TangentialModel::zhou(friction, c_t),
        }
    }
}

impl ContactSpec {
    /// The presets' coefficients as given, in the order of [`Preset::KEYS`].
    fn preset_values(&self) -> [Option<f64>; 7] {
        [
            self.k_n_n_per_m,
            self.kt_over_kn,
            self.restitution,
            self.friction,
            self.tangential_damping_ratio,
            self.c_n,
            self.c_t,
        ]
    }

    /// The contact model and the particles' and walls' materials.
    fn read(&self, origin: &str) -> Result<(ContactModel, Material, Material)> {
        let sub = (&self.normal, &self.damping, &self.tangential);
        let given_sub = sub.0.is_some() || sub.1.is_some() || sub.2.is_some();
        let (normal, damping, tangential) = match (self.model, sub) {
            (Some(p), _) if given_sub => {
                return invalid(format!(
                    "{origin}: contact.model = \"{}\" (a preset) and contact.normal, \
                     contact.damping, contact.tangential (sub-models): give one or the other",
                    p.name()
                ))
            }
            (Some(p), _) => {
                let (n, d, t) = p.sub_models(self, origin)?;
                // errors name the preset's keys
                let damping_key = match d {
                    DampingSpec::Zhou2002 { .. } => "contact.c_n",
                    _ => "contact.restitution",
                };
                (
                    keyed(n.model(), origin, "contact.k_n_n_per_m")?,
                    keyed(d.model(), origin, damping_key)?,
                    keyed(t.model(), origin, "contact")?,
                )
            }
            (None, (Some(n), Some(d), Some(t))) => {
                for ((key, _), value) in Preset::KEYS.iter().zip(self.preset_values()) {
                    refuse(
                        origin,
                        &format!("contact.{key}"),
                        value.is_some(),
                        "a coefficient of the presets (contact.model); with the sub-models give \
                         it in contact.normal, contact.damping or contact.tangential",
                    )?;
                }
                (
                    keyed(n.model(), origin, "contact.normal")?,
                    keyed(d.model(), origin, "contact.damping")?,
                    keyed(t.model(), origin, "contact.tangential")?,
                )
            }
            (None, _) => {
                return invalid(format!(
                    "{origin}: contact: give model (a preset: \"hertz-mindlin\", \"hertz\", \
                     \"linear\" or \"zhou2002\") or all three of contact.normal, contact.damping \
                     and contact.tangential"
                ))
            }
        };
        let limit = match self.coulomb_limit {
            None => CoulombLimit::default(),
            Some(CoulombLimitSpec::NoTension) => CoulombLimit::NoTension,
            Some(CoulombLimitSpec::DashpotInLimit) => CoulombLimit::DashpotInLimit,
        };
        let model = keyed(
            ContactModel::new(normal, damping, tangential),
            origin,
            "contact",
        )?
        .with_limit(limit);
        let (particle, wall) = self.materials(origin, &model)?;
        Ok((model, particle, wall))
    }

    /// The particles' and walls' elastic constants: required (Young's modulus) where the
    /// model reads them, refused where it reads none.
    fn materials(&self, origin: &str, model: &ContactModel) -> Result<(Material, Material)> {
        let keys = [
            ("young_pa", self.young_pa),
            ("poisson", self.poisson),
            ("wall_young_pa", self.wall_young_pa),
            ("wall_poisson", self.wall_poisson),
        ];
        if !model.reads_moduli() {
            for (key, v) in keys {
                refuse(
                    origin,
                    &format!("contact.{key}"),
                    v.is_some(),
                    "not read by these contact laws (linear springs carry their own stiffness)",
                )?;
            }
            let m = keyed(
                Material::new(UNREAD_MATERIAL.0, UNREAD_MATERIAL.1),
                origin,
                "contact",
            )?;
            return Ok((m, m));
        }
        let Some(young) = self.young_pa else {
            return invalid(format!(
                "{origin}: contact.young_pa is required for Hertz, Mindlin and Zhou laws"
            ));
        };
        let poisson = self.poisson.unwrap_or(DEFAULT_POISSON);
        let particle = keyed(
            Material::new(young, poisson),
            origin,
            "contact.young_pa/poisson",
        )?;
        let wall = keyed(
            Material::new(
                self.wall_young_pa.unwrap_or(young),
                self.wall_poisson.unwrap_or(poisson),
            ),
            origin,
            "contact.wall_young_pa/wall_poisson",
        )?;
        Ok((particle, wall))
    }
}

impl RunSpec {
    /// Sets the setup's time step and skin.
    fn apply(&self, origin: &str, setup: &mut Setup) -> Result<()> {
        if let Some(dt) = self.dt_s {
            setup.time_step = TimeStep::Given {
                dt_s: positive(origin, "run.dt_s", dt)?,
            };
        }
        setup.skin_m = self
            .skin_m
            .map(|s| positive(origin, "run.skin_m", s))
            .transpose()?;
        Ok(())
    }

    /// The stop rule: settled by the peak rule and the force balance, or the time limit.
    fn stop_rule(&self, origin: &str) -> Result<StopRule> {
        StopRule::new(
            self.check_every_s.unwrap_or(0.01),
            self.max_time_s.unwrap_or(1.0),
            Rest::PeakFraction {
                ke_fraction: self.ke_fraction.unwrap_or(1e-6),
                height_tol_over_d: self.height_tol_over_d.unwrap_or(1e-3),
            },
        )
        .and_then(|rule| {
            rule.with_balance(Balance {
                tol: self.balance_tol.unwrap_or(Balance::DEFAULT.tol),
                window_s: self.balance_window_s.unwrap_or(Balance::DEFAULT.window_s),
            })
        })
        // the rule's messages start with the field, which is the key
        .map_err(|e| Error::InvalidInput(format!("{origin}: run.{e}")))
    }

    /// Refuses a run whose work, spheres times steps up to the time limit, exceeds
    /// `max_particle_steps` [`DEFAULT_MAX_PARTICLE_STEPS`], before anything is allocated.
    fn check_work(&self, origin: &str, setup: &Setup, rule: &StopRule) -> Result<()> {
        let limit = self
            .max_particle_steps
            .map(|x| positive(origin, "run.max_particle_steps", x))
            .transpose()?
            .unwrap_or(DEFAULT_MAX_PARTICLE_STEPS);
        let n = setup.start.radii().len();
        let dt = setup
            .time_step_s()
            .map_err(|e| Error::InvalidInput(format!("{origin}: run.dt_s: {e}")))?;
        let work = n as f64 * (rule.max_time_s() / dt).ceil();
        if work > limit {
            return invalid(format!(
                "{origin}: particles.n = {n} over run.max_time_s = {} s at dt = {dt:.3e} s is \
                 {work:.3e} particle-steps, more than run.max_particle_steps = {limit:e}: make \
                 the run smaller, or raise run.max_particle_steps to run it anyway",
                rule.max_time_s()
            ));
        }
        Ok(())
    }

    /// The output settings, frames at whole numbers of checks of `check_every_s`.
    fn outputs(&self, origin: &str, check_every_s: f64) -> Result<OutputSettings> {
        let profile_bins = self.profile_bins.unwrap_or(60);
        if profile_bins == 0 {
            return invalid(format!(
                "{origin}: run.profile_bins = 0: must be at least 1"
            ));
        }
        let frame_every_checks = match self.trajectory_every_s {
            None => None,
            Some(t) => {
                let t = positive(origin, "run.trajectory_every_s", t)?;
                if t < check_every_s * (1.0 - 1e-9) {
                    return invalid(format!(
                        "{origin}: run.trajectory_every_s = {t}: must be at least \
                         run.check_every_s = {check_every_s} (frames are written at checks)"
                    ));
                }
                Some((t / check_every_s).round() as u64)
            }
        };
        let rdf_max_over_d = self
            .rdf_max_over_d
            .map(|x| positive(origin, "run.rdf_max_over_d", x))
            .transpose()?;
        let rdf_bins = self.rdf_bins.unwrap_or(150);
        if rdf_bins == 0 {
            return invalid(format!("{origin}: run.rdf_bins = 0: must be at least 1"));
        }
        let pore_voxels_per_d = self.pore_voxels_per_d.unwrap_or(10.0);
        if !(pore_voxels_per_d.is_finite() && pore_voxels_per_d >= 0.0) {
            return invalid(format!(
                "{origin}: run.pore_voxels_per_d = {pore_voxels_per_d}: must be >= 0 and finite \
                 (0: no pore sizes)"
            ));
        }
        Ok(OutputSettings {
            profile_bins,
            frame_every_checks,
            rdf_max_over_d,
            rdf_bins,
            pore_voxels_per_d,
        })
    }
}
