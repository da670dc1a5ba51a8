//! The packing scene file: a serde mirror of [`packing::Setup`] (unknown keys refused by name,
//! shapes, containers, schemes and size distributions as tagged enums) and its conversion into
//! a [`PackingScene`], with errors that name the file, the key, the value and the rule.

use crate::contact::ContactShape;
use crate::error::{invalid, Error};
use crate::packing::{self, Container, ParticleShapes, Scheme, Stage};
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

/// `[particles]`: equal spheres or spherocylinders by `shape`, `n` and
/// `length_over_diameter`, or a table of species.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct ParticlesSpec {
    #[serde(default)]
    shape: Option<EqualShape>,
    #[serde(default)]
    n: Option<usize>,
    #[serde(default)]
    length_over_diameter: Option<f64>,
    /// Mixture / polydisperse / superquadric species (instead of the three keys above).
    #[serde(default)]
    species: Vec<SpeciesSpec>,
}

/// `particles.shape`: the shape of equal particles of diameter 1.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum EqualShape {
    Sphere,
    Spherocylinder,
}

/// One `[[particles.species]]` entry, by its `shape`; each shape takes its own keys.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "shape", rename_all = "kebab-case", deny_unknown_fields)]
enum SpeciesSpec {
    Sphere {
        n: usize,
        /// [1]
        diameter: Option<f64>,
        polydisperse: Option<PolySpec>,
    },
    Spherocylinder {
        n: usize,
        /// [1]
        diameter: Option<f64>,
        length: f64,
        polydisperse: Option<PolySpec>,
    },
    Ellipsoid {
        n: usize,
        semi_axes: [f64; 3],
    },
    Superball {
        n: usize,
        /// [0.5]
        half_width: Option<f64>,
        exponent: f64,
    },
    Superquadric {
        n: usize,
        semi_axes: [f64; 3],
        exponents: [f64; 3],
    },
}

impl SpeciesSpec {
    fn name(&self) -> &'static str {
        match self {
            SpeciesSpec::Sphere { .. } => "sphere",
            SpeciesSpec::Spherocylinder { .. } => "spherocylinder",
            SpeciesSpec::Ellipsoid { .. } => "ellipsoid",
            SpeciesSpec::Superball { .. } => "superball",
            SpeciesSpec::Superquadric { .. } => "superquadric",
        }
    }

    fn n(&self) -> usize {
        match *self {
            SpeciesSpec::Sphere { n, .. }
            | SpeciesSpec::Spherocylinder { n, .. }
            | SpeciesSpec::Ellipsoid { n, .. }
            | SpeciesSpec::Superball { n, .. }
            | SpeciesSpec::Superquadric { n, .. } => n,
        }
    }

    /// The shape at diameter `d` (spheres and spherocylinders; the others ignore it).
    fn shape(&self, d: f64) -> ContactShape {
        match *self {
            SpeciesSpec::Sphere { .. } => ContactShape::Sphere { radius: 0.5 * d },
            SpeciesSpec::Spherocylinder { length, .. } => ContactShape::Spherocylinder {
                radius: 0.5 * d,
                length,
            },
            SpeciesSpec::Ellipsoid { semi_axes, .. } => ContactShape::Ellipsoid { semi_axes },
            SpeciesSpec::Superball {
                half_width,
                exponent,
                ..
            } => ContactShape::Superquadric {
                semi_axes: [half_width.unwrap_or(0.5); 3],
                exponents: [exponent; 3],
            },
            SpeciesSpec::Superquadric {
                semi_axes,
                exponents,
                ..
            } => ContactShape::Superquadric {
                semi_axes,
                exponents,
            },
        }
    }

    /// The diameter and the size distribution of a sphere or spherocylinder species.
    fn sizes(&self) -> (f64, Option<&PolySpec>) {
        match self {
            SpeciesSpec::Sphere {
                diameter,
                polydisperse,
                ..
            }
            | SpeciesSpec::Spherocylinder {
                diameter,
                polydisperse,
                ..
            } => (diameter.unwrap_or(1.0), polydisperse.as_ref()),
            _ => (1.0, None),
        }
    }
}

/// `[particles.species.polydisperse]`: per-particle diameters of a sphere or spherocylinder
/// species, drawn from a ChaCha8 stream seeded with `seed`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "distribution", rename_all = "kebab-case", deny_unknown_fields)]
enum PolySpec {
    /// Uniform in [min, max].
    Uniform { min: f64, max: f64, seed: u64 },
    /// Lognormal with the species' diameter as median and log-standard deviation sigma.
    Lognormal { sigma: f64, seed: u64 },
}

/// `[container]`, by its `shape`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "shape", rename_all = "kebab-case", deny_unknown_fields)]
enum ContainerSpec {
    /// Periodic cubic box (a struct variant, so that a key of another shape is refused).
    Periodic {},
    /// Hard cylinder of diameter D_cyl (D) about z, periodic along z.
    Cylinder { diameter: f64 },
    /// Wedge: length l_w along x (D) and angle alpha in degrees (h_w = l_w tan(alpha)).
    Wedge { length: f64, angle_deg: f64 },
}

impl Default for ContainerSpec {
    fn default() -> Self {
        ContainerSpec::Periodic {}
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
struct McmSpec {
    seed: u64,
    scheme: Scheme,
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
        let p = packing::Setup::new(2, 0.0, 1);
        McmSpec {
            seed: 1,
            scheme: Scheme::Original,
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
    scheme: Option<Scheme>,
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

/// What the final configuration is measured with (`[analysis]`).
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Gap cut-offs of the contact-number extrapolation (sec. 2.2.5).
    pub cutoffs: Vec<f64>,
    pub rattler_min_contacts: usize,
    pub gr_r_max: Option<f64>,
    pub gr_bins: usize,
    pub s4_trials: usize,
}

/// A parsed and checked packing scene.
#[derive(Debug, Clone)]
pub struct PackingScene {
    pub title: String,
    pub setup: packing::Setup,
    pub analysis: Analysis,
    /// Canonical JSON of the parsed file: a checkpoint must carry the same text to be resumed.
    pub(super) fingerprint: String,
}

/// Parses a packing scene; `origin` names the source in errors.
pub fn parse_scene(text: &str, origin: &str) -> Result<PackingScene> {
    let f: SceneFile = toml::from_str(text)
        .map_err(|e| crate::scene::keys::name_the_key(text, e))
        .map_err(|e| Error::File {
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
    let (n, length, particles) = match parse_particles(&f.particles) {
        Ok(p) => p,
        Err(e) => return bad(e),
    };
    let container = match container(&f.container) {
        Ok(c) => c,
        Err(e) => return bad(e),
    };
    let m = &f.mcm;
    let mut p = packing::Setup::new(n, length, m.seed);
    p.particles = particles;
    p.container = container;
    p.scheme = m.scheme;
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
    // The final stage inherits the scheme, tries, beta and dt of [mcm], not its budget.
    p.final_stage = f.final_stage.as_ref().map(|s| Stage {
        scheme: s.scheme.unwrap_or(m.scheme),
        delta_v_per_particle: s.delta_v_per_particle,
        halvings: s.halvings,
        tries_per_particle: s.tries_per_particle.unwrap_or(m.tries_per_particle),
        stage_budget_per_particle: s.stage_budget_per_particle,
        beta: s.beta.unwrap_or(m.beta),
        dt: s.dt.unwrap_or(m.dt),
    });
    p.validate()
        .map_err(|e| Error::InvalidInput(format!("{origin}: {e}")))?;
    let analysis = match analysis(&f.analysis, &p) {
        Ok(a) => a,
        Err(e) => return bad(e),
    };
    let fingerprint = serde_json::to_string(&f).map_err(|e| Error::InvalidInput(e.to_string()))?;
    Ok(PackingScene {
        title: f.title.clone(),
        setup: p,
        analysis,
        fingerprint,
    })
}

/// The container of `[container]`; Err: the message (key, value, rule).
fn container(c: &ContainerSpec) -> std::result::Result<Container, String> {
    Ok(match *c {
        ContainerSpec::Periodic {} => Container::Periodic,
        ContainerSpec::Cylinder { diameter } => Container::Cylinder { diameter },
        ContainerSpec::Wedge { length, angle_deg } => {
            // Thesis Fig. 2.3: the right triangular prism 0 <= y <= x tan(alpha), x <= l_w.
            if !(angle_deg.is_finite() && angle_deg > 0.0 && angle_deg < 90.0) {
                return Err(format!(
                    "container.angle_deg = {angle_deg}: must be in (0, 90) degrees (the wedge is \
                     the right triangular prism 0 <= y <= x tan(alpha), thesis Fig. 2.3)"
                ));
            }
            if !(length.is_finite() && length > 0.0) {
                return Err(format!(
                    "container.length = {length}: must be positive and finite (D)"
                ));
            }
            Container::Wedge {
                length,
                angle_rad: angle_deg.to_radians(),
            }
        }
    })
}

/// The checked `[analysis]` of a scene whose setup is `p`; Err: the message.
fn analysis(a: &AnalysisSpec, p: &packing::Setup) -> std::result::Result<Analysis, String> {
    if a.contact_cutoffs.len() < 2 {
        return Err(format!(
            "analysis.contact_cutoffs has {} values: need at least 2 for the extrapolation",
            a.contact_cutoffs.len()
        ));
    }
    if let Some(d) = a
        .contact_cutoffs
        .iter()
        .find(|d| !(d.is_finite() && **d > 0.0))
    {
        return Err(format!(
            "analysis.contact_cutoffs: {d} must be positive and finite"
        ));
    }
    if a.gr_bins == 0 {
        return Err("analysis.gr_bins = 0: need at least one bin".into());
    }
    if let Some(r) = a.gr_r_max {
        if !(r.is_finite() && r > 0.0) {
            return Err(format!(
                "analysis.gr_r_max = {r}: must be positive and finite"
            ));
        }
    }
    if a.s4_trials < 10 {
        return Err(format!(
            "analysis.s4_trials = {}: need at least 10",
            a.s4_trials
        ));
    }
    Ok(Analysis {
        cutoffs: a.contact_cutoffs.clone(),
        // Rattlers have fewer than 4 contacts among spheres, else fewer than 5.
        rattler_min_contacts: a
            .rattler_min_contacts
            .unwrap_or(if all_spheres(p) { 4 } else { 5 }),
        gr_r_max: a.gr_r_max,
        gr_bins: a.gr_bins,
        s4_trials: a.s4_trials,
    })
}

/// True when every particle is a sphere.
fn all_spheres(p: &packing::Setup) -> bool {
    match &p.particles {
        // Equal particles: no table of n entries is built before the memory check.
        None => p.length == 0.0,
        Some(t) => t
            .shapes
            .iter()
            .all(|s| matches!(s, ContactShape::Sphere { .. })),
    }
}

/// The particles of a scene: (n, cylinder length, None) for the equal-particle keys
/// `shape`/`n`/`length_over_diameter`, (n, 0, Some(table)) for `[[particles.species]]`.
fn parse_particles(
    s: &ParticlesSpec,
) -> std::result::Result<(usize, f64, Option<ParticleShapes>), String> {
    if s.species.is_empty() {
        let length = match (s.shape.unwrap_or(EqualShape::Sphere), s.length_over_diameter) {
            (EqualShape::Sphere, None) => 0.0,
            (EqualShape::Sphere, Some(0.0)) => 0.0,
            (EqualShape::Sphere, Some(l)) => {
                return Err(format!(
                    "particles.length_over_diameter = {l}: a sphere has none (use shape = \"spherocylinder\")"
                ))
            }
            (EqualShape::Spherocylinder, Some(l)) if l.is_finite() && l > 0.0 => l,
            (EqualShape::Spherocylinder, Some(l)) => {
                return Err(format!(
                    "particles.length_over_diameter = {l}: must be positive and finite for a spherocylinder"
                ))
            }
            (EqualShape::Spherocylinder, None) => {
                return Err(
                    "particles.length_over_diameter: required for shape = \"spherocylinder\"".into(),
                )
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
        let at = |msg: String| format!("particles.species[{k}] ({}): {msg}", sp.name());
        if sp.n() == 0 {
            return Err(at("n = 0: need at least one particle".into()));
        }
        let (d, poly) = sp.sizes();
        match poly {
            None => {
                let shape = sp.shape(d);
                shape.validate().map_err(|e| at(e.to_string()))?;
                species.extend(std::iter::repeat_n(shapes.len(), sp.n()));
                shapes.push(shape);
            }
            Some(pd) => {
                for dk in polydisperse_diameters(pd, d, sp.n()).map_err(&at)? {
                    let shape = sp.shape(dk);
                    shape.validate().map_err(|e| at(e.to_string()))?;
                    species.push(shapes.len());
                    shapes.push(shape);
                }
            }
        }
    }
    let n = species.len();
    Ok((n, 0.0, Some(ParticleShapes { shapes, species })))
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
    match *pd {
        PolySpec::Uniform {
            min: lo,
            max: hi,
            seed,
        } => {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return Err(format!(
                    "polydisperse min = {lo}, max = {hi}: need 0 < min <= max, finite"
                ));
            }
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            Ok((0..n).map(|_| lo + (hi - lo) * rng.gen::<f64>()).collect())
        }
        PolySpec::Lognormal { sigma, seed } => {
            if !(sigma > 0.0 && sigma <= 0.5) {
                return Err(format!("polydisperse sigma = {sigma}: must be in (0, 0.5]"));
            }
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
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
    }
}
