//! Packing scenes (`kind = "packing"`): the mechanical contraction method of [`crate::packing`]
//! run from a TOML file, with outputs and checkpoints in the output folder.
//!
//! Schema (every table and key optional unless marked; defaults in brackets; reduced units:
//! particle diameter 1):
//!
//! ```toml
//! kind = "packing"                 # required
//! title = "..."                    # free text, copied to the summary
//! [particles]
//! shape = "sphere"                 # "sphere" | "spherocylinder"  [sphere]
//! n = 1000                         # number of particles (>= 2)     [1000]
//! length_over_diameter = 0.0       # L/D of the cylinder between the caps (spherocylinder, > 0)
//! [container]
//! shape = "periodic"               # "periodic" (cubic box) | "cylinder" (hard wall, periodic
//!                                  # along its axis z; sec. 2.2.4) | "wedge" (three hard
//!                                  # planes, periodic along z; eq. 2.12-2.13)  [periodic]
//! diameter = 6.0                   # cylinder diameter D_cyl in D (> 1), cylinder only
//! length = 10.0                    # wedge length l_w along x (D), wedge only
//! angle_deg = 30.0                 # wedge angle alpha (degrees), wedge only
//!                                  # (any shape, superquadrics included, packs in any container)
//! [mcm]
//! seed = 1                         # ChaCha8 seed of the random start [1]
//! scheme = "original"              # "original" (eq. 2.4-2.10) | "revised" (eq. 3.2-3.13) |
//!                                  # "relax" (collective FIRE descent, packing::relax)
//! phi0 = 0.05                      # start packing fraction, (0, 0.2]
//! delta_v_per_particle = 0.01      # Delta V / N in D^3
//! halvings = 6                     # halvings of Delta V after failed steps
//! tries_per_particle = 200.0       # particle moves allowed per compression step / N
//! stage_budget_per_particle = 2e4  # moves allowed over the whole stage / N [unbounded]
//! overlap_tol = 1e-4               # overlaps below this count as removed (sec. 2.2.6)
//! beta = 0.5                       # original scheme, eq. 2.10
//! dt = 0.1                         # revised scheme, eq. 3.9 / 3.12; relax: FIRE's initial step
//! energy = 1.0                     # revised scheme, c of eq. 3.4
//! max_steps = 1000000              # safety limit on accepted steps
//! [final_stage]                    # optional second stage from where the first stopped
//! scheme = "revised"               # [as in [mcm]]
//! delta_v_per_particle = 1e-4      # required in the table
//! halvings = 10                    # required in the table
//! tries_per_particle = 1000.0      # [as in [mcm]]
//! stage_budget_per_particle = 2.5e4 # [unbounded; not inherited from [mcm]]
//! beta = 0.5                       # [as in [mcm]]
//! dt = 0.1                         # [as in [mcm]]
//! [analysis]
//! contact_cutoffs = [1e-8, 1e-7, 1e-6, 1e-5]   # gap cut-offs for the extrapolation (sec. 2.2.5)
//! rattler_min_contacts = 4         # fewer contacts: rattler [4 spheres, 5 spherocylinders]
//! gr_r_max = 3.0                   # g(r) range (<= half the box) [min(3, L/2)]
//! gr_bins = 150                    # [150]
//! s4_trials = 2000                 # trial directions of the S4 maximisation (eq. 4.17)
//! ```
//!
//! Outputs in the output folder (README, "Output formats"): `final.xyz` (extended XYZ),
//! `summary.json`, `phi_history.csv`, `gr.csv`, and `checkpoint.json`, written atomically after
//! every compression step. When `checkpoint.json` is present, `porelab run` resumes from it
//! (after checking that it was written by the same scene) and reaches bitwise the same
//! configuration as an uninterrupted run: the MCM draws no random numbers after the start.

use super::{Builtin, RunOptions};
use crate::analysis;
use crate::contact::ContactShape;
use crate::error::{invalid, Error};
use crate::io::plot::CsvPlot;
use crate::io::{write_atomic, xyz};
use crate::packing::{
    self, Container, McmParams, McmState, Packing, Particles, Scheme, Stage, StepOutcome,
    StepRecord,
};
use crate::Result;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// The built-in packing scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "packing-spheres",
            about: "MCM: 1000 spheres in a periodic box (compacting + settling stage; ~1 min)",
            toml: include_str!("builtin/packing-spheres.toml"),
        },
        Builtin {
            name: "packing-cylinder",
            about: "MCM: 500 spheres in a hard cylinder D_cyl = 6 (virtual-particle wall)",
            toml: include_str!("builtin/packing-cylinder.toml"),
        },
        Builtin {
            name: "packing-wedge",
            about: "MCM: 300 spherocylinders L/D = 1 in a hard 30-degree wedge (virtual-particle walls)",
            toml: include_str!("builtin/packing-wedge.toml"),
        },
        Builtin {
            name: "packing-superballs",
            about: "MCM: 50 superballs gamma = 3 in a periodic box (revised scheme, contact solver)",
            toml: include_str!("builtin/packing-superballs.toml"),
        },
        Builtin {
            name: "packing-superballs-cylinder",
            about: "MCM: 50 superballs gamma = 3 in a hard cylinder D_cyl = 4 (support-function wall)",
            toml: include_str!("builtin/packing-superballs-cylinder.toml"),
        },
        Builtin {
            name: "packing-spherocylinders",
            about: "MCM: 500 spherocylinders L/D = 0.4 in a periodic box (original scheme)",
            toml: include_str!("builtin/packing-spherocylinders.toml"),
        },
    ]
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    kind: String,
    #[serde(default)]
    title: String,
    #[serde(default)]
    particles: ParticlesSpec,
    #[serde(default)]
    container: ContainerSpec,
    #[serde(default)]
    mcm: McmSpec,
    #[serde(default)]
    final_stage: Option<FinalStageSpec>,
    #[serde(default)]
    analysis: AnalysisSpec,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct ParticlesSpec {
    #[serde(default)]
    shape: Option<String>,
    #[serde(default)]
    n: Option<usize>,
    #[serde(default)]
    length_over_diameter: Option<f64>,
    /// Mixture / polydisperse / superquadric species (instead of the three keys above).
    #[serde(default)]
    species: Vec<SpeciesSpec>,
}

/// One `[[particles.species]]` entry.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct SpeciesSpec {
    shape: String,
    n: usize,
    #[serde(default)]
    diameter: Option<f64>,
    #[serde(default)]
    length: Option<f64>,
    #[serde(default)]
    semi_axes: Option<[f64; 3]>,
    #[serde(default)]
    exponents: Option<[f64; 3]>,
    #[serde(default)]
    half_width: Option<f64>,
    #[serde(default)]
    exponent: Option<f64>,
    #[serde(default)]
    polydisperse: Option<PolySpec>,
}

/// `[particles.species.polydisperse]`: per-particle diameters of a sphere or spherocylinder
/// species.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct PolySpec {
    distribution: String,
    #[serde(default)]
    min: Option<f64>,
    #[serde(default)]
    max: Option<f64>,
    #[serde(default)]
    sigma: Option<f64>,
    seed: u64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct ContainerSpec {
    #[serde(default = "default_container")]
    shape: String,
    #[serde(default)]
    diameter: Option<f64>,
    /// Wedge: length l_w along x (particle diameters).
    #[serde(default)]
    length: Option<f64>,
    /// Wedge: angle alpha in degrees (h_w = l_w tan(alpha)).
    #[serde(default)]
    angle_deg: Option<f64>,
}
fn default_container() -> String {
    "periodic".into()
}
impl Default for ContainerSpec {
    fn default() -> Self {
        ContainerSpec {
            shape: default_container(),
            diameter: None,
            length: None,
            angle_deg: None,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
struct McmSpec {
    seed: u64,
    scheme: String,
    phi0: f64,
    delta_v_per_particle: f64,
    halvings: u32,
    tries_per_particle: f64,
    /// Moves over the whole stage, per particle (absent: unbounded).
    #[serde(skip_serializing_if = "Option::is_none")]
    stage_budget_per_particle: Option<f64>,
    overlap_tol: f64,
    beta: f64,
    dt: f64,
    energy: f64,
    max_steps: usize,
}
impl Default for McmSpec {
    fn default() -> Self {
        let p = McmParams::new(2, 0.0, 1);
        McmSpec {
            seed: 1,
            scheme: "original".into(),
            phi0: p.phi0,
            delta_v_per_particle: p.delta_v_per_particle,
            halvings: p.halvings,
            tries_per_particle: p.tries_per_particle,
            stage_budget_per_particle: None,
            overlap_tol: p.overlap_tol,
            beta: p.beta,
            dt: p.dt,
            energy: p.energy,
            max_steps: p.max_steps,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct FinalStageSpec {
    scheme: Option<String>,
    delta_v_per_particle: f64,
    halvings: u32,
    tries_per_particle: Option<f64>,
    /// Moves over the whole stage, per particle (absent: unbounded; not inherited).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    stage_budget_per_particle: Option<f64>,
    beta: Option<f64>,
    dt: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
struct AnalysisSpec {
    contact_cutoffs: Vec<f64>,
    rattler_min_contacts: Option<usize>,
    gr_r_max: Option<f64>,
    gr_bins: usize,
    s4_trials: usize,
}
impl Default for AnalysisSpec {
    fn default() -> Self {
        AnalysisSpec {
            contact_cutoffs: vec![1e-8, 1e-7, 1e-6, 1e-5],
            rattler_min_contacts: None,
            gr_r_max: None,
            gr_bins: 150,
            s4_trials: 2000,
        }
    }
}

/// A parsed and checked packing scene.
#[derive(Debug, Clone)]
pub struct PackingScene {
    pub title: String,
    pub params: McmParams,
    pub cutoffs: Vec<f64>,
    pub rattler_min_contacts: usize,
    pub gr_r_max: Option<f64>,
    pub gr_bins: usize,
    pub s4_trials: usize,
    /// Canonical JSON of the parsed file: a checkpoint must carry the same text to be resumed.
    fingerprint: String,
}

/// Parses a packing scene; `origin` names the source in errors.
pub fn parse_scene(text: &str, origin: &str) -> Result<PackingScene> {
    let f: SceneFile = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("packing scene: {e}"),
    })?;
    let bad = |msg: String| invalid::<PackingScene>(format!("{origin}: {msg}"));
    if f.kind != "packing" {
        return bad(format!(
            "kind = \"{}\": a packing scene needs kind = \"packing\"",
            f.kind
        ));
    }
    let (n, length, particles) = parse_particles(&f.particles).or_else(bad_particles(origin))?;
    let cs = &f.container;
    let only = |key: &str, value: Option<f64>, shapes: &str| -> Result<()> {
        match value {
            Some(v) => crate::error::invalid(format!(
                "{origin}: container.{key} = {v}: only a {shapes} has it"
            )),
            None => Ok(()),
        }
    };
    let container = match cs.shape.as_str() {
        "periodic" => {
            only("diameter", cs.diameter, "cylinder")?;
            only("length", cs.length, "wedge")?;
            only("angle_deg", cs.angle_deg, "wedge")?;
            Container::Periodic
        }
        "cylinder" => {
            only("length", cs.length, "wedge")?;
            only("angle_deg", cs.angle_deg, "wedge")?;
            let Some(diameter) = cs.diameter else {
                return bad("container.diameter: required for shape = \"cylinder\"".into());
            };
            Container::Cylinder { diameter }
        }
        "wedge" => {
            only("diameter", cs.diameter, "cylinder")?;
            let (Some(length), Some(angle)) = (cs.length, cs.angle_deg) else {
                return bad(
                    "container.length and container.angle_deg: both required for shape = \"wedge\""
                        .into(),
                );
            };
            // Thesis Fig. 2.3: the right triangular prism 0 <= y <= x tan(alpha), x <= l_w.
            if !(angle.is_finite() && angle > 0.0 && angle < 90.0) {
                return bad(format!(
                    "container.angle_deg = {angle}: must be in (0, 90) degrees (the wedge is the \
                     right triangular prism 0 <= y <= x tan(alpha), thesis Fig. 2.3)"
                ));
            }
            if !(length.is_finite() && length > 0.0) {
                return bad(format!(
                    "container.length = {length}: must be positive and finite (D)"
                ));
            }
            Container::Wedge {
                length,
                angle_rad: angle.to_radians(),
            }
        }
        other => {
            return bad(format!(
                "container.shape = \"{other}\": must be \"periodic\", \"cylinder\" or \"wedge\""
            ))
        }
    };
    let m = &f.mcm;
    let scheme_of = |name: &str, key: &str| match name {
        "original" => Ok(Scheme::Original),
        "revised" => Ok(Scheme::Revised),
        "relax" => Ok(Scheme::Relax),
        other => invalid(format!(
            "{origin}: {key} = \"{other}\": must be \"original\", \"revised\" or \"relax\""
        )),
    };
    let scheme = scheme_of(&m.scheme, "mcm.scheme")?;
    let final_scheme = match f.final_stage.as_ref().and_then(|s| s.scheme.as_deref()) {
        Some(name) => scheme_of(name, "final_stage.scheme")?,
        None => scheme,
    };
    let mut p = McmParams::new(n, length, m.seed);
    p.particles = particles;
    p.container = container;
    p.scheme = scheme;
    p.phi0 = m.phi0;
    p.delta_v_per_particle = m.delta_v_per_particle;
    p.halvings = m.halvings;
    p.tries_per_particle = m.tries_per_particle;
    p.stage_budget_per_particle = m.stage_budget_per_particle;
    p.overlap_tol = m.overlap_tol;
    p.beta = m.beta;
    p.dt = m.dt;
    p.energy = m.energy;
    p.max_steps = m.max_steps;
    p.final_stage = f.final_stage.as_ref().map(|s| Stage {
        scheme: final_scheme,
        delta_v_per_particle: s.delta_v_per_particle,
        halvings: s.halvings,
        tries_per_particle: s.tries_per_particle.unwrap_or(m.tries_per_particle),
        stage_budget_per_particle: s.stage_budget_per_particle,
        beta: s.beta.unwrap_or(m.beta),
        dt: s.dt.unwrap_or(m.dt),
    });
    p.validate()
        .map_err(|e| Error::InvalidInput(format!("{origin}: {e}")))?;
    let a = &f.analysis;
    if a.contact_cutoffs.len() < 2 {
        return bad(format!(
            "analysis.contact_cutoffs has {} values: need at least 2 for the extrapolation",
            a.contact_cutoffs.len()
        ));
    }
    if let Some(d) = a
        .contact_cutoffs
        .iter()
        .find(|d| !(d.is_finite() && **d > 0.0))
    {
        return bad(format!(
            "analysis.contact_cutoffs: {d} must be positive and finite"
        ));
    }
    if a.gr_bins == 0 {
        return bad("analysis.gr_bins = 0: need at least one bin".into());
    }
    if let Some(r) = a.gr_r_max {
        if !(r.is_finite() && r > 0.0) {
            return bad(format!(
                "analysis.gr_r_max = {r}: must be positive and finite"
            ));
        }
    }
    if a.s4_trials < 10 {
        return bad(format!(
            "analysis.s4_trials = {}: need at least 10",
            a.s4_trials
        ));
    }
    let rattlers = a
        .rattler_min_contacts
        .unwrap_or(if all_spheres(&p) { 4 } else { 5 });
    let fingerprint = serde_json::to_string(&f).map_err(|e| Error::InvalidInput(e.to_string()))?;
    Ok(PackingScene {
        title: f.title.clone(),
        params: p,
        cutoffs: a.contact_cutoffs.clone(),
        rattler_min_contacts: rattlers,
        gr_r_max: a.gr_r_max,
        gr_bins: a.gr_bins,
        s4_trials: a.s4_trials,
        fingerprint,
    })
}

fn bad_particles(origin: &str) -> impl Fn(String) -> Result<(usize, f64, Option<Particles>)> + '_ {
    move |msg| invalid(format!("{origin}: {msg}"))
}

/// True when every particle is a sphere (rattlers have fewer than 4 contacts, else 5).
fn all_spheres(p: &McmParams) -> bool {
    match &p.particles {
        // Equal particles: no table of n entries is built before the memory check.
        None => p.length == 0.0,
        Some(t) => t
            .shapes
            .iter()
            .all(|s| matches!(s, ContactShape::Sphere { .. })),
    }
}

/// The particles of a scene: (n, cylinder length, None) for the single-shape keys
/// `shape`/`n`/`length_over_diameter`, (n, 0, Some(table)) for `[[particles.species]]`.
fn parse_particles(
    s: &ParticlesSpec,
) -> std::result::Result<(usize, f64, Option<Particles>), String> {
    if s.species.is_empty() {
        let shape = s.shape.as_deref().unwrap_or("sphere");
        let length = match (shape, s.length_over_diameter) {
            ("sphere", l) if l.unwrap_or(0.0) == 0.0 => 0.0,
            ("sphere", Some(l)) => {
                return Err(format!(
                    "particles.length_over_diameter = {l}: a sphere has none (use shape = \"spherocylinder\")"
                ))
            }
            ("spherocylinder", Some(l)) if l.is_finite() && l > 0.0 => l,
            ("spherocylinder", Some(l)) => {
                return Err(format!(
                    "particles.length_over_diameter = {l}: must be positive and finite for a spherocylinder"
                ))
            }
            ("spherocylinder", None) => {
                return Err(
                    "particles.length_over_diameter: required for shape = \"spherocylinder\"".into(),
                )
            }
            (other, _) => {
                return Err(format!(
                    "particles.shape = \"{other}\": must be \"sphere\" or \"spherocylinder\" (other \
                     shapes and mixtures: [[particles.species]])"
                ))
            }
        };
        return Ok((s.n.unwrap_or(1000), length, None));
    }
    for (key, set) in [
        ("shape", s.shape.is_some()),
        ("n", s.n.is_some()),
        ("length_over_diameter", s.length_over_diameter.is_some()),
    ] {
        if set {
            return Err(format!(
                "particles.{key}: not allowed together with [[particles.species]] (give it per \
                 species)"
            ));
        }
    }
    let mut shapes = Vec::new();
    let mut species = Vec::new();
    for (k, sp) in s.species.iter().enumerate() {
        let at = |msg: String| format!("particles.species[{k}] ({}): {msg}", sp.shape);
        if sp.n == 0 {
            return Err(at("n = 0: need at least one particle".into()));
        }
        let allowed: &[&str] = match sp.shape.as_str() {
            "sphere" => &["diameter", "polydisperse"],
            "spherocylinder" => &["diameter", "length", "polydisperse"],
            "ellipsoid" => &["semi_axes"],
            "superball" => &["half_width", "exponent"],
            "superquadric" => &["semi_axes", "exponents"],
            other => {
                return Err(at(format!(
                    "shape = \"{other}\": must be \"sphere\", \"spherocylinder\", \"ellipsoid\", \
                     \"superball\" or \"superquadric\""
                )))
            }
        };
        for (key, set) in [
            ("diameter", sp.diameter.is_some()),
            ("length", sp.length.is_some()),
            ("semi_axes", sp.semi_axes.is_some()),
            ("exponents", sp.exponents.is_some()),
            ("half_width", sp.half_width.is_some()),
            ("exponent", sp.exponent.is_some()),
            ("polydisperse", sp.polydisperse.is_some()),
        ] {
            if set && !allowed.contains(&key) {
                return Err(at(format!(
                    "key `{key}` does not apply to this shape (allowed: {})",
                    allowed.join(", ")
                )));
            }
        }
        let need = |v: Option<f64>, key: &str| v.ok_or_else(|| at(format!("`{key}` is required")));
        let d = sp.diameter.unwrap_or(1.0);
        let make = |d: f64| -> std::result::Result<ContactShape, String> {
            Ok(match sp.shape.as_str() {
                "sphere" => ContactShape::Sphere { radius: 0.5 * d },
                "spherocylinder" => ContactShape::Spherocylinder {
                    radius: 0.5 * d,
                    length: need(sp.length, "length")?,
                },
                "ellipsoid" => ContactShape::Ellipsoid {
                    semi_axes: sp
                        .semi_axes
                        .ok_or_else(|| at("`semi_axes` is required".into()))?,
                },
                "superball" => {
                    let a = sp.half_width.unwrap_or(0.5);
                    let g = need(sp.exponent, "exponent")?;
                    ContactShape::Superquadric {
                        semi_axes: [a; 3],
                        exponents: [g; 3],
                    }
                }
                _ => ContactShape::Superquadric {
                    semi_axes: sp
                        .semi_axes
                        .ok_or_else(|| at("`semi_axes` is required".into()))?,
                    exponents: sp
                        .exponents
                        .ok_or_else(|| at("`exponents` is required".into()))?,
                },
            })
        };
        match &sp.polydisperse {
            None => {
                let shape = make(d)?;
                shape.validate().map_err(|e| at(e.to_string()))?;
                species.extend(std::iter::repeat_n(shapes.len(), sp.n));
                shapes.push(shape);
            }
            Some(pd) => {
                for dk in polydisperse_diameters(pd, d, sp.n).map_err(&at)? {
                    let shape = make(dk)?;
                    shape.validate().map_err(|e| at(e.to_string()))?;
                    species.push(shapes.len());
                    shapes.push(shape);
                }
            }
        }
    }
    let n = species.len();
    Ok((n, 0.0, Some(Particles { shapes, species })))
}

/// Per-particle diameters of a polydisperse species (ChaCha8 seeded with `seed`): uniform in
/// [min, max], or lognormal with median `median` and log-standard deviation sigma (0, 0.5],
/// redrawn outside median exp(+-3 sigma) so no particle outgrows the box.
fn polydisperse_diameters(
    pd: &PolySpec,
    median: f64,
    n: usize,
) -> std::result::Result<Vec<f64>, String> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(pd.seed);
    match (pd.distribution.as_str(), pd.min, pd.max, pd.sigma) {
        ("uniform", Some(lo), Some(hi), None) => {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return Err(format!(
                    "polydisperse min = {lo}, max = {hi}: need 0 < min <= max, finite"
                ));
            }
            Ok((0..n).map(|_| lo + (hi - lo) * rng.gen::<f64>()).collect())
        }
        ("lognormal", None, None, Some(sigma)) => {
            if !(sigma > 0.0 && sigma <= 0.5) {
                return Err(format!("polydisperse sigma = {sigma}: must be in (0, 0.5]"));
            }
            let mut out = Vec::with_capacity(n);
            while out.len() < n {
                // Box-Muller: z standard normal.
                let (u1, u2): (f64, f64) = (rng.gen(), rng.gen());
                let z = (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                if z.abs() <= 3.0 {
                    out.push(median * (sigma * z).exp());
                }
            }
            Ok(out)
        }
        (d @ ("uniform" | "lognormal"), ..) => Err(format!(
            "polydisperse distribution = \"{d}\": uniform needs `min` and `max` (no `sigma`), \
             lognormal needs `sigma` (no `min`/`max`; the median is `diameter`)"
        )),
        (other, ..) => Err(format!(
            "polydisperse distribution = \"{other}\": must be \"uniform\" or \"lognormal\""
        )),
    }
}

/// `porelab run` entry point for `kind = "packing"`.
/// `--threads` sets the worker threads of the parallel analysis (the MCM moves themselves are
/// sequential); results do not depend on it.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    match opts.threads {
        None => run_scene_limited(text, origin, out, opts, None),
        Some(0) => invalid("--threads 0: need at least one thread"),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| Error::InvalidInput(format!("--threads {t}: {e}")))?
            .install(|| run_scene_limited(text, origin, out, opts, None)),
    }
}

/// Runs (or resumes) a scene; with `max_new_steps` it stops after that many compression
/// steps, leaving the checkpoint behind as an interrupted run would (used by the tests).
fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_new_steps: Option<usize>,
) -> Result<()> {
    if let Some(t) = opts.checkpoint_every_seconds {
        if !(t.is_finite() && t >= 0.0) {
            return invalid(format!(
                "checkpoint interval {t} s: must be finite and not negative"
            ));
        }
    }
    let scene = parse_scene(text, origin)?;
    let prm = &scene.params;
    // Upper estimate: a 40000-sphere run holds about 30 MB (750 bytes a particle: state,
    // neighbour lists, the relaxation's arrays); 2 kB a particle leaves room for rods' longer
    // lists and the analysis.
    super::check_memory(
        origin,
        &format!("particles n = {} (about 2 kB per particle)", prm.n),
        2048.0 * prm.n as f64,
    )?;
    let ckpt_path = out.join("checkpoint.json");
    let (mut state, mut seconds) = if ckpt_path.exists() {
        let c = read_checkpoint(&ckpt_path, &scene)?;
        if !opts.quiet {
            eprintln!(
                "resuming {} from {} (step {}, phi = {:.4})",
                origin,
                ckpt_path.display(),
                c.0.history.len(),
                c.0.packing.packing_fraction()
            );
        }
        c
    } else {
        let start = packing::random_start_of(prm.container, prm.particles(), prm.phi0, prm.seed)?;
        (McmState::new(start, prm)?, 0.0)
    };
    // Only now, with the scene and its start checked: a refused scene leaves no empty folder.
    crate::io::create_dir(out)?;
    if !opts.quiet {
        eprintln!(
            "packing: {} particles ({}), {:?} scheme (eq. {}), {}, seed {}; stages: {}",
            prm.n,
            describe_particles(&prm.particles()),
            prm.scheme,
            match prm.scheme {
                Scheme::Original => "2.4-2.10",
                Scheme::Revised => "3.2-3.13",
                Scheme::Relax => "FIRE descent of the overlap energy, packing::relax",
            },
            match prm.container {
                Container::Periodic => "periodic cubic box".to_string(),
                Container::Cylinder { diameter } => format!(
                    "cylinder D_cyl = {diameter} (virtual-particle wall, sec. 2.2.4), periodic along z"
                ),
                Container::Wedge { length, angle_rad } => format!(
                    "wedge l_w = {length}, alpha = {} deg (virtual-particle walls, sec. 2.2.4), periodic along z",
                    angle_rad.to_degrees()
                ),
            },
            prm.seed,
            prm.stages()
        );
    }
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new_spinner();
        b.set_style(
            indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        b
    };
    let t0 = Instant::now();
    let base = seconds;
    let mut new_steps = 0usize;
    let mut last_checkpoint = Instant::now();
    let (mut stage_seen, mut stage_t0, mut stage_tries0) =
        (state.stage, Instant::now(), state.stage_tries);
    while !state.is_done() {
        if max_new_steps.is_some_and(|m| new_steps >= m) {
            bar.finish_and_clear();
            // Stopped between throttled checkpoints: save the state reached.
            return write_checkpoint(&ckpt_path, &scene, &state, seconds);
        }
        let o = state.step(prm)?;
        new_steps += 1;
        seconds = base + t0.elapsed().as_secs_f64();
        let due = opts
            .checkpoint_every_seconds
            .is_none_or(|t| last_checkpoint.elapsed().as_secs_f64() >= t);
        if due || o != StepOutcome::Accepted {
            write_checkpoint(&ckpt_path, &scene, &state, seconds)?;
            last_checkpoint = Instant::now();
        }
        if o != StepOutcome::Finished {
            // With a stage budget: how much of it the running stage has used.
            // and, from the rate so far, the most time the stage can still take (an ETA: the
            // stage may end sooner, on its halvings).
            if state.stage != stage_seen {
                (stage_seen, stage_t0, stage_tries0) =
                    (state.stage, Instant::now(), state.stage_tries);
            }
            let budget = prm
                .stage_params(state.stage)
                .stage_budget_per_particle
                .map_or(String::new(), |b| {
                    let n = state.packing.n() as f64;
                    let used = state.stage_tries as f64 / n;
                    let done_here = (state.stage_tries - stage_tries0) as f64 / n;
                    let eta = (done_here > 0.0).then(|| {
                        stage_t0.elapsed().as_secs_f64() * (b - used).max(0.0) / done_here
                    });
                    format!(
                        "  stage moves/N {used:.0} of {b:.0}{}",
                        eta.map_or(String::new(), |t| format!(" (stage ends within {t:.0} s)"))
                    )
                });
            bar.set_message(format!(
                "stage {} step {}  phi = {:.5}  Delta V = {:.3e}  halvings left {}  tries {}{budget}",
                state.stage + 1,
                state.history.len(),
                state.packing.packing_fraction(),
                state.delta_v,
                state.halvings_left,
                state.total_tries
            ));
            bar.tick();
        }
    }
    bar.finish_and_clear();
    let (summary, rattler_free_mean_defined) = write_outputs(out, origin, &scene, &state, seconds)?;
    if !rattler_free_mean_defined {
        eprintln!(
            "warning: with analysis.rattler_min_contacts = {} every particle is a rattler at some \
             cut-off, so contacts_extrapolated_no_rattlers is null; set a lower threshold",
            scene.rattler_min_contacts
        );
    }
    // The result on stdout (even with --quiet, which hides progress), the report on stderr.
    println!("{summary}");
    if !opts.quiet {
        eprintln!("outputs in {}", out.display());
    }
    Ok(())
}

/// One line per species kind: "1000 sphere d = 1", "750 superquadric a = [..] g = [..]"; a
/// polydisperse species (one particle per table entry) is summarised by its diameter range.
fn describe_particles(p: &Particles) -> String {
    let counts = p.counts();
    if p.shapes.len() > 8 {
        let d: Vec<f64> = p
            .shapes
            .iter()
            .filter_map(analysis::rod_parameters)
            .map(|(r, _)| 2.0 * r)
            .collect();
        let (lo, hi) = d
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        return format!(
            "{} species, polydisperse, diameters {lo:.4}..{hi:.4}",
            p.shapes.len()
        );
    }
    p.shapes
        .iter()
        .zip(counts)
        .map(|(s, c)| match *s {
            ContactShape::Sphere { radius } => format!("{c} sphere d = {}", 2.0 * radius),
            ContactShape::Spherocylinder { radius, length } => {
                format!("{c} spherocylinder d = {} L = {length}", 2.0 * radius)
            }
            ContactShape::Ellipsoid { semi_axes } => format!("{c} ellipsoid a = {semi_axes:?}"),
            ContactShape::Superquadric {
                semi_axes,
                exponents,
            } => format!("{c} superquadric a = {semi_axes:?} g = {exponents:?}"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The XYZ columns of one particle shape: type name, OVITO Aspherical Shape, radius (bounding
/// radius for non-rods), cylinder length and Superquadric Roundness (README "Output formats" lists them).
fn xyz_columns(s: &ContactShape) -> (&'static str, [f64; 3], f64, f64, [f64; 2]) {
    match *s {
        ContactShape::Sphere { radius } => ("sphere", [radius; 3], radius, 0.0, [1.0, 1.0]),
        ContactShape::Spherocylinder { radius, length } => (
            "spherocylinder",
            [radius, radius, length],
            radius,
            length,
            [1.0, 1.0],
        ),
        ContactShape::Ellipsoid { semi_axes } => {
            let r = semi_axes.iter().cloned().fold(0.0, f64::max);
            ("ellipsoid", semi_axes, r, 0.0, [1.0, 1.0])
        }
        ContactShape::Superquadric {
            semi_axes,
            exponents,
        } => {
            let r = crate::shape::bounding_radius_of(s).unwrap_or(f64::NAN);
            (
                "superquadric",
                semi_axes,
                r,
                0.0,
                [2.0 / exponents[0], 2.0 / exponents[2]],
            )
        }
    }
}

/// Observables of a final configuration (thesis sec. 2.2.5, 3.3, eq. 2.11, 4.17).
#[derive(Debug, Clone, Serialize)]
pub struct Measures {
    pub packing_fraction: f64,
    /// Deepest overlap (>= 0) by the analysis' pair search ([`analysis::pair_gaps`], independent
    /// of the engine; equal to the brute force over all pairs and images).
    pub deepest_overlap: f64,
    pub contact_cutoffs: Vec<f64>,
    /// Mean contacts at each cut-off, all particles.
    pub contacts_at_cutoffs: Vec<f64>,
    /// Linear extrapolation to zero cut-off, all particles counted (rattlers included).
    pub contacts_extrapolated: f64,
    /// The same with rattlers removed repeatedly (fewer than `rattler_min_contacts`); `None`
    /// (JSON null) when that removes every particle at some cut-off, as it does for hypostatic
    /// packings (superballs with the default threshold 5): there is no mean to report.
    pub contacts_extrapolated_no_rattlers: Option<f64>,
    pub rattler_min_contacts: usize,
    /// Rattlers at the smallest cut-off.
    pub rattlers: usize,
    pub nematic_s: f64,
    pub cubatic_s4: f64,
    /// Cylinder and wedge: fraction of the particles within D of a wall whose axis is
    /// tangential to it within 4 degrees (thesis sec. 2.2.5, Fig. 2.6, 2.14), and how many are
    /// in that layer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_aligned_fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_layer_particles: Option<usize>,
    /// Ellipsoids / superquadrics only: deepest penetration proven by the solver-free sampled
    /// check ([`analysis::sampled_overlap`], 0 when no sample lies inside another particle)
    /// and the sample spacing, its resolution.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampled_deepest_overlap: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sample_spacing: Option<f64>,
}

/// Measures a configuration with [`crate::analysis`].
pub fn measure(
    p: &Packing,
    cutoffs: &[f64],
    min_contacts: usize,
    s4_trials: usize,
) -> Result<Measures> {
    let v = p.view();
    let dmax = cutoffs.iter().cloned().fold(0.0, f64::max);
    let gaps = analysis::pair_gaps(&v, dmax)?;
    let deepest = gaps.iter().map(|g| -g.gap).fold(0.0f64, f64::max);
    let contacts_at: Vec<f64> = cutoffs
        .iter()
        .map(|&d| analysis::mean_contacts(v.n(), &gaps, d, None).0)
        .collect();
    let (c0, _) = analysis::extrapolated_contacts(v.n(), &gaps, cutoffs, None)?;
    let c0r = if analysis::cutoff_where_all_rattle(v.n(), &gaps, cutoffs, min_contacts).is_some() {
        None
    } else {
        Some(analysis::extrapolated_contacts(v.n(), &gaps, cutoffs, Some(min_contacts))?.0)
    };
    let dmin = cutoffs.iter().cloned().fold(f64::INFINITY, f64::min);
    let (_, rattlers) = analysis::mean_contacts(v.n(), &gaps, dmin, Some(min_contacts));
    let wall = match p.container {
        Container::Periodic => None,
        Container::Cylinder { .. } | Container::Wedge { .. } => Some(
            analysis::wall_aligned_fraction(&v, 2.0 * packing::RADIUS, 4f64.to_radians())?,
        ),
    };
    let sampled = if p.particles.has_superquadrics() {
        Some(analysis::sampled_overlap(&v, analysis::OVERLAP_SAMPLES)?)
    } else {
        None
    };
    Ok(Measures {
        sampled_deepest_overlap: sampled.map(|s| s.worst.map_or(0.0, |w| w.2)),
        sample_spacing: sampled.map(|s| s.spacing),
        packing_fraction: p.packing_fraction(),
        deepest_overlap: deepest,
        contact_cutoffs: cutoffs.to_vec(),
        contacts_at_cutoffs: contacts_at,
        contacts_extrapolated: c0,
        contacts_extrapolated_no_rattlers: c0r,
        rattler_min_contacts: min_contacts,
        rattlers,
        nematic_s: analysis::nematic_order(&p.axes())?,
        cubatic_s4: analysis::cubatic_order(&p.orientations, s4_trials)?,
        wall_aligned_fraction: wall.map(|w| w.0),
        wall_layer_particles: wall.map(|w| w.1),
    })
}

#[derive(Serialize)]
struct Summary<'a> {
    scene: &'a str,
    title: &'a str,
    porelab_version: &'static str,
    /// Worker threads of the run (the analysis and the relaxation's force loop); the results
    /// do not depend on it.
    threads: usize,
    shape: &'static str,
    n: usize,
    /// Equal spheres / spherocylinders of diameter 1 only.
    #[serde(skip_serializing_if = "Option::is_none")]
    length_over_diameter: Option<f64>,
    seed: u64,
    scheme: String,
    box_length: f64,
    #[serde(flatten)]
    measures: Measures,
    compression_steps: usize,
    failed_steps: usize,
    total_tries: u64,
    jammed: bool,
    /// The last stage ended on its `stage_budget_per_particle`, not on its halvings.
    stage_budget_spent: bool,
    seconds: f64,
}

fn write_outputs(
    out: &Path,
    origin: &str,
    scene: &PackingScene,
    state: &McmState,
    seconds: f64,
) -> Result<(String, bool)> {
    let p = &state.packing;
    let prm = &scene.params;
    let m = measure(
        p,
        &scene.cutoffs,
        scene.rattler_min_contacts,
        scene.s4_trials,
    )?;
    let parts: Vec<xyz::XyzParticle> = (0..p.n())
        .map(|i| {
            let (name, shape, radius, cylinder_length, roundness) =
                xyz_columns(p.particles.shape(i));
            xyz::XyzParticle {
                species: name.to_string(),
                position: p.positions[i],
                orientation: p.orientations[i],
                aspherical_shape: shape,
                radius,
                cylinder_length,
                roundness,
            }
        })
        .collect();
    let cell = match p.container {
        Container::Periodic => xyz::Cell::cubic(p.box_length),
        Container::Cylinder { diameter } => xyz::Cell {
            lengths: [diameter, diameter, p.box_length],
            origin: [-0.5 * diameter, -0.5 * diameter, 0.0],
            pbc: [false, false, true],
        },
        Container::Wedge { length, angle_rad } => xyz::Cell {
            lengths: [length, length * angle_rad.tan(), p.box_length],
            origin: [0.0, 0.0, 0.0],
            pbc: [false, false, true],
        },
    };
    xyz::write(
        &out.join("final.xyz"),
        &cell,
        &parts,
        &[
            ("packing_fraction", format!("{}", m.packing_fraction)),
            ("seed", format!("{}", prm.seed)),
        ],
    )?;
    let mut csv = String::from("step,delta_v_D3,packing_fraction,tries\n");
    for h in &state.history {
        csv.push_str(&format!(
            "{},{},{},{}\n",
            h.step, h.delta_v, h.packing_fraction, h.tries
        ));
    }
    write_atomic(&out.join("phi_history.csv"), csv.as_bytes())?;
    CsvPlot {
        title: "Packing fraction after each accepted compression step",
        x: "step",
        y: "packing_fraction",
        x_label: "compression step",
        y_label: "packing fraction",
        ..Default::default()
    }
    .write_or_warn(&out.join("phi_history.svg"), &csv);
    if p.container == Container::Periodic {
        let rmax = scene.gr_r_max.unwrap_or(3.0).min(0.5 * p.box_length);
        let g = analysis::radial_distribution(&p.view(), rmax, scene.gr_bins)?;
        let mut gcsv = String::from("r_D,g\n");
        for (rc, v) in g {
            gcsv.push_str(&format!("{rc},{v}\n"));
        }
        write_atomic(&out.join("gr.csv"), gcsv.as_bytes())?;
        CsvPlot {
            title: "Radial distribution function of the centres",
            x: "r_D",
            y: "g",
            x_label: "r (particle diameters D)",
            y_label: "g(r)",
            ..Default::default()
        }
        .write_or_warn(&out.join("gr.svg"), &gcsv);
    }
    let h = analysis::orientation_histogram(&p.axes(), 9, 18)?;
    let mut hcsv = String::from("theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,count\n");
    for (kt, row) in h.iter().enumerate() {
        for (kp, c) in row.iter().enumerate() {
            hcsv.push_str(&format!(
                "{},{},{},{},{c}\n",
                kt * 10,
                (kt + 1) * 10,
                kp * 10,
                (kp + 1) * 10
            ));
        }
    }
    write_atomic(&out.join("orientation_histogram.csv"), hcsv.as_bytes())?;
    let rattler_free_mean_defined = m.contacts_extrapolated_no_rattlers.is_some();
    let s = Summary {
        scene: origin,
        title: &scene.title,
        porelab_version: env!("CARGO_PKG_VERSION"),
        threads: rayon::current_num_threads(),
        shape: match p.particles.shapes.as_slice() {
            [one] => one.name(),
            _ => "mixture",
        },
        n: p.n(),
        length_over_diameter: p.monodisperse_length(),
        seed: prm.seed,
        scheme: format!("{:?}", prm.scheme).to_lowercase(),
        box_length: p.box_length,
        measures: m,
        compression_steps: state.history.len(),
        failed_steps: state.failed_steps,
        total_tries: state.total_tries,
        // Ended by its schedule after compressing at all: a run whose every step failed
        // (Delta V too large for the start) did not jam, it did nothing.
        jammed: state.finished == Some(true) && !state.history.is_empty(),
        stage_budget_spent: state.stage_budget_spent,
        seconds,
    };
    let json = serde_json::to_string_pretty(&s).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    Ok((json, rattler_free_mean_defined))
}

/// The checkpoint: the scene fingerprint and the full [`McmState`], every f64 stored as its
/// IEEE bits so the resumed run starts from bitwise the same state.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: f64,
    box_length: u64,
    positions: Vec<[u64; 3]>,
    /// Quaternion (w, i, j, k) bits.
    orientations: Vec<[u64; 4]>,
    delta_v: u64,
    halvings_left: u32,
    stage: u32,
    /// (step, packing fraction bits, Delta V bits, tries) per accepted step.
    history: Vec<(usize, u64, u64, u64)>,
    failed_steps: usize,
    total_tries: u64,
    /// Moves in the running stage (absent in checkpoints written before stage budgets: 0,
    /// which is exact for their scenes, as they had no budget).
    #[serde(default)]
    stage_tries: u64,
    #[serde(default)]
    stage_budget_spent: bool,
    finished: Option<bool>,
}

fn write_checkpoint(path: &Path, scene: &PackingScene, s: &McmState, seconds: f64) -> Result<()> {
    let p = &s.packing;
    let c = Checkpoint {
        format: 2,
        scene: scene.fingerprint.clone(),
        seconds,
        box_length: p.box_length.to_bits(),
        positions: p
            .positions
            .iter()
            .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .collect(),
        orientations: p
            .orientations
            .iter()
            .map(|q| {
                let q = q.quaternion();
                [q.w.to_bits(), q.i.to_bits(), q.j.to_bits(), q.k.to_bits()]
            })
            .collect(),
        delta_v: s.delta_v.to_bits(),
        halvings_left: s.halvings_left,
        stage: s.stage,
        history: s
            .history
            .iter()
            .map(|h| {
                (
                    h.step,
                    h.packing_fraction.to_bits(),
                    h.delta_v.to_bits(),
                    h.tries,
                )
            })
            .collect(),
        failed_steps: s.failed_steps,
        total_tries: s.total_tries,
        stage_tries: s.stage_tries,
        stage_budget_spent: s.stage_budget_spent,
        finished: s.finished,
    };
    let text = serde_json::to_vec(&c).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(path, &text)
}

fn read_checkpoint(path: &Path, scene: &PackingScene) -> Result<(McmState, f64)> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let text =
        std::fs::read(path).map_err(|e| file_err(format!("cannot read the checkpoint: {e}")))?;
    let c: Checkpoint = serde_json::from_slice(&text)
        .map_err(|e| file_err(format!("not a packing checkpoint: {e}")))?;
    if c.format != 2 {
        return Err(file_err(format!(
            "checkpoint format {}: this porelab reads format 2",
            c.format
        )));
    }
    if c.scene != scene.fingerprint {
        return Err(file_err(
            "written by a different scene (parameters differ): delete it to start afresh, or \
             choose another output folder with --out"
                .into(),
        ));
    }
    let f = f64::from_bits;
    if c.positions.len() != scene.params.n || c.orientations.len() != scene.params.n {
        return Err(file_err(format!(
            "{} positions, {} orientations: the scene has n = {}",
            c.positions.len(),
            c.orientations.len(),
            scene.params.n
        )));
    }
    let packing = Packing {
        container: scene.params.container,
        box_length: f(c.box_length),
        particles: scene.params.particles(),
        positions: c
            .positions
            .iter()
            .map(|b| Vector3::new(f(b[0]), f(b[1]), f(b[2])))
            .collect(),
        orientations: c
            .orientations
            .iter()
            .map(|b| {
                UnitQuaternion::new_unchecked(Quaternion::new(f(b[0]), f(b[1]), f(b[2]), f(b[3])))
            })
            .collect(),
    };
    let state = McmState {
        packing,
        delta_v: f(c.delta_v),
        halvings_left: c.halvings_left,
        history: c
            .history
            .iter()
            .map(|h| StepRecord {
                step: h.0,
                packing_fraction: f(h.1),
                delta_v: f(h.2),
                tries: h.3,
            })
            .collect(),
        failed_steps: c.failed_steps,
        total_tries: c.total_tries,
        stage_tries: c.stage_tries,
        stage_budget_spent: c.stage_budget_spent,
        stage: c.stage,
        finished: c.finished,
    };
    Ok((state, c.seconds))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"
kind = "packing"
title = "test"
[particles]
shape = "spherocylinder"
n = 40
length_over_diameter = 0.5
[mcm]
seed = 11
delta_v_per_particle = 0.05
halvings = 2
tries_per_particle = 50.0
[final_stage]
delta_v_per_particle = 0.005
halvings = 1
[analysis]
gr_bins = 20
s4_trials = 50
"#;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("porelab-scene-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// The summary.json of a finished run in `dir`.
    fn summary_of(dir: &std::path::Path) -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap()
    }

    fn quiet() -> RunOptions {
        RunOptions {
            quiet: true,
            ..Default::default()
        }
    }

    /// Four touching spheres in a row have 1.5 contacts each on average. With the rattler
    /// threshold 2 the ends go, then the middle pair: nothing is left, and the rattler-free
    /// contact number is null, not 0. Threshold 1 keeps all four.
    #[test]
    fn rattler_free_contacts_are_null_when_every_particle_rattles() {
        let p = Packing {
            container: Container::Periodic,
            box_length: 10.0,
            particles: Particles::monodisperse(4, 0.0),
            positions: (0..4)
                .map(|k| Vector3::new(1.0 + k as f64, 5.0, 5.0))
                .collect(),
            orientations: vec![UnitQuaternion::identity(); 4],
        };
        let cut = [1e-6, 1e-5];
        let all = measure(&p, &cut, 2, 10).unwrap();
        assert_eq!(all.rattlers, 4);
        assert_eq!(all.contacts_extrapolated_no_rattlers, None);
        assert!((all.contacts_extrapolated - 1.5).abs() < 1e-12);
        let kept = measure(&p, &cut, 1, 10).unwrap();
        assert_eq!(kept.rattlers, 0);
        let c0 = kept.contacts_extrapolated_no_rattlers.unwrap();
        assert!((c0 - 1.5).abs() < 1e-12, "{c0}");
    }

    /// A run whose final stage ends on its budget resumes, one step at a time, to the same
    /// result: the checkpoint carries the stage's moves so far.
    #[test]
    fn budgeted_stage_resumes_to_the_same_result() {
        let text = SMALL.replace(
            "halvings = 1\n[analysis]",
            "halvings = 6\nstage_budget_per_particle = 120.0\n[analysis]",
        );
        assert_ne!(text, SMALL);
        let (a, b) = (tmp("budget-full"), tmp("budget-resumed"));
        run_scene(&text, "test", &a, &quiet()).unwrap();
        let mut calls = 0;
        while !b.join("final.xyz").exists() {
            run_scene_limited(&text, "test", &b, &quiet(), Some(1)).unwrap();
            calls += 1;
            assert!(calls < 10_000);
        }
        assert!(
            std::fs::read(a.join("final.xyz")).unwrap()
                == std::fs::read(b.join("final.xyz")).unwrap(),
            "final.xyz differs between the full and the resumed run"
        );
        let sa = summary_of(&a);
        let sb = summary_of(&b);
        assert_eq!(sa["stage_budget_spent"], serde_json::Value::Bool(true));
        for k in ["total_tries", "failed_steps", "stage_budget_spent"] {
            assert_eq!(sa[k], sb[k], "{k}");
        }
    }

    #[test]
    fn interrupted_run_resumes_to_the_same_result() {
        let (a, b) = (tmp("full"), tmp("resumed"));
        run_scene(SMALL, "test", &a, &quiet()).unwrap();
        // Interrupt twice (after 7 and 5 more steps), then finish. The interrupted parts
        // checkpoint rarely (every 1e9 s): the stop itself must save the state reached.
        let rare = RunOptions {
            checkpoint_every_seconds: Some(1e9),
            ..quiet()
        };
        run_scene_limited(SMALL, "test", &b, &rare, Some(7)).unwrap();
        assert!(b.join("checkpoint.json").exists() && !b.join("final.xyz").exists());
        let scene = parse_scene(SMALL, "test").unwrap();
        let (state, _) = read_checkpoint(&b.join("checkpoint.json"), &scene).unwrap();
        assert_eq!(state.history.len() + state.failed_steps, 7);
        run_scene_limited(SMALL, "test", &b, &rare, Some(5)).unwrap();
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let o = RunOptions {
                checkpoint_every_seconds: Some(bad),
                ..quiet()
            };
            let e = run_scene(SMALL, "test", &b, &o).unwrap_err().to_string();
            assert!(e.contains("checkpoint interval"), "{e}");
        }
        run_scene(SMALL, "test", &b, &rare).unwrap();
        for f in ["final.xyz", "phi_history.csv", "gr.csv"] {
            let (x, y) = (
                std::fs::read(a.join(f)).unwrap(),
                std::fs::read(b.join(f)).unwrap(),
            );
            assert!(x == y, "{f} differs between the full and the resumed run");
        }
        let sa = summary_of(&a);
        let sb = summary_of(&b);
        for k in [
            "packing_fraction",
            "compression_steps",
            "total_tries",
            "cubatic_s4",
        ] {
            assert_eq!(sa[k], sb[k], "{k}");
        }
        // The outputs describe an overlap-free packing: check the XYZ file independently.
        let (cell, parts) = xyz::parse(
            &std::fs::read_to_string(a.join("final.xyz")).unwrap(),
            "final",
        )
        .unwrap();
        let l = cell.lengths[0];
        let pos: Vec<_> = parts.iter().map(|p| p.position).collect();
        let ori: Vec<_> = parts.iter().map(|p| p.orientation).collect();
        let mono = Particles::monodisperse(pos.len(), 0.5);
        let v = analysis::Rods {
            box_length: l,
            wall_diameter: None,
            wedge: None,
            shapes: &mono.shapes,
            species: &mono.species,
            positions: &pos,
            orientations: &ori,
        };
        analysis::check_no_overlap(&v, 1e-4 * (1.0 + 1e-6)).unwrap();
        assert_eq!(
            sa["packing_fraction"].as_f64().unwrap(),
            analysis::packing_fraction(&v).unwrap()
        );
        // The history has one row per accepted step, increasing packing fraction.
        let hist = std::fs::read_to_string(a.join("phi_history.csv")).unwrap();
        let phis: Vec<f64> = hist
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
            .collect();
        assert_eq!(phis.len() as u64, sa["compression_steps"].as_u64().unwrap());
        assert!(phis.windows(2).all(|w| w[1] > w[0]));
        // One worker thread gives the same outputs as the default pool.
        let c = tmp("one-thread");
        let one = RunOptions {
            quiet: true,
            threads: Some(1),
            ..Default::default()
        };
        run_scene(SMALL, "test", &c, &one).unwrap();
        for f in [
            "final.xyz",
            "phi_history.csv",
            "gr.csv",
            "orientation_histogram.csv",
        ] {
            assert!(
                std::fs::read(a.join(f)).unwrap() == std::fs::read(c.join(f)).unwrap(),
                "{f} depends on the thread count"
            );
        }
        let _ = std::fs::remove_dir_all(&c);
        // A changed scene refuses the old checkpoint, naming it.
        let changed = SMALL.replace("seed = 11", "seed = 12");
        let e = run_scene_limited(&changed, "test", &b, &quiet(), Some(1)).unwrap_err();
        assert!(e.to_string().contains("different scene"), "{e}");
        let _ = std::fs::remove_dir_all(&a);
        let _ = std::fs::remove_dir_all(&b);
    }

    #[test]
    fn misspelt_and_bad_keys_are_rejected_by_name() {
        let e = parse_scene(&SMALL.replace("halvings = 2", "halvings_ = 2"), "t").unwrap_err();
        assert!(e.to_string().contains("halvings_"), "{e}");
        let e = parse_scene(&SMALL.replace("n = 40", "n = 1"), "t").unwrap_err();
        assert!(e.to_string().contains("n = 1"), "{e}");
        let e = parse_scene(&SMALL.replace("\"spherocylinder\"", "\"cube\""), "t").unwrap_err();
        assert!(e.to_string().contains("cube"), "{e}");
        let e = parse_scene(&SMALL.replace("length_over_diameter = 0.5", ""), "t").unwrap_err();
        assert!(e.to_string().contains("length_over_diameter"), "{e}");
        let e = parse_scene(
            &SMALL.replace(
                "[final_stage]\ndelta_v_per_particle = 0.005",
                "[final_stage]\ndelta_v_per_particle = -1",
            ),
            "t",
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("final stage") && e.to_string().contains("delta_v"),
            "{e}"
        );
        let e = parse_scene(&format!("{SMALL}\n[box]\nx = 1\n"), "t").unwrap_err();
        assert!(e.to_string().contains("box"), "{e}");
    }

    const MIXTURE: &str = r#"
kind = "packing"
[[particles.species]]
shape = "sphere"
n = 30
diameter = 1.4
[[particles.species]]
shape = "sphere"
n = 50
[particles.species.polydisperse]
distribution = "uniform"
min = 0.8
max = 1.2
seed = 3
[mcm]
seed = 2
"#;

    /// Species tables: a monodisperse block and a polydisperse one (one table entry per
    /// particle, diameters inside [min, max]); misspelt or misplaced keys are named.
    #[test]
    fn species_tables_parse_and_bad_keys_are_named() {
        let sc = parse_scene(MIXTURE, "t").unwrap();
        let p = sc.params.particles();
        assert_eq!((sc.params.n, p.n(), p.shapes.len()), (80, 80, 51));
        assert_eq!(p.counts()[0], 30);
        for s in &p.shapes[1..] {
            let (r, _) = analysis::rod_parameters(s).unwrap();
            assert!((0.4..=0.6).contains(&r), "{r}");
        }
        assert_eq!(sc.rattler_min_contacts, 4);
        let bad = |from: &str, to: &str, want: &str| {
            let e = parse_scene(&MIXTURE.replacen(from, to, 1), "t").unwrap_err();
            assert!(e.to_string().contains(want), "{e}");
        };
        bad("diameter = 1.4", "diametre = 1.4", "diametre");
        bad("diameter = 1.4", "exponent = 3.0", "exponent");
        bad(r#""uniform""#, r#""gaussian""#, "gaussian");
        bad("min = 0.8", "sigma = 0.2", "uniform needs");
        bad(
            "[[particles.species]]",
            "[particles]\nn = 5\n[[particles.species]]",
            "particles.n",
        );
        bad(r#"shape = "sphere""#, r#"shape = "cube""#, "cube");
        let sb = parse_scene(
            r#"
kind = "packing"
[[particles.species]]
shape = "superball"
n = 50
exponent = 3.0
[mcm]
scheme = "original"
"#,
            "t",
        )
        .unwrap_err();
        assert!(sb.to_string().contains("revised"), "{sb}");
    }

    /// The built-in `packing-spheres` is the schedule of case 512 and the benchmark.
    #[test]
    fn builtin_spheres_is_the_jamming_schedule() {
        let b = builtins()
            .into_iter()
            .find(|b| b.name == "packing-spheres")
            .unwrap();
        let got = parse_scene(b.toml, b.name).unwrap().params;
        let want = McmParams::jammed_spheres(1000, 1);
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
    }

    #[test]
    fn builtins_parse() {
        for b in builtins() {
            parse_scene(b.toml, b.name).unwrap();
        }
    }
}
