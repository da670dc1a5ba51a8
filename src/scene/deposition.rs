//! Deposition scenes (`kind = "deposition"`): the Monte-Carlo coating-layer model of seed 000.
//! Schema in README ("Deposition scenes"); every table rejects unknown keys by name.

use super::{on_threads, Builtin, RunOptions};
use crate::deposition::energy::EnergyTerms;
use crate::deposition::engine::{deposit, DepositionOutcome, DepositionParams};
use crate::deposition::film::{build, Colour, FilmOptions};
use crate::deposition::grain::Grain;
use crate::deposition::measure::{measure, posed, DepositMeasures, MeasureOptions};
use crate::deposition::Layer;
use crate::error::{invalid, Error, Result};
use crate::io::xyz::{Cell, XyzParticle};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "deposition-spheres",
            about: "Deposition: 400 monodisperse spheres (r = 0.5 um), 65 % solids, 4 runs",
            toml: include_str!("builtin/deposition-spheres.toml"),
        },
        Builtin {
            name: "deposition-platelets",
            about: "Deposition: 600 clay platelets of aspect ratio 4 (oblate), 65 % solids, 4 runs",
            toml: include_str!("builtin/deposition-platelets.toml"),
        },
        Builtin {
            name: "deposition-blend",
            about: "Deposition: clay platelets (aspect 10) and carbonate needles (aspect 4), 50/50 by volume",
            toml: include_str!("builtin/deposition-blend.toml"),
        },
    ]
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    kind: String,
    #[serde(default)]
    title: String,
    #[serde(default = "one_u64")]
    seed: u64,
    #[serde(default = "one_usize")]
    runs: usize,
    film: FilmSpec,
    species: Vec<SpeciesSpec>,
    #[serde(default)]
    deposition: MovesSpec,
    #[serde(default)]
    start: StartSpec,
    #[serde(default)]
    analysis: AnalysisSpec,
}

fn one_u64() -> u64 {
    1
}
fn one_usize() -> usize {
    1
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct FilmSpec {
    /// Total number of particles.
    particles: usize,
    /// Side of the periodic box, m (default: 10 x the longest semi-axis of any particle).
    #[serde(default)]
    box_side_m: Option<f64>,
    solids_percent: f64,
    #[serde(default = "d_pigment")]
    pigment_density_kg_m3: f64,
    #[serde(default = "d_binder")]
    binder_density_kg_m3: f64,
    #[serde(default = "d_pph")]
    binder_pph: f64,
    #[serde(default = "d_water")]
    water_density_kg_m3: f64,
    /// Overrides the binder-solution density.
    #[serde(default)]
    fluid_density_kg_m3: Option<f64>,
}
fn d_pigment() -> f64 {
    2500.0
}
fn d_binder() -> f64 {
    1500.0
}
fn d_pph() -> f64 {
    7.0
}
fn d_water() -> f64 {
    1000.0
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
struct SpeciesSpec {
    name: String,
    /// The three semi-axes; or give `shape`, `aspect_ratio` and `longest_semi_axis_m`.
    #[serde(default)]
    semi_axes_m: Option<[f64; 3]>,
    /// `platelet` (oblate: a, a, a/AR), `needle` (prolate: a, a/AR, a/AR) or `sphere`.
    #[serde(default)]
    shape: Option<String>,
    /// Longest over shortest semi-axis (seed 000's aspect ratio), with `shape`.
    #[serde(default)]
    aspect_ratio: Option<f64>,
    /// The longest semi-axis a, with `shape`.
    #[serde(default)]
    longest_semi_axis_m: Option<f64>,
    /// Or the particle volume, with `shape` (the seed's blends keep it as the aspect ratio
    /// changes).
    #[serde(default)]
    particle_volume_m3: Option<f64>,
    /// Share of the pigment volume (normalised over the species); default 1.
    #[serde(default)]
    volume_ratio: Option<f64>,
    /// Or the share in percent: then every species gives one, but at most one that takes
    /// the rest (100 minus the others).
    #[serde(default)]
    volume_percent: Option<f64>,
    /// Particle density (default: the film's pigment density).
    #[serde(default)]
    density_kg_m3: Option<f64>,
    /// Lognormal size factor (median 1) of this geometric standard deviation's logarithm.
    #[serde(default)]
    lognormal_sigma: Option<f64>,
    /// Size table: [size factor, number fraction] rows.
    #[serde(default)]
    size_table: Option<Vec<[f64; 2]>>,
}

/// The volume ratio of each species: `volume_ratio` [1], or `volume_percent` where at most
/// one species omits it and takes the rest. Err: the message.
fn volume_ratios(species: &[SpeciesSpec]) -> std::result::Result<Vec<f64>, String> {
    if species.iter().all(|s| s.volume_percent.is_none()) {
        return Ok(species
            .iter()
            .map(|s| s.volume_ratio.unwrap_or(1.0))
            .collect());
    }
    if let Some(s) = species.iter().find(|s| s.volume_ratio.is_some()) {
        return Err(format!(
            "species `{}`: volume_ratio with volume_percent in the same scene: use one of them",
            s.name
        ));
    }
    let open: Vec<&SpeciesSpec> = species
        .iter()
        .filter(|s| s.volume_percent.is_none())
        .collect();
    let given: f64 = species.iter().filter_map(|s| s.volume_percent).sum();
    for s in species {
        if let Some(p) = s
            .volume_percent
            .filter(|p| !(p.is_finite() && *p >= 0.0 && *p <= 100.0))
        {
            return Err(format!(
                "species `{}`.volume_percent = {p}: must be in [0, 100]",
                s.name
            ));
        }
    }
    let rest = 100.0 - given;
    match open.len() {
        0 if (rest).abs() <= 1e-9 => {}
        0 => {
            return Err(format!(
                "species volume_percent values sum to {given}, not 100"
            ))
        }
        1 if rest >= -1e-9 => {}
        1 => {
            return Err(format!(
                "species volume_percent values sum to {given}: above 100, nothing is left for \
                 species `{}`",
                open[0].name
            ))
        }
        _ => {
            return Err(format!(
                "species volume_percent: {} species omit it; at most one may (it takes the rest)",
                open.len()
            ))
        }
    }
    Ok(species
        .iter()
        .map(|s| s.volume_percent.unwrap_or(rest.max(0.0)))
        .collect())
}

/// The semi-axes of a species: `semi_axes_m` as given, or built from `shape`, `aspect_ratio`
/// and `longest_semi_axis_m` (seed 000: the aspect ratio is the longest semi-axis over the
/// shortest; platelets keep their diameter, needles their length). Err: the message.
fn species_semi_axes(s: &SpeciesSpec, at: &str) -> std::result::Result<[f64; 3], String> {
    let size = match (s.longest_semi_axis_m, s.particle_volume_m3) {
        (None, None) => None,
        (Some(a), None) => Some(Ok(a)),
        (None, Some(v)) => Some(Err(v)),
        (Some(_), Some(_)) => {
            return Err(format!(
                "{at}: give longest_semi_axis_m or particle_volume_m3, not both"
            ))
        }
    };
    let by_shape = (&s.shape, s.aspect_ratio, size);
    match (s.semi_axes_m, by_shape) {
        (Some(axes), (None, None, None)) => Ok(axes),
        (None, (Some(shape), ar, Some(size))) => {
            let ar = ar.unwrap_or(1.0);
            if !(ar.is_finite() && ar >= 1.0) {
                return Err(format!("{at}.aspect_ratio = {ar}: must be >= 1 and finite"));
            }
            // From the volume 4/3 pi a b c: platelet a^3 / AR, needle a^3 / AR^2.
            let a = match size {
                Ok(a) => a,
                Err(v) if v.is_finite() && v > 0.0 => {
                    let per_ar = match shape.as_str() {
                        "needle" => ar * ar,
                        "platelet" => ar,
                        _ => 1.0,
                    };
                    (3.0 * v * per_ar / (4.0 * std::f64::consts::PI)).cbrt()
                }
                Err(v) => {
                    return Err(format!(
                        "{at}.particle_volume_m3 = {v}: must be positive and finite"
                    ))
                }
            };
            match shape.as_str() {
                "platelet" => Ok([a, a, a / ar]),
                "needle" => Ok([a, a / ar, a / ar]),
                "sphere" if ar == 1.0 => Ok([a, a, a]),
                "sphere" => Err(format!(
                    "{at}.aspect_ratio = {ar}: a sphere has aspect ratio 1"
                )),
                o => Err(format!(
                    "{at}.shape = \"{o}\": one of \"platelet\", \"needle\", \"sphere\""
                )),
            }
        }
        (Some(_), _) => Err(format!(
            "{at}: give either semi_axes_m or shape with aspect_ratio and longest_semi_axis_m \
             (or particle_volume_m3), not both"
        )),
        (None, _) => Err(format!(
            "{at}: give semi_axes_m = [a, b, c], or shape, aspect_ratio and longest_semi_axis_m \
             (or particle_volume_m3)"
        )),
    }
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
struct MovesSpec {
    k_max_m2: f64,
    viscosity_pa_s: f64,
    time_unit_s: f64,
    #[serde(rename = "temperature_K")]
    temperature_k: f64,
    stop_fraction: f64,
    stop_window: u64,
    max_sweeps: u64,
    gravity: bool,
    drag: bool,
    gravity_m_s2: f64,
}
impl Default for MovesSpec {
    fn default() -> Self {
        MovesSpec {
            k_max_m2: 1e-14,
            viscosity_pa_s: 0.01,
            time_unit_s: 1.0,
            temperature_k: 0.0,
            stop_fraction: 1e-3,
            stop_window: 10,
            max_sweeps: 200_000,
            gravity: true,
            drag: true,
            gravity_m_s2: crate::consts::STANDARD_GRAVITY,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
struct StartSpec {
    rsa_limit: f64,
    tries_per_particle: usize,
    max_growth_rounds: usize,
}
impl Default for StartSpec {
    fn default() -> Self {
        StartSpec {
            rsa_limit: 0.30,
            tries_per_particle: 5000,
            max_growth_rounds: 20_000,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
struct AnalysisSpec {
    nodes_per_shortest_semi_axis: f64,
    profile_bins: usize,
    touch_fraction: f64,
}
impl Default for AnalysisSpec {
    fn default() -> Self {
        let m = MeasureOptions::default();
        AnalysisSpec {
            nodes_per_shortest_semi_axis: m.nodes_per_shortest_semi_axis,
            profile_bins: m.profile_bins,
            touch_fraction: m.touch_fraction,
        }
    }
}

/// A parsed, checked deposition scene.
#[derive(Debug, Clone)]
pub struct DepositionScene {
    pub title: String,
    pub seed: u64,
    pub runs: usize,
    pub particles: usize,
    pub box_side_m: f64,
    pub colour: Colour,
    pub phi: f64,
    pub fluid_density_kg_m3: f64,
    pub species: Vec<Species>,
    pub params: DepositionParams,
    pub film: FilmOptions,
    pub measure: MeasureOptions,
    pub gravity_m_s2: f64,
}

/// One species of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Species {
    pub name: String,
    pub semi_axes_m: [f64; 3],
    pub volume_share: f64,
    pub density_kg_m3: f64,
    pub sizes: SizeLaw,
}

/// How a species' size factor (multiplying all semi-axes) is drawn.
#[derive(Debug, Clone, PartialEq)]
pub enum SizeLaw {
    Fixed,
    Lognormal {
        sigma: f64,
    },
    /// (factor, cumulative number fraction).
    Table(Vec<(f64, f64)>),
}

impl SizeLaw {
    fn draw<R: Rng>(&self, rng: &mut R) -> f64 {
        match self {
            SizeLaw::Fixed => 1.0,
            SizeLaw::Lognormal { sigma } => {
                // Box-Muller from two uniforms in (0, 1].
                let u1: f64 = 1.0 - rng.gen::<f64>();
                let u2: f64 = rng.gen::<f64>();
                let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                (sigma * z).exp()
            }
            SizeLaw::Table(rows) => {
                let u: f64 = rng.gen::<f64>();
                rows.iter()
                    .find(|(_, c)| u < *c)
                    .map(|r| r.0)
                    .unwrap_or(rows[rows.len() - 1].0)
            }
        }
    }
    /// Mean of the cubed factor (number-weighted volume factor).
    fn mean_cube(&self) -> f64 {
        match self {
            SizeLaw::Fixed => 1.0,
            SizeLaw::Lognormal { sigma } => (4.5 * sigma * sigma).exp(),
            SizeLaw::Table(rows) => {
                let mut prev = 0.0;
                rows.iter()
                    .map(|(f, c)| {
                        let w = c - prev;
                        prev = *c;
                        w * f * f * f
                    })
                    .sum()
            }
        }
    }
}

/// Parses and checks a deposition scene; `origin` names the file in errors.
pub fn parse_scene(text: &str, origin: &str) -> Result<DepositionScene> {
    let f: SceneFile = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("deposition scene: {e}"),
    })?;
    let bad = |msg: String| invalid::<DepositionScene>(format!("{origin}: {msg}"));
    if f.kind != "deposition" {
        return bad(format!(
            "kind = \"{}\": a deposition scene needs kind = \"deposition\"",
            f.kind
        ));
    }
    if f.runs == 0 || f.runs > 100_000 {
        return bad(format!("runs = {}: must be 1 to 100000", f.runs));
    }
    let fs = &f.film;
    if fs.particles == 0 || fs.particles > 5_000_000 {
        return bad(format!(
            "film.particles = {}: must be 1 to 5000000 (about 400 bytes each)",
            fs.particles
        ));
    }
    if !(fs.solids_percent > 0.0 && fs.solids_percent < 100.0) {
        return bad(format!(
            "film.solids_percent = {}: must be in (0, 100)",
            fs.solids_percent
        ));
    }
    let colour = Colour {
        solids_mass_fraction: fs.solids_percent / 100.0,
        pigment_density_kg_m3: fs.pigment_density_kg_m3,
        binder_density_kg_m3: fs.binder_density_kg_m3,
        binder_pph: fs.binder_pph,
        water_density_kg_m3: fs.water_density_kg_m3,
    };
    let phi = colour
        .pigment_volume_fraction()
        .map_err(|e| Error::InvalidInput(format!("{origin}: film: {e}")))?;
    let fluid_density = match fs.fluid_density_kg_m3 {
        Some(v) if v.is_finite() && v >= 0.0 => v,
        Some(v) => {
            return bad(format!(
                "film.fluid_density_kg_m3 = {v}: must be >= 0 and finite"
            ))
        }
        None => colour
            .fluid_density_kg_m3()
            .map_err(|e| Error::InvalidInput(format!("{origin}: film: {e}")))?,
    };
    if f.species.is_empty() {
        return bad("no [[species]]: give at least one".into());
    }
    let ratios = match volume_ratios(&f.species) {
        Ok(r) => r,
        Err(e) => return bad(e),
    };
    let total_ratio: f64 = ratios.iter().sum();
    let mut species = Vec::new();
    for (k, s) in f.species.iter().enumerate() {
        let at = format!("species[{k}] (`{}`)", s.name);
        if s.name.is_empty() || s.name.contains(char::is_whitespace) {
            return bad(format!("{at}.name: must be non-empty without whitespace"));
        }
        let semi_axes_m = match species_semi_axes(s, &at) {
            Ok(axes) => axes,
            Err(e) => return bad(e),
        };
        for (i, &a) in semi_axes_m.iter().enumerate() {
            if !(a.is_finite() && a > 0.0 && a < 1e-2) {
                return bad(format!(
                    "{at}.semi_axes_m[{i}] = {a}: must be positive and below 1 cm"
                ));
            }
        }
        let mx = semi_axes_m.iter().cloned().fold(0.0, f64::max);
        let mn = semi_axes_m.iter().cloned().fold(f64::INFINITY, f64::min);
        if mx / mn > 100.0 {
            return bad(format!(
                "{at}.semi_axes_m: aspect ratio {}: at most 100",
                mx / mn
            ));
        }
        if !(ratios[k].is_finite() && ratios[k] >= 0.0) {
            return bad(format!(
                "{at}.volume_ratio = {}: must be >= 0 and finite",
                ratios[k]
            ));
        }
        let density = s.density_kg_m3.unwrap_or(fs.pigment_density_kg_m3);
        if !(density.is_finite() && density > 0.0) {
            return bad(format!(
                "{at}.density_kg_m3 = {density}: must be positive and finite"
            ));
        }
        let sizes = match (s.lognormal_sigma, &s.size_table) {
            (Some(_), Some(_)) => {
                return bad(format!(
                    "{at}: give lognormal_sigma or size_table, not both"
                ))
            }
            (Some(sig), None) => {
                if !(0.0..=1.0).contains(&sig) {
                    return bad(format!("{at}.lognormal_sigma = {sig}: must be in [0, 1]"));
                }
                SizeLaw::Lognormal { sigma: sig }
            }
            (None, Some(rows)) => {
                if rows.is_empty() {
                    return bad(format!("{at}.size_table: empty"));
                }
                let sum: f64 = rows.iter().map(|r| r[1]).sum();
                let mut c = 0.0;
                let mut cum = Vec::new();
                for (i, r) in rows.iter().enumerate() {
                    if !(r[0].is_finite()
                        && r[0] > 0.0
                        && r[0] <= 10.0
                        && r[1] >= 0.0
                        && r[1].is_finite())
                    {
                        return bad(format!(
                            "{at}.size_table[{i}] = [{}, {}]: factor in (0, 10], fraction >= 0",
                            r[0], r[1]
                        ));
                    }
                    c += r[1] / sum;
                    cum.push((r[0], c));
                }
                if sum.is_nan() || sum <= 0.0 {
                    return bad(format!("{at}.size_table: fractions sum to 0"));
                }
                SizeLaw::Table(cum)
            }
            (None, None) => SizeLaw::Fixed,
        };
        species.push(Species {
            name: s.name.clone(),
            semi_axes_m,
            volume_share: ratios[k] / total_ratio,
            density_kg_m3: density,
            sizes,
        });
    }
    if total_ratio.is_nan() || total_ratio <= 0.0 {
        return bad("species volume ratios sum to 0".into());
    }
    let longest = species
        .iter()
        .map(|s| s.semi_axes_m.iter().cloned().fold(0.0, f64::max))
        .fold(0.0, f64::max);
    let box_side_m = match fs.box_side_m {
        None => 10.0 * longest,
        Some(l) if l.is_finite() && l > 0.0 => l,
        Some(l) => {
            return bad(format!(
                "film.box_side_m = {l}: must be positive and finite"
            ))
        }
    };
    let m = &f.deposition;
    if !(m.gravity_m_s2.is_finite() && m.gravity_m_s2 >= 0.0) {
        return bad(format!(
            "deposition.gravity_m_s2 = {}: must be >= 0 and finite",
            m.gravity_m_s2
        ));
    }
    if !(m.temperature_k.is_finite() && m.temperature_k >= 0.0) {
        return bad(format!(
            "deposition.temperature_K = {}: must be >= 0 and finite",
            m.temperature_k
        ));
    }
    let params = DepositionParams {
        k_max_m2: m.k_max_m2,
        energy: EnergyTerms {
            gravity: m.gravity,
            drag: m.drag,
            viscosity_pa_s: m.viscosity_pa_s,
        },
        time_unit_s: m.time_unit_s,
        kt_j: crate::consts::KB * m.temperature_k,
        stop_fraction: m.stop_fraction,
        stop_window: m.stop_window,
        max_sweeps: m.max_sweeps,
    };
    params
        .check()
        .map_err(|e| Error::InvalidInput(format!("{origin}: deposition: {e}")))?;
    if m.k_max_m2.sqrt() > longest {
        return bad(format!(
            "deposition.k_max_m2 = {}: a move of up to {} m exceeds the largest particle \
             semi-axis {longest} m",
            m.k_max_m2,
            m.k_max_m2.sqrt()
        ));
    }
    let st = &f.start;
    if !(st.rsa_limit > 0.0 && st.rsa_limit <= 0.38) {
        return bad(format!(
            "start.rsa_limit = {}: must be in (0, 0.38]",
            st.rsa_limit
        ));
    }
    if st.tries_per_particle == 0 || st.max_growth_rounds == 0 {
        return bad("start.tries_per_particle and start.max_growth_rounds: must be >= 1".into());
    }
    let an = &f.analysis;
    if !(an.nodes_per_shortest_semi_axis >= 5.0 && an.nodes_per_shortest_semi_axis <= 100.0) {
        return bad(format!(
            "analysis.nodes_per_shortest_semi_axis = {}: must be in [5, 100]",
            an.nodes_per_shortest_semi_axis
        ));
    }
    if an.profile_bins == 0 || an.profile_bins > 100_000 {
        return bad(format!(
            "analysis.profile_bins = {}: must be 1 to 100000",
            an.profile_bins
        ));
    }
    if !(an.touch_fraction > 0.0 && an.touch_fraction < 1.0) {
        return bad(format!(
            "analysis.touch_fraction = {}: must be in (0, 1)",
            an.touch_fraction
        ));
    }
    Ok(DepositionScene {
        title: f.title.clone(),
        seed: f.seed,
        runs: f.runs,
        particles: fs.particles,
        box_side_m,
        colour,
        phi,
        fluid_density_kg_m3: fluid_density,
        species,
        params,
        film: FilmOptions {
            rsa_limit: st.rsa_limit,
            tries_per_particle: st.tries_per_particle,
            max_growth_rounds: st.max_growth_rounds,
            k_max_m2: m.k_max_m2,
        },
        measure: MeasureOptions {
            nodes_per_shortest_semi_axis: an.nodes_per_shortest_semi_axis,
            profile_bins: an.profile_bins,
            touch_fraction: an.touch_fraction,
        },
        gravity_m_s2: m.gravity_m_s2,
    })
}

/// The seed of run `k` of a scene seeded `seed` (SplitMix64 of the pair: independent streams).
pub fn run_seed(seed: u64, k: usize) -> u64 {
    let mut z = seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl DepositionScene {
    /// Particle counts per species: shares of the pigment volume over mean particle volumes,
    /// rounded so that they sum to the film's count.
    pub fn counts(&self) -> Vec<usize> {
        let weights: Vec<f64> = self
            .species
            .iter()
            .map(|s| {
                let v = s.semi_axes_m.iter().product::<f64>() * s.sizes.mean_cube();
                s.volume_share / v
            })
            .collect();
        let total: f64 = weights.iter().sum();
        let mut counts: Vec<usize> = weights
            .iter()
            .map(|w| (w / total * self.particles as f64).floor() as usize)
            .collect();
        // Largest remainders take the rest.
        let mut rem: Vec<(f64, usize)> = weights
            .iter()
            .enumerate()
            .map(|(k, w)| (w / total * self.particles as f64 - counts[k] as f64, k))
            .collect();
        rem.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
        let missing = self.particles - counts.iter().sum::<usize>();
        for &(_, k) in rem.iter().take(missing) {
            counts[k] += 1;
        }
        counts
    }

    /// The grains of one run (sizes drawn from `rng`).
    pub fn grains<R: Rng>(&self, rng: &mut R) -> Result<Vec<Grain>> {
        let mut out = Vec::with_capacity(self.particles);
        for (k, (s, n)) in self.species.iter().zip(self.counts()).enumerate() {
            for _ in 0..n {
                let f = s.sizes.draw(rng);
                out.push(Grain::new(
                    s.semi_axes_m.map(|a| a * f),
                    k,
                    s.density_kg_m3,
                    self.fluid_density_kg_m3,
                    self.gravity_m_s2,
                )?);
            }
        }
        Ok(out)
    }

    /// The active terms, as printed before a run and stored in the summary.
    pub fn active_terms(&self) -> Vec<String> {
        let mut t = vec!["hard core".to_string()];
        let any_aspherical = self
            .species
            .iter()
            .any(|s| s.semi_axes_m.iter().any(|&a| a != s.semi_axes_m[0]));
        if self.params.energy.gravity && self.gravity_m_s2 > 0.0 {
            t.push("buoyant gravity".into());
        }
        if self.params.energy.drag {
            t.push("drag potential (eq. A2-A3)".into());
        }
        if any_aspherical {
            t.push("rotations (eq. A16d-f)".into());
            t.push("Perram-Wertheim overlap".into());
        } else {
            t.push("sphere overlap in closed form (no rotation)".into());
        }
        if self.params.kt_j > 0.0 {
            t.push("Metropolis at T > 0".into());
        }
        t
    }

    /// One run: the start, the deposit and its measures.
    pub fn run_one(&self, k: usize, progress: impl FnMut(u64, f64, f64)) -> Result<RunResult> {
        let t0 = Instant::now();
        let mut rng = ChaCha8Rng::seed_from_u64(run_seed(self.seed, k));
        let grains = self.grains(&mut rng)?;
        let mut layer = build(grains, self.box_side_m, self.phi, &self.film, &mut rng)?;
        let start_seconds = t0.elapsed().as_secs_f64();
        let outcome = deposit(&mut layer, &self.params, &mut rng, progress)?;
        let measures = measure(&layer, self.species.len(), &self.measure)?;
        Ok(RunResult {
            run: k,
            layer,
            outcome,
            measures,
            start_seconds,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

/// The result of one run.
pub struct RunResult {
    pub run: usize,
    pub layer: Layer,
    pub outcome: DepositionOutcome,
    pub measures: DepositMeasures,
    pub start_seconds: f64,
    pub seconds: f64,
}

/// Mean and standard error of a sample (None for an empty one; stderr None below 2 values).
fn mean_se(v: &[f64]) -> (Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (None, None);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (Some(m), None);
    }
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (Some(m), Some((var / n).sqrt()))
}

pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let scene = parse_scene(text, origin)?;
    on_threads(opts.threads, || run_parsed(&scene, origin, out, opts))
}

fn run_parsed(scene: &DepositionScene, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    if !opts.quiet {
        let counts = scene.counts();
        let sp: Vec<String> = scene
            .species
            .iter()
            .zip(&counts)
            .map(|(s, n)| format!("{n} x {} {:?} m", s.name, s.semi_axes_m))
            .collect();
        eprintln!(
            "deposition: {}; box {:.4e} m, {} % solids -> pigment fraction {:.4}, fluid {:.1} \
             kg/m^3; K_max {:e} m^2; {} runs, seed {}",
            sp.join(" + "),
            scene.box_side_m,
            scene.colour.solids_mass_fraction * 100.0,
            scene.phi,
            scene.fluid_density_kg_m3,
            scene.params.k_max_m2,
            scene.runs,
            scene.seed
        );
        eprintln!("active terms: {}", scene.active_terms().join(", "));
    }
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(scene.runs as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("[{elapsed_precise}] runs {pos}/{len} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    };
    let t0 = Instant::now();
    let results: Vec<Result<RunResult>> = (0..scene.runs)
        .into_par_iter()
        .map(|k| {
            let r = scene.run_one(k, |sweep, d, stop| {
                if k == 0 && sweep % 50 == 0 {
                    bar.set_message(format!(
                        "(run 0: sweep {sweep}, mean displacement {d:.3e} m, stop below {stop:.3e} m)"
                    ));
                }
            });
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let results: Vec<RunResult> = results.into_iter().collect::<Result<_>>()?;
    write_outputs(scene, origin, out, &results, t0.elapsed().as_secs_f64())?;
    let ens = ensemble(&results);
    let core = ens.iter().find(|r| r.0 == "core_porosity");
    println!(
        "deposition: {} runs in {:.1} s; layer porosity {}; core porosity {}; outputs in {}",
        results.len(),
        t0.elapsed().as_secs_f64(),
        fmt_mean(ens.iter().find(|r| r.0 == "layer_porosity")),
        fmt_mean(core),
        out.display()
    );
    Ok(())
}

fn fmt_mean(r: Option<&(String, Option<f64>, Option<f64>, usize)>) -> String {
    match r {
        Some((_, Some(m), Some(se), _)) => format!("{m:.4} +- {se:.4}"),
        Some((_, Some(m), None, _)) => format!("{m:.4}"),
        _ => "n/a (layer too thin)".into(),
    }
}

/// Scalars per run, by name (None where not defined).
fn scalars(r: &RunResult) -> Vec<(String, Option<f64>)> {
    let m = &r.measures;
    let mut v = vec![
        ("layer_porosity".to_string(), Some(m.layer_porosity)),
        ("core_porosity".to_string(), m.core_porosity),
        ("rms_roughness_m".to_string(), Some(m.rms_roughness_m)),
        (
            "surface_mean_height_m".to_string(),
            Some(m.surface_mean_height_m),
        ),
        (
            "first_layer_coverage".to_string(),
            Some(m.first_layer_coverage),
        ),
        ("sweeps".to_string(), Some(r.outcome.sweeps as f64)),
        (
            "acceptance".to_string(),
            Some(r.outcome.accepted as f64 / r.outcome.moves.max(1) as f64),
        ),
        ("seconds".to_string(), Some(r.seconds)),
    ];
    for (k, o) in m.order_by_species.iter().enumerate() {
        v.push((format!("order_species{k}"), *o));
    }
    v
}

/// (name, mean, standard error, count) over the runs.
fn ensemble(results: &[RunResult]) -> Vec<(String, Option<f64>, Option<f64>, usize)> {
    let per: Vec<_> = results.iter().map(scalars).collect();
    (0..per[0].len())
        .map(|i| {
            let vals: Vec<f64> = per.iter().filter_map(|s| s[i].1).collect();
            let (m, se) = mean_se(&vals);
            (per[0][i].0.clone(), m, se, vals.len())
        })
        .collect()
}

#[derive(Serialize)]
struct RunSummary<'a> {
    run: usize,
    seed: u64,
    particles: usize,
    measures: &'a DepositMeasures,
    sweeps: u64,
    moves: u64,
    accepted: u64,
    converged: bool,
    first_displacement_m: f64,
    prefilters: crate::deposition::overlap::PrefilterCounts,
    start_seconds: f64,
    seconds: f64,
}

fn write_outputs(
    scene: &DepositionScene,
    origin: &str,
    out: &Path,
    results: &[RunResult],
    seconds: f64,
) -> Result<()> {
    use crate::io::plot::CsvPlot;
    use crate::io::write_atomic;
    let names: Vec<&str> = scene.species.iter().map(|s| s.name.as_str()).collect();
    let mut runs_csv = String::new();
    let header: Vec<String> = scalars(&results[0]).into_iter().map(|(n, _)| n).collect();
    let _ = writeln!(runs_csv, "run,{}", header.join(","));
    let mut profiles_csv = String::from("run,z_mid_m,porosity\n");
    for r in results {
        let dir = out.join(format!("run-{:03}", r.run));
        let top = r
            .layer
            .poses
            .iter()
            .map(|p| p.position.z)
            .fold(r.layer.film_height_m, f64::max)
            + r.layer.reach_m();
        let cell = Cell {
            lengths: [scene.box_side_m, scene.box_side_m, top],
            origin: [0.0; 3],
            pbc: [true, true, false],
        };
        let parts: Vec<XyzParticle> = posed(&r.layer)
            .iter()
            .zip(&r.layer.grains)
            .map(|(p, g)| XyzParticle {
                species: names[g.species].to_string(),
                position: p.position,
                orientation: p.orientation,
                aspherical_shape: p.semi_axes,
                radius: g.outer_radius_m,
                cylinder_length: 0.0,
                roundness: [1.0, 1.0],
            })
            .collect();
        crate::io::xyz::write(
            &dir.join("final.xyz"),
            &cell,
            &parts,
            &[("units", "m".into())],
        )?;
        let mut prof = String::from("z_low_m,z_high_m,porosity\n");
        for b in &r.measures.profile {
            let _ = writeln!(prof, "{},{},{}", b.z_low_m, b.z_high_m, b.porosity);
            let z_mid_m = 0.5 * (b.z_low_m + b.z_high_m);
            let _ = writeln!(profiles_csv, "{},{z_mid_m},{}", r.run, b.porosity);
        }
        write_atomic(&dir.join("porosity_profile.csv"), prof.as_bytes())?;
        let mut hist = String::from("sweep,mean_displacement_m,acceptance,drainage_speed_m_s\n");
        for h in &r.outcome.history {
            let _ = writeln!(
                hist,
                "{},{},{},{}",
                h.sweep, h.mean_displacement_m, h.acceptance, h.drainage_speed_m_s
            );
        }
        write_atomic(&dir.join("history.csv"), hist.as_bytes())?;
        let s = RunSummary {
            run: r.run,
            seed: run_seed(scene.seed, r.run),
            particles: r.layer.grains.len(),
            measures: &r.measures,
            sweeps: r.outcome.sweeps,
            moves: r.outcome.moves,
            accepted: r.outcome.accepted,
            converged: r.outcome.converged,
            first_displacement_m: r.outcome.first_displacement_m,
            prefilters: r.outcome.prefilters,
            start_seconds: r.start_seconds,
            seconds: r.seconds,
        };
        write_atomic(
            &dir.join("summary.json"),
            serde_json::to_string_pretty(&s)
                .map_err(|e| Error::Validation(e.to_string()))?
                .as_bytes(),
        )?;
        let vals: Vec<String> = scalars(r)
            .into_iter()
            .map(|(_, v)| v.map(|x| x.to_string()).unwrap_or_default())
            .collect();
        let _ = writeln!(runs_csv, "{},{}", r.run, vals.join(","));
    }
    write_atomic(&out.join("runs.csv"), runs_csv.as_bytes())?;
    CsvPlot {
        title: "Porosity profile of the deposit (exact slab volumes), one curve per run",
        x: "z_mid_m",
        y: "porosity",
        group_by: &["run"],
        x_label: "height above the substrate (m)",
        y_label: "porosity",
        ..Default::default()
    }
    .write_or_warn(&out.join("porosity_profile.svg"), &profiles_csv);
    let ens = ensemble(results);
    let mut ens_csv = String::from("quantity,mean,standard_error,runs\n");
    for (n, m, se, c) in &ens {
        let f = |x: &Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
        let _ = writeln!(ens_csv, "{n},{},{},{c}", f(m), f(se));
    }
    write_atomic(&out.join("ensemble.csv"), ens_csv.as_bytes())?;
    let summary = serde_json::json!({
        "scene": origin,
        "title": scene.title,
        "porelab_version": env!("CARGO_PKG_VERSION"),
        "threads": rayon::current_num_threads(),
        "runs": results.len(),
        "particles": scene.particles,
        "box_side_m": scene.box_side_m,
        "pigment_volume_fraction_start": scene.phi,
        "fluid_density_kg_m3": scene.fluid_density_kg_m3,
        "species": names,
        "active_terms": scene.active_terms(),
        "converged_runs": results.iter().filter(|r| r.outcome.converged).count(),
        "ensemble": ens.iter().map(|(n, m, se, c)| serde_json::json!({
            "quantity": n, "mean": m, "standard_error": se, "runs": c})).collect::<Vec<_>>(),
        // The same means by name, as scalars that `porelab sweep collect` averages over jobs.
        "ensemble_mean": ens.iter().map(|(n, m, _, _)| (n.clone(), serde_json::json!(m)))
            .collect::<serde_json::Map<_, _>>(),
        "seconds": seconds,
    });
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .map_err(|e| Error::Validation(e.to_string()))?
            .as_bytes(),
    )?;
    Ok(())
}

/// `kind = "deposition"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "deposition"
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
    use super::parse_scene;

    fn scene(species: &str) -> crate::Result<super::DepositionScene> {
        parse_scene(
            &format!(
                "kind = \"deposition\"\n[film]\nparticles = 100\nsolids_percent = 60\n{species}"
            ),
            "test",
        )
    }

    /// Shape and aspect ratio give the semi-axes of seed 000: platelets keep the diameter,
    /// needles the length; a particle volume fixes a = (3 V AR^k / (4 pi))^(1/3).
    #[test]
    fn species_by_shape_aspect_ratio_and_volume() {
        let s = scene(
            "[[species]]\nname = \"c\"\nshape = \"platelet\"\naspect_ratio = 4\n\
             longest_semi_axis_m = 0.5e-6\n\
             [[species]]\nname = \"n\"\nshape = \"needle\"\naspect_ratio = 4\n\
             longest_semi_axis_m = 0.5e-6\n",
        )
        .unwrap();
        assert_eq!(s.species[0].semi_axes_m, [0.5e-6, 0.5e-6, 0.125e-6]);
        assert_eq!(s.species[1].semi_axes_m, [0.5e-6, 0.125e-6, 0.125e-6]);
        // A needle of aspect 4 with the volume 4/3 pi (0.5)(0.125)^2 um^3 has a = 0.5 um.
        let v = 4.0 / 3.0 * std::f64::consts::PI * 0.5e-6 * 0.125e-6 * 0.125e-6;
        let s = scene(&format!(
            "[[species]]\nname = \"n\"\nshape = \"needle\"\naspect_ratio = 4\n\
             particle_volume_m3 = {v:e}\n"
        ))
        .unwrap();
        let a = s.species[0].semi_axes_m;
        assert!(
            (a[0] - 0.5e-6).abs() < 1e-21 && (a[1] - 0.125e-6).abs() < 1e-21,
            "{a:?}"
        );
    }

    #[test]
    fn species_shape_errors_name_the_key() {
        let e = |sp: &str| scene(sp).unwrap_err().to_string();
        assert!(
            e("[[species]]\nname = \"p\"\nshape = \"cube\"\nlongest_semi_axis_m = 1e-6\n")
                .contains("shape = \"cube\"")
        );
        assert!(e(
            "[[species]]\nname = \"p\"\nshape = \"platelet\"\naspect_ratio = 0.5\n\
                   longest_semi_axis_m = 1e-6\n"
        )
        .contains("aspect_ratio = 0.5"));
        assert!(e(
            "[[species]]\nname = \"p\"\nsemi_axes_m = [1e-6, 1e-6, 1e-6]\n\
                   shape = \"sphere\"\nlongest_semi_axis_m = 1e-6\n"
        )
        .contains("not both"));
        assert!(e(
            "[[species]]\nname = \"p\"\nshape = \"sphere\"\nlongest_semi_axis_m = 1e-6\n\
                   particle_volume_m3 = 1e-18\n"
        )
        .contains("not both"));
        assert!(e("[[species]]\nname = \"p\"\n").contains("semi_axes_m = [a, b, c]"));
    }

    /// volume_percent: the species without one takes the rest; sums are checked.
    #[test]
    fn volume_percent_takes_the_rest() {
        let sp = |p: &str| {
            format!(
                "[[species]]\nname = \"a\"\nsemi_axes_m = [1e-6, 1e-6, 1e-6]\n{p}\n\
                 [[species]]\nname = \"b\"\nsemi_axes_m = [1e-6, 1e-6, 0.5e-6]\n"
            )
        };
        let s = scene(&sp("volume_percent = 30")).unwrap();
        assert!((s.species[0].volume_share - 0.3).abs() < 1e-15);
        assert!((s.species[1].volume_share - 0.7).abs() < 1e-15);
        let e = scene(&sp("volume_percent = 130")).unwrap_err().to_string();
        assert!(e.contains("volume_percent = 130"), "{e}");
        let e = scene(&sp("volume_percent = 30\nvolume_ratio = 2"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("volume_ratio with volume_percent"), "{e}");
    }
}
