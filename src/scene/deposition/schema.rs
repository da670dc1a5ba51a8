//! The deposition scene file: a serde mirror of [`deposition::Setup`] (unknown keys refused
//! by name, species shapes as an enum) and its conversion into a [`DepositionScene`], with
//! errors that name the file, the key, the value and the rule.

use crate::deposition::energy::EnergyTerms;
use crate::deposition::film::{Colour, FilmOptions};
use crate::deposition::measure::MeasureOptions;
use crate::deposition::{Moves, Setup, SizeLaw, Species, StopRule};
use crate::error::{Error, Result};
use crate::scene::keys::parse_renamed;
use serde::{Deserialize, Serialize};

/// A parsed, checked deposition scene: its runs of the engine's setup, and what is measured.
#[derive(Debug, Clone)]
pub struct DepositionScene {
    pub title: String,
    pub runs: usize,
    /// The pigment volume fraction of the wet film (from the setup's colour).
    pub phi: f64,
    pub setup: Setup,
    pub measure: MeasureOptions,
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
    shape: Option<SpeciesShape>,
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

/// `species.shape`: how the semi-axes follow from the aspect ratio AR and the longest one a.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum SpeciesShape {
    /// Oblate: a, a, a/AR (keeps its diameter as AR changes).
    Platelet,
    /// Prolate: a, a/AR, a/AR (keeps its length).
    Needle,
    /// a, a, a (AR = 1).
    Sphere,
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
    let by_shape = (s.shape, s.aspect_ratio, size);
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
                    let per_ar = match shape {
                        SpeciesShape::Needle => ar * ar,
                        SpeciesShape::Platelet => ar,
                        SpeciesShape::Sphere => 1.0,
                    };
                    (3.0 * v * per_ar / (4.0 * std::f64::consts::PI)).cbrt()
                }
                Err(v) => {
                    return Err(format!(
                        "{at}.particle_volume_m3 = {v}: must be positive and finite"
                    ))
                }
            };
            match shape {
                SpeciesShape::Platelet => Ok([a, a, a / ar]),
                SpeciesShape::Needle => Ok([a, a / ar, a / ar]),
                SpeciesShape::Sphere if ar == 1.0 => Ok([a, a, a]),
                SpeciesShape::Sphere => Err(format!(
                    "{at}.aspect_ratio = {ar}: a sphere has aspect ratio 1"
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
    stop_supported_fraction: Option<f64>,
    stop_accepted_rate: Option<f64>,
    isotropic_directions: bool,
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
            stop_supported_fraction: None,
            stop_accepted_rate: None,
            isotropic_directions: false,
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

/// Parses and checks a deposition scene; `origin` names the file in errors.
pub fn parse_scene(text: &str, origin: &str) -> Result<DepositionScene> {
    let f: SceneFile = parse_renamed(text, origin).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("deposition scene: {e}"),
    })?;
    f.scene()
        .map_err(|msg| Error::InvalidInput(format!("{origin}: {msg}")))
}

/// Err: the message (key, value, rule), without the file's name.
type Checked<T> = std::result::Result<T, String>;

impl SceneFile {
    /// The checked scene of the parsed file.
    fn scene(&self) -> Checked<DepositionScene> {
        if self.kind != "deposition" {
            return Err(format!(
                "kind = \"{}\": a deposition scene needs kind = \"deposition\"",
                self.kind
            ));
        }
        if self.runs == 0 || self.runs > 100_000 {
            return Err(format!("runs = {}: must be 1 to 100000", self.runs));
        }
        let (colour, phi, fluid_density) = self.film.colour()?;
        let species = species_table(&self.species, self.film.pigment_density_kg_m3)?;
        let longest = species
            .iter()
            .map(|s| s.semi_axes_m.iter().cloned().fold(0.0, f64::max))
            .fold(0.0, f64::max);
        let box_side_m = match self.film.box_side_m {
            None => 10.0 * longest,
            Some(l) if l.is_finite() && l > 0.0 => l,
            Some(l) => {
                return Err(format!(
                    "film.box_side_m = {l}: must be positive and finite"
                ))
            }
        };
        let m = &self.deposition;
        let (moves, stop) = m.moves_and_stop()?;
        if m.k_max_m2.sqrt() > longest {
            return Err(format!(
                "deposition.k_max_m2 = {}: a move of up to {} m exceeds the largest particle \
                 semi-axis {longest} m",
                m.k_max_m2,
                m.k_max_m2.sqrt()
            ));
        }
        let setup = Setup {
            particles: self.film.particles,
            box_side_m,
            colour,
            fluid_density_kg_m3: fluid_density,
            gravity_m_s2: m.gravity_m_s2,
            species,
            start: self.start.options(m.k_max_m2)?,
            moves,
            stop,
            seed: self.seed,
        };
        let measure = self.analysis.options()?;
        setup.check().map_err(|e| e.to_string())?;
        Ok(DepositionScene {
            title: self.title.clone(),
            runs: self.runs,
            phi,
            setup,
            measure,
        })
    }
}

impl FilmSpec {
    /// The colour of `[film]`, its pigment volume fraction and the fluid's density (kg/m^3).
    fn colour(&self) -> Checked<(Colour, f64, f64)> {
        if self.particles == 0 || self.particles > 5_000_000 {
            return Err(format!(
                "film.particles = {}: must be 1 to 5000000 (about 400 bytes each)",
                self.particles
            ));
        }
        if !(self.solids_percent > 0.0 && self.solids_percent < 100.0) {
            return Err(format!(
                "film.solids_percent = {}: must be in (0, 100)",
                self.solids_percent
            ));
        }
        let colour = Colour {
            solids_mass_fraction: self.solids_percent / 100.0,
            pigment_density_kg_m3: self.pigment_density_kg_m3,
            binder_density_kg_m3: self.binder_density_kg_m3,
            binder_pph: self.binder_pph,
            water_density_kg_m3: self.water_density_kg_m3,
        };
        let film = |e: Error| format!("film: {e}");
        let phi = colour.pigment_volume_fraction().map_err(film)?;
        let fluid_density = match self.fluid_density_kg_m3 {
            Some(v) if v.is_finite() && v >= 0.0 => v,
            Some(v) => {
                return Err(format!(
                    "film.fluid_density_kg_m3 = {v}: must be >= 0 and finite"
                ))
            }
            None => colour.fluid_density_kg_m3().map_err(film)?,
        };
        Ok((colour, phi, fluid_density))
    }
}

/// The species of `[[species]]`, their volume shares normalised; a species without a density
/// has the pigment's, `pigment_density_kg_m3`.
fn species_table(specs: &[SpeciesSpec], pigment_density_kg_m3: f64) -> Checked<Vec<Species>> {
    if specs.is_empty() {
        return Err("no [[species]]: give at least one".into());
    }
    let ratios = volume_ratios(specs)?;
    let total_ratio: f64 = ratios.iter().sum();
    let mut species = Vec::new();
    for (k, s) in specs.iter().enumerate() {
        let at = format!("species[{k}] (`{}`)", s.name);
        if s.name.is_empty() || s.name.contains(char::is_whitespace) {
            return Err(format!("{at}.name: must be non-empty without whitespace"));
        }
        let semi_axes_m = species_semi_axes(s, &at)?;
        for (i, &a) in semi_axes_m.iter().enumerate() {
            if !(a.is_finite() && a > 0.0 && a < 1e-2) {
                return Err(format!(
                    "{at}.semi_axes_m[{i}] = {a}: must be positive and below 1 cm"
                ));
            }
        }
        let mx = semi_axes_m.iter().cloned().fold(0.0, f64::max);
        let mn = semi_axes_m.iter().cloned().fold(f64::INFINITY, f64::min);
        if mx / mn > 100.0 {
            return Err(format!(
                "{at}.semi_axes_m: aspect ratio {}: at most 100",
                mx / mn
            ));
        }
        if !(ratios[k].is_finite() && ratios[k] >= 0.0) {
            return Err(format!(
                "{at}.volume_ratio = {}: must be >= 0 and finite",
                ratios[k]
            ));
        }
        let density = s.density_kg_m3.unwrap_or(pigment_density_kg_m3);
        if !(density.is_finite() && density > 0.0) {
            return Err(format!(
                "{at}.density_kg_m3 = {density}: must be positive and finite"
            ));
        }
        species.push(Species {
            name: s.name.clone(),
            semi_axes_m,
            volume_share: ratios[k] / total_ratio,
            density_kg_m3: density,
            sizes: s.size_law(&at)?,
        });
    }
    if total_ratio.is_nan() || total_ratio <= 0.0 {
        return Err("species volume ratios sum to 0".into());
    }
    Ok(species)
}

impl SpeciesSpec {
    /// The size law of the species (`at` names it in errors).
    fn size_law(&self, at: &str) -> Checked<SizeLaw> {
        Ok(match (self.lognormal_sigma, &self.size_table) {
            (Some(_), Some(_)) => {
                return Err(format!(
                    "{at}: give lognormal_sigma or size_table, not both"
                ))
            }
            (Some(sig), None) => {
                if !(0.0..=1.0).contains(&sig) {
                    return Err(format!("{at}.lognormal_sigma = {sig}: must be in [0, 1]"));
                }
                SizeLaw::Lognormal { sigma: sig }
            }
            (None, Some(rows)) => {
                if rows.is_empty() {
                    return Err(format!("{at}.size_table: empty"));
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
                        return Err(format!(
                            "{at}.size_table[{i}] = [{}, {}]: factor in (0, 10], fraction >= 0",
                            r[0], r[1]
                        ));
                    }
                    c += r[1] / sum;
                    cum.push((r[0], c));
                }
                if sum.is_nan() || sum <= 0.0 {
                    return Err(format!("{at}.size_table: fractions sum to 0"));
                }
                SizeLaw::Table(cum)
            }
            (None, None) => SizeLaw::Fixed,
        })
    }
}

impl MovesSpec {
    /// The moves and the stop rule of `[deposition]`.
    fn moves_and_stop(&self) -> Checked<(Moves, StopRule)> {
        if !(self.gravity_m_s2.is_finite() && self.gravity_m_s2 >= 0.0) {
            return Err(format!(
                "deposition.gravity_m_s2 = {}: must be >= 0 and finite",
                self.gravity_m_s2
            ));
        }
        if !(self.temperature_k.is_finite() && self.temperature_k >= 0.0) {
            return Err(format!(
                "deposition.temperature_K = {}: must be >= 0 and finite",
                self.temperature_k
            ));
        }
        let moves = Moves {
            k_max_m2: self.k_max_m2,
            energy: EnergyTerms {
                gravity: self.gravity,
                drag: self.drag,
                viscosity_pa_s: self.viscosity_pa_s,
            },
            time_unit_s: self.time_unit_s,
            kt_j: crate::consts::KB * self.temperature_k,
            isotropic_directions: self.isotropic_directions,
        };
        let stop = StopRule {
            fraction: self.stop_fraction,
            window: self.stop_window,
            max_sweeps: self.max_sweeps,
            supported: self.stop_supported_fraction,
            accepted_rate: self.stop_accepted_rate,
        };
        moves
            .check()
            .and_then(|_| stop.check())
            .map_err(|e| format!("deposition: {e}"))?;
        Ok((moves, stop))
    }
}

impl StartSpec {
    /// How the start is built; the hard-core moves of its growth take `k_max_m2`.
    fn options(&self, k_max_m2: f64) -> Checked<FilmOptions> {
        if !(self.rsa_limit > 0.0 && self.rsa_limit <= 0.38) {
            return Err(format!(
                "start.rsa_limit = {}: must be in (0, 0.38]",
                self.rsa_limit
            ));
        }
        if self.tries_per_particle == 0 || self.max_growth_rounds == 0 {
            return Err(
                "start.tries_per_particle and start.max_growth_rounds: must be >= 1".into(),
            );
        }
        Ok(FilmOptions {
            rsa_limit: self.rsa_limit,
            tries_per_particle: self.tries_per_particle,
            max_growth_rounds: self.max_growth_rounds,
            k_max_m2,
        })
    }
}

impl AnalysisSpec {
    /// What the deposits are measured with.
    fn options(&self) -> Checked<MeasureOptions> {
        if !(self.nodes_per_shortest_semi_axis >= 5.0 && self.nodes_per_shortest_semi_axis <= 100.0)
        {
            return Err(format!(
                "analysis.nodes_per_shortest_semi_axis = {}: must be in [5, 100]",
                self.nodes_per_shortest_semi_axis
            ));
        }
        if self.profile_bins == 0 || self.profile_bins > 100_000 {
            return Err(format!(
                "analysis.profile_bins = {}: must be 1 to 100000",
                self.profile_bins
            ));
        }
        if !(self.touch_fraction > 0.0 && self.touch_fraction < 1.0) {
            return Err(format!(
                "analysis.touch_fraction = {}: must be in (0, 1)",
                self.touch_fraction
            ));
        }
        Ok(MeasureOptions {
            nodes_per_shortest_semi_axis: self.nodes_per_shortest_semi_axis,
            profile_bins: self.profile_bins,
            touch_fraction: self.touch_fraction,
        })
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
        assert_eq!(s.setup.species[0].semi_axes_m, [0.5e-6, 0.5e-6, 0.125e-6]);
        assert_eq!(s.setup.species[1].semi_axes_m, [0.5e-6, 0.125e-6, 0.125e-6]);
        // A needle of aspect 4 with the volume 4/3 pi (0.5)(0.125)^2 um^3 has a = 0.5 um.
        let v = 4.0 / 3.0 * std::f64::consts::PI * 0.5e-6 * 0.125e-6 * 0.125e-6;
        let s = scene(&format!(
            "[[species]]\nname = \"n\"\nshape = \"needle\"\naspect_ratio = 4\n\
             particle_volume_m3 = {v:e}\n"
        ))
        .unwrap();
        let a = s.setup.species[0].semi_axes_m;
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
        assert!((s.setup.species[0].volume_share - 0.3).abs() < 1e-15);
        assert!((s.setup.species[1].volume_share - 0.7).abs() < 1e-15);
        let e = scene(&sp("volume_percent = 130")).unwrap_err().to_string();
        assert!(e.contains("volume_percent = 130"), "{e}");
        let e = scene(&sp("volume_percent = 30\nvolume_ratio = 2"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("volume_ratio with volume_percent"), "{e}");
    }
}
