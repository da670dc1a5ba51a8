//! What a deposition run is (seed 000, Table B1): the coating colour and its film, the
//! pigment species and their size laws, how the start is built, how grains move, when the
//! deposit stops, and the seed of the runs' random streams. Checked once by
//! [`Setup::check`]; the engine ([`super::Deposition::new`]) refuses a setup that fails it.

use super::energy::EnergyTerms;
use super::film::{Colour, FilmOptions};
use super::grain::Grain;
use crate::error::{invalid, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How grains move (eq. A12-A16) and which energy they lower (eq. A2, A3, A11).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moves {
    /// Maximum kinetic-energy constraint K_max, m^2 (Table B1: 1e-14).
    pub k_max_m2: f64,
    pub energy: EnergyTerms,
    /// The time unit over which the previous sweep's mean displacement gives V, s.
    pub time_unit_s: f64,
    /// kT, J (0: the seed's T = 0).
    pub kt_j: f64,
    /// Translation directions uniform on the sphere, keeping eq. A16's lengths: not the
    /// seed's rule (eq. A16 draws each component as the signed square root of a uniform
    /// share, so directions near a coordinate plane are rare). False: the seed's.
    pub isotropic_directions: bool,
}

impl Moves {
    /// Table B1: K_max = 1e-14 m^2, mu = 0.01 Pa s, T = 0, buoyant gravity and drag on, a time
    /// unit of 1 s.
    pub fn table_b1() -> Moves {
        Moves {
            k_max_m2: 1e-14,
            energy: EnergyTerms {
                gravity: true,
                drag: true,
                viscosity_pa_s: 0.01,
            },
            time_unit_s: 1.0,
            kt_j: 0.0,
            isotropic_directions: false,
        }
    }

    /// Checks every value, naming it.
    pub fn check(&self) -> Result<()> {
        positive("k_max_m2", self.k_max_m2)?;
        positive("time_unit_s", self.time_unit_s)?;
        if self.energy.drag {
            positive("viscosity_pa_s", self.energy.viscosity_pa_s)?;
        }
        if !(self.kt_j.is_finite() && self.kt_j >= 0.0) {
            return invalid(format!("kT = {} J: must be >= 0 and finite", self.kt_j));
        }
        Ok(())
    }
}

fn positive(name: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        invalid(format!("{name} = {v}: must be positive and finite"))
    }
}

/// When the deposit stops: the mean displacement per sweep, averaged over the last `window`
/// sweeps, below `fraction` of the first sweep's (the seed's rule, see `engine.rs`), or one of
/// the rest rules instead (`supported`, `accepted_rate`), or `max_sweeps`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopRule {
    /// Stop below this fraction of the first sweep's mean displacement.
    pub fraction: f64,
    /// Sweeps averaged by the stop rule (1: the last sweep alone).
    pub window: u64,
    /// Guard: stop after this many sweeps (reported as not converged).
    pub max_sweeps: u64,
    /// The at-rest rule instead of the seed's: stop when at least this fraction of the spheres
    /// is supported (support.rs), checked every `window` sweeps (spheres only). None: the
    /// seed's displacement rule.
    pub supported: Option<f64>,
    /// The accepted-move rest rule instead of the seed's: stop when the accepted moves per
    /// particle per sweep, averaged over the last `window` sweeps (counted from the first
    /// sweep that moved), fall below this. None: not used.
    pub accepted_rate: Option<f64>,
}

impl StopRule {
    /// 1e-3 of the first sweep over 10 sweeps, with `max_sweeps` as the guard.
    pub fn table_b1(max_sweeps: u64) -> StopRule {
        StopRule {
            fraction: 1e-3,
            window: 10,
            max_sweeps,
            supported: None,
            accepted_rate: None,
        }
    }

    /// Checks every value, naming it.
    pub fn check(&self) -> Result<()> {
        if !(self.fraction > 0.0 && self.fraction < 1.0) {
            return invalid(format!(
                "stop_fraction = {}: must be in (0, 1)",
                self.fraction
            ));
        }
        if self.window == 0 || self.window > 10_000_000 {
            return invalid(format!(
                "stop_window = {}: must be 1 to 10000000",
                self.window
            ));
        }
        if self.max_sweeps == 0 {
            return invalid("max_sweeps = 0: must be at least 1");
        }
        if let Some(s) = self.supported {
            if !(s > 0.0 && s <= 1.0) {
                return invalid(format!("stop_supported_fraction = {s}: must be in (0, 1]"));
            }
        }
        if let Some(a) = self.accepted_rate {
            if !(a > 0.0 && a < 1.0) {
                return invalid(format!("stop_accepted_rate = {a}: must be in (0, 1)"));
            }
            if self.supported.is_some() {
                return invalid(
                    "stop_accepted_rate and stop_supported_fraction: give at most one rest rule",
                );
            }
        }
        Ok(())
    }
}

/// One pigment species.
#[derive(Debug, Clone, PartialEq)]
pub struct Species {
    pub name: String,
    pub semi_axes_m: [f64; 3],
    /// Share of the pigment volume (the shares of a setup sum to 1).
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
                    .or(rows.last())
                    .map_or(1.0, |r| r.0)
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

/// A deposition: `particles` grains of the `species` in a periodic square film of side
/// `box_side_m` at the pigment volume fraction of `colour`, in a fluid of density
/// `fluid_density_kg_m3` under gravity `gravity_m_s2`; the start built by `start`, the grains
/// moved by `moves` until `stop`. Run k of an ensemble draws every random number (sizes,
/// start, moves) from one ChaCha8 stream seeded with [`run_seed`]`(seed, k)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    pub particles: usize,
    pub box_side_m: f64,
    pub colour: Colour,
    pub fluid_density_kg_m3: f64,
    pub gravity_m_s2: f64,
    pub species: Vec<Species>,
    pub start: FilmOptions,
    pub moves: Moves,
    pub stop: StopRule,
    pub seed: u64,
}

impl Setup {
    /// Checks every value (the species' shapes are checked by [`Grain::new`] as grains are
    /// made).
    pub fn check(&self) -> Result<()> {
        if self.particles == 0 {
            return invalid("particles = 0: the film needs at least one");
        }
        if self.species.is_empty() {
            return invalid("no species: give at least one");
        }
        self.colour.pigment_volume_fraction()?;
        if !(self.fluid_density_kg_m3.is_finite() && self.fluid_density_kg_m3 >= 0.0) {
            return invalid(format!(
                "fluid_density_kg_m3 = {}: must be >= 0 and finite",
                self.fluid_density_kg_m3
            ));
        }
        if !(self.gravity_m_s2.is_finite() && self.gravity_m_s2 >= 0.0) {
            return invalid(format!(
                "gravity_m_s2 = {}: must be >= 0 and finite",
                self.gravity_m_s2
            ));
        }
        positive("box_side_m", self.box_side_m)?;
        self.moves.check()?;
        self.stop.check()
    }

    /// The pigment volume fraction of the wet film (from the colour, Table B1).
    pub fn pigment_volume_fraction(&self) -> Result<f64> {
        self.colour.pigment_volume_fraction()
    }

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
        rem.sort_by(|a, b| b.0.total_cmp(&a.0));
        let missing = self.particles.saturating_sub(counts.iter().sum::<usize>());
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

    /// The random stream of run `k`.
    pub fn run_rng(&self, k: usize) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(run_seed(self.seed, k))
    }

    /// The active terms, as printed before a run and stored in the summary.
    pub fn active_terms(&self) -> Vec<String> {
        let mut t = vec!["hard core".to_string()];
        let any_aspherical = self
            .species
            .iter()
            .any(|s| s.semi_axes_m.iter().any(|&a| a != s.semi_axes_m[0]));
        if self.moves.energy.gravity && self.gravity_m_s2 > 0.0 {
            t.push("buoyant gravity".into());
        }
        if self.moves.energy.drag {
            t.push("drag potential (eq. A2-A3)".into());
        }
        if any_aspherical {
            t.push("rotations (eq. A16d-f)".into());
            t.push("Perram-Wertheim overlap".into());
        } else {
            t.push("sphere overlap in closed form (no rotation)".into());
        }
        if self.moves.kt_j > 0.0 {
            t.push("Metropolis at T > 0".into());
        }
        if self.moves.isotropic_directions {
            t.push("isotropic move directions (not the seed's eq. A16)".into());
        }
        if let Some(a) = self.stop.accepted_rate {
            t.push(format!(
                "accepted-move rest rule ({a} per particle per sweep)"
            ));
        } else if let Some(s) = self.stop.supported {
            t.push(format!("supported-fraction rest rule ({s})"));
        }
        t
    }
}

/// The seed of run `k` of a setup seeded `seed` (SplitMix64 of the pair: independent streams).
pub fn run_seed(seed: u64, k: usize) -> u64 {
    let mut z = seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
