//! The packing scene file: its schema (serde, unknown keys refused by name) and the checks
//! that turn it into a [`PackingScene`].

use crate::contact::ContactShape;
use crate::error::{invalid, Error};
use crate::packing::{Container, McmParams, Particles, Scheme, Stage};
use crate::Result;
use serde::{Deserialize, Serialize};

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
    pub(super) fingerprint: String,
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
