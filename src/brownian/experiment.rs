//! The capture experiments of thesis 003, section 6.4, as drivers around [`Simulation`]:
//!
//! - [`CaptureExperiment`]: N particles started in the TOP and SIDE regions (Fig. 6.2) of one
//!   magnetized cylinder, or on a dense cubic lattice near its rim (section 6.4.6); capture
//!   fraction against time per region (Fig. 6.4, 6.7, 6.13), the Brownian-particle criterion
//!   (eq. 6.24) and chain statistics (eq. 6.25–6.26) at each sample time;
//! - [`run_cascade`]: the cascade estimate for many cylinders, random or optimal (section
//!   6.4.5, Fig. 6.10–6.11);
//! - [`capture_volume`]: the capture-volume map with a force cut-off (section 6.4.1, Fig. 6.3).
//!
//! Geometry: the field is applied along +x; the cylinder is centred at the origin with its axis
//! in the x–z plane at angle alpha from the field, axis = (cos alpha, 0, sin alpha), so alpha = 0
//! is longitudinal and alpha = 90 degrees transverse (section 6.3).
//!
//! Regions (Fig. 6.2; the text gives no dimensions, so they are parameters): TOP is the disc
//! slab above the +axis cap, cylinder radius wide, axial gap from `gap` to `gap + thickness`;
//! SIDE is the annular shell around the lateral surface, radial gap from `gap` to
//! `gap + thickness`, over the whole length. Positions are uniform in each region's volume;
//! TOP-and-SIDE averages weight each region by its volume, as the thesis does (Fig. 6.6).
//!
//! Independent runs are independent random streams (`run_rng(seed, run)`) and can run in
//! parallel; results depend only on (seed, run).

use super::capture::{CaptureSet, CylinderBody};
use super::driver::run_sampled;
use super::forces::{LangevinMoment, Mie, WithUniform};
use super::magnetization::{saturated_at_angle, stoner_wohlfarth_magnet};
use super::mobility::{stokes_mobility, Hydrodynamics};
use super::noise::NoiseMethod;
use super::setup::{Fluid, Magnetic, Setup, StepGuard};
use super::Simulation;
use super::{cubic_lattice, run_rng, Particles};
use crate::consts::MU0;
use crate::driver::Hooks;
use crate::error::{invalid, require_positive, Result};
use crate::magnetics::{Cylinder, Magnet};
use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{PI, TAU};

/// Table 6.1 of the thesis (data of Schaller et al.): hydrodynamic radius (nm) and particle
/// magnetic moment (1e-16 A m^2).
pub const TABLE_6_1: [(f64, f64); 6] = [
    (25.0, 0.016),
    (50.0, 0.344),
    (75.0, 0.870),
    (100.0, 0.662),
    (125.0, 5.151),
    (212.0, 19.35),
];

/// The Table 6.1 moment (A m^2) of particles of hydrodynamic radius `radius_m`, or an error
/// listing the radii of the table.
pub fn table_6_1_moment(radius_m: f64) -> Result<f64> {
    TABLE_6_1
        .iter()
        .find(|(r_nm, _)| (r_nm * 1e-9 - radius_m).abs() < 1e-3 * r_nm * 1e-9)
        .map(|(_, mu)| mu * 1e-16)
        .map_or_else(
            || {
                invalid(format!(
                    "particle radius {radius_m:e} m is not in Table 6.1 (radii 25, 50, 75, 100, \
                     125, 212 nm); give the moment explicitly"
                ))
            },
            Ok,
        )
}

/// Where a particle started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Region {
    Top,
    Side,
    /// The dense lattice block of section 6.4.6.
    Block,
}

impl Region {
    pub fn name(self) -> &'static str {
        match self {
            Region::Top => "TOP",
            Region::Side => "SIDE",
            Region::Block => "BLOCK",
        }
    }
}

/// Extent of the TOP and SIDE regions (m): gap from the cylinder surface to the region's inner
/// face, and the region's thickness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionShape {
    pub gap_m: f64,
    pub thickness_m: f64,
}

impl RegionShape {
    pub fn new(gap_m: f64, thickness_m: f64) -> Result<RegionShape> {
        if !(gap_m.is_finite() && gap_m >= 0.0) {
            return invalid(format!("region gap {gap_m} m: must be finite and >= 0"));
        }
        require_positive(thickness_m, || format!("region thickness {thickness_m} m"))?;
        Ok(RegionShape { gap_m, thickness_m })
    }

    /// Volume (m^3) of a region around `body`.
    pub fn volume(&self, body: &CylinderBody, region: Region) -> f64 {
        let (r, l) = (body.radius, body.half_length);
        match region {
            Region::Top => PI * r * r * self.thickness_m,
            Region::Side => {
                let (r1, r2) = (r + self.gap_m, r + self.gap_m + self.thickness_m);
                PI * (r2 * r2 - r1 * r1) * 2.0 * l
            }
            Region::Block => 0.0,
        }
    }

    /// A point uniform in the volume of a TOP or SIDE region around `body`.
    pub fn sample<R: Rng + ?Sized>(
        &self,
        body: &CylinderBody,
        region: Region,
        rng: &mut R,
    ) -> Vector3<f64> {
        let (r, l) = (body.radius, body.half_length);
        let phi = TAU * rng.gen::<f64>();
        let (rho, u) = match region {
            Region::Top => (
                r * rng.gen::<f64>().sqrt(),
                l + self.gap_m + self.thickness_m * rng.gen::<f64>(),
            ),
            _ => {
                let (r1, r2) = (r + self.gap_m, r + self.gap_m + self.thickness_m);
                (
                    (r1 * r1 + (r2 * r2 - r1 * r1) * rng.gen::<f64>()).sqrt(),
                    l * (2.0 * rng.gen::<f64>() - 1.0),
                )
            }
        };
        let (e1, e2) = perpendicular_pair(&body.axis());
        body.centre + body.axis() * u + (e1 * phi.cos() + e2 * phi.sin()) * rho
    }
}

/// Two unit vectors completing `a` (unit) to a right-handed orthonormal frame.
fn perpendicular_pair(a: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let trial = if a.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = (trial - a * trial.dot(a)).normalize();
    (e1, a.cross(&e1))
}

/// Positions for particles of radius `a` in the given `regions` (in that order) around `body`,
/// uniform in each region's volume, no two closer than 2a (rejection, at most 10^4 tries per
/// particle, then an error).
fn place_in_regions(
    body: &CylinderBody,
    shape: &RegionShape,
    a: f64,
    regions: Vec<Region>,
    rng: &mut ChaCha8Rng,
) -> Result<(Vec<Vector3<f64>>, Vec<Region>)> {
    if shape.gap_m <= a {
        return invalid(format!(
            "region gap {} m must exceed the particle radius {a} m (no particle may start in \
             contact with the cylinder)",
            shape.gap_m
        ));
    }
    let mut pos: Vec<Vector3<f64>> = Vec::with_capacity(regions.len());
    for &region in &regions {
        let mut tries = 0;
        let p = loop {
            let p = shape.sample(body, region, rng);
            if pos.iter().all(|q| (p - q).norm() >= 2.0 * a) {
                break p;
            }
            tries += 1;
            if tries == 10_000 {
                let count = regions.iter().filter(|&&r| r == region).count();
                return invalid(format!(
                    "could not place particle {} in region {} without overlap in 10^4 tries: \
                     the region is too small for {count} particles of radius {a:e} m",
                    pos.len(),
                    region.name(),
                ));
            }
        };
        pos.push(p);
    }
    Ok((pos, regions))
}

/// How the cylinder is magnetized by the applied field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MagnetizationLaw {
    /// Saturated, direction by Stoner–Wohlfarth energy minimisation with the exact
    /// demagnetizing factors (section 6.3).
    StonerWohlfarth,
    /// Saturated at this angle (rad) from the axis, toward the field (section 6.4.1).
    FixedAngle(f64),
}

/// The magnetized cylinder: diameter (m), aspect ratio L/D, saturation (A/m), law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderSetup {
    pub diameter_m: f64,
    pub aspect_ratio: f64,
    pub saturation_a_per_m: f64,
    pub law: MagnetizationLaw,
}

impl CylinderSetup {
    /// The magnet centred at `centre` with axis `axis` in the applied field `h0` (A/m).
    pub fn magnet(
        &self,
        centre: Vector3<f64>,
        axis: Vector3<f64>,
        h0: &Vector3<f64>,
    ) -> Result<Magnet> {
        require_positive(self.diameter_m, || {
            format!("cylinder diameter {} m", self.diameter_m)
        })?;
        require_positive(self.aspect_ratio, || {
            format!("cylinder aspect ratio L/D = {}", self.aspect_ratio)
        })?;
        let cyl = Cylinder::new(
            0.5 * self.diameter_m,
            0.5 * self.aspect_ratio * self.diameter_m,
        )?;
        match self.law {
            MagnetizationLaw::StonerWohlfarth => {
                stoner_wohlfarth_magnet(cyl, centre, axis, h0, self.saturation_a_per_m)
            }
            MagnetizationLaw::FixedAngle(angle) => {
                let m = saturated_at_angle(&axis, h0, angle, self.saturation_a_per_m)?;
                Magnet::new(cyl, centre, axis, m)
            }
        }
    }
}

/// Axis at angle `alpha` (rad) from the +x field direction, in the x–z plane.
pub fn axis_at_angle(alpha: f64) -> Vector3<f64> {
    Vector3::new(alpha.cos(), 0.0, alpha.sin())
}

/// Where the particles start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Placement {
    /// `n_top` in TOP and `n_side` in SIDE (Fig. 6.2).
    TopSide {
        n_top: usize,
        n_side: usize,
        shape: RegionShape,
    },
    /// `n` particles uniform in the union of TOP and SIDE: each particle is in TOP with
    /// probability V_TOP / (V_TOP + V_SIDE), then uniform in its region. This is the population
    /// whose captured fraction the thesis' volume-weighted TOP-and-SIDE averages estimate
    /// (Fig. 6.6, 6.8b, 6.9), and a reading of the cascade's "randomly placed around a
    /// cylinder" (section 6.4.5).
    Uniform { n: usize, shape: RegionShape },
    /// `n` particles on a simple cubic lattice of spacing `spacing_m`, the block's face
    /// `distance_m` above the +axis cap and its centre over the rim (section 6.4.6; spacing
    /// d = (rho V_p / c)^(1/3) gives the mass concentration c).
    Block {
        n: usize,
        spacing_m: f64,
        distance_m: f64,
    },
}

/// A capture run: physics of the particles, the cylinder, and what to record.
#[derive(Debug, Clone)]
pub struct CaptureExperiment {
    pub fluid: Fluid,
    /// Time step (s).
    pub dt_s: f64,
    pub particle_radius_m: f64,
    pub moment: LangevinMoment,
    pub placement: Placement,
    pub cylinder: CylinderSetup,
    /// Axis angle from the field (rad).
    pub alpha: f64,
    /// Applied field H0 (A/m).
    pub h0: Vector3<f64>,
    pub hydrodynamics: Hydrodynamics,
    pub noise: NoiseMethod,
    /// Mie(n, m) repulsion with epsilon in units of kT, or none.
    pub mie: Option<(i32, i32, f64)>,
    /// Dipole–dipole cut-off (m), or no dipole pairs.
    pub dipole_cutoff_m: Option<f64>,
    pub guard: StepGuard,
    pub t_max_s: f64,
    pub sample_every_s: f64,
    /// Two particles closer than this factor times 2R are bonded in the chain statistics.
    pub bond_factor: f64,
}

/// One sample of a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample {
    pub time_s: f64,
    /// Captured fraction per region, in the order of [`RunResult::regions`].
    pub captured: Vec<f64>,
    /// Chain statistics of the free and captured particles together.
    pub chains: ChainStats,
}

/// The outcome of one run (serialisable: a finished run is a checkpoint of its ensemble).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunResult {
    pub run: u64,
    /// The regions present, in a fixed order (TOP, SIDE, or BLOCK).
    pub regions: Vec<Region>,
    pub region_of: Vec<Region>,
    pub initial: Vec<Vector3<f64>>,
    pub last: Vec<Vector3<f64>>,
    /// Capture time (s) per particle, None if free at the end.
    pub capture_time_s: Vec<Option<f64>>,
    /// Eq. 6.24 at the end: a free particle whose squared displacement is below 2 x 6 D t.
    pub brownian: Vec<bool>,
    pub samples: Vec<Sample>,
    /// Steps taken (sub-steps of the guard not counted).
    pub steps: u64,
}

impl CaptureExperiment {
    /// Rejects bad values with a message naming them.
    pub fn validate(&self) -> Result<()> {
        require_positive(self.particle_radius_m, || {
            format!("particle radius {} m", self.particle_radius_m)
        })?;
        require_positive(self.t_max_s, || format!("run.t_max_s = {} s", self.t_max_s))?;
        require_positive(self.sample_every_s, || {
            format!("run.sample_every_s = {} s", self.sample_every_s)
        })?;
        super::setup::check_time_step(self.dt_s)?;
        if self.sample_every_s < self.dt_s {
            return invalid(format!(
                "sample interval {} s is shorter than the time step {} s",
                self.sample_every_s, self.dt_s
            ));
        }
        if !(self.bond_factor.is_finite() && self.bond_factor >= 1.0) {
            return invalid(format!(
                "chain bond factor {}: must be finite and >= 1",
                self.bond_factor
            ));
        }
        if !self.alpha.is_finite() {
            return invalid(format!(
                "cylinder angle alpha = {} rad: must be finite",
                self.alpha
            ));
        }
        Ok(())
    }

    /// Number of time steps of a run.
    pub fn steps(&self) -> u64 {
        (self.t_max_s / self.dt_s).round().max(1.0) as u64
    }

    fn steps_per_sample(&self) -> u64 {
        (self.sample_every_s / self.dt_s).round().max(1.0) as u64
    }

    /// The magnet for axis angle `alpha`.
    pub fn magnet(&self, axis: Vector3<f64>) -> Result<Magnet> {
        self.cylinder.magnet(Vector3::zeros(), axis, &self.h0)
    }

    /// Initial positions and their regions around `body`, drawn from `rng`; no two particles
    /// closer than 2R (rejection, at most 10^4 tries per particle, then an error).
    pub fn place(
        &self,
        body: &CylinderBody,
        rng: &mut ChaCha8Rng,
    ) -> Result<(Vec<Vector3<f64>>, Vec<Region>)> {
        let a = self.particle_radius_m;
        match self.placement {
            Placement::TopSide {
                n_top,
                n_side,
                shape,
            } => {
                let regions: Vec<Region> = std::iter::repeat_n(Region::Top, n_top)
                    .chain(std::iter::repeat_n(Region::Side, n_side))
                    .collect();
                place_in_regions(body, &shape, a, regions, rng)
            }
            Placement::Uniform { n, shape } => {
                let (vt, vs) = (
                    shape.volume(body, Region::Top),
                    shape.volume(body, Region::Side),
                );
                let p_top = vt / (vt + vs);
                let regions: Vec<Region> = (0..n)
                    .map(|_| {
                        if rng.gen::<f64>() < p_top {
                            Region::Top
                        } else {
                            Region::Side
                        }
                    })
                    .collect();
                place_in_regions(body, &shape, a, regions, rng)
            }
            Placement::Block {
                n,
                spacing_m,
                distance_m,
            } => {
                if spacing_m < 2.0 * a {
                    return invalid(format!(
                        "lattice spacing {spacing_m:e} m is below the particle diameter {:e} m \
                         (concentration too high for a cubic lattice)",
                        2.0 * a
                    ));
                }
                if distance_m <= a {
                    return invalid(format!(
                        "block distance {distance_m:e} m from the cap must exceed the particle \
                         radius {a:e} m"
                    ));
                }
                let lattice = cubic_lattice(n, spacing_m);
                let side = (n as f64).cbrt().ceil() * spacing_m;
                let (e1, e2) = perpendicular_pair(&body.axis());
                // Block centre over the rim (radial offset R), bottom face distance_m above the cap.
                let origin = body.centre
                    + body.axis() * (body.half_length + distance_m)
                    + e1 * (body.radius - 0.5 * side)
                    - e2 * (0.5 * side);
                let pos = lattice
                    .iter()
                    .map(|q| origin + e1 * q.x + e2 * q.y + body.axis() * q.z)
                    .collect();
                Ok((pos, vec![Region::Block; n]))
            }
        }
    }

    /// The setup of one run around `magnet`, from `positions`: capture by the magnet's
    /// cylinder, the field force on the particles' moments, dipole pairs and Mie repulsion as
    /// the experiment says.
    pub fn setup(&self, magnet: Magnet, positions: Vec<Vector3<f64>>) -> Result<Setup> {
        let body = CylinderBody::from_magnet(&magnet)?;
        let n = positions.len();
        let particles = Particles::new(positions, self.particle_radius_m)?;
        let mut s = Setup::new(particles, self.fluid, self.dt_s)?;
        s.capture = Some(CaptureSet::new(vec![body], n));
        s.hydrodynamics = self.hydrodynamics;
        s.noise = self.noise;
        s.guard = self.guard;
        // The guard protects the repulsion; the field force's step is an accuracy choice of dt.
        s.guard_field_force = false;
        if let Some((nn, mm, eps_kt)) = self.mie {
            s.repulsion = Some(Mie::new(
                nn,
                mm,
                eps_kt * self.fluid.kt(),
                2.0 * self.particle_radius_m,
            )?);
        }
        s.magnetic = Some(Magnetic {
            source: Box::new(WithUniform {
                h0: self.h0,
                source: magnet,
            }),
            moment: self.moment,
            dipole_pairs: self.dipole_cutoff_m.is_some(),
            cutoff: self.dipole_cutoff_m.unwrap_or(0.0),
        });
        Ok(s)
    }

    /// Free-particle diffusion coefficient kT / (6 pi eta R) (m^2/s), eq. 6.5.
    pub fn diffusion_coefficient(&self) -> Result<f64> {
        Ok(self.fluid.kt() * stokes_mobility(self.fluid.viscosity_pa_s(), self.particle_radius_m)?)
    }

    /// Run number `run` of the experiment seeded with `seed` (stream [`run_rng`]`(seed, run)`:
    /// the placement, then the noise); the hooks hear every step (a progress bar moves with
    /// every step, not once per sample interval: with 1e5 particles one interval of a few
    /// hundred steps takes minutes).
    pub fn run(
        &self,
        seed: u64,
        run: u64,
        hooks: &mut impl Hooks<Simulation>,
    ) -> Result<RunResult> {
        self.validate()?;
        let mut rng = run_rng(seed, run);
        let magnet = self.magnet(axis_at_angle(self.alpha))?;
        let body = CylinderBody::from_magnet(&magnet)?;
        let (initial, region_of) = self.place(&body, &mut rng)?;
        let mut sim = Simulation::new(self.setup(magnet, initial.clone())?, rng)?;
        let regions = present_regions(&region_of);
        let (steps, per_sample) = (self.steps(), self.steps_per_sample());
        let mut samples = vec![self.sample(&sim, &regions, &region_of)?];
        run_sampled(&mut sim, steps, per_sample, hooks, |sim| {
            samples.push(self.sample(sim, &regions, &region_of)?);
            Ok(())
        })
        .map_err(|e| {
            crate::Error::InvalidInput(format!("run {run}, t = {:e} s: {e}", sim.time_s()))
        })?;
        let capture = captures(&sim)?;
        let capture_time_s: Vec<Option<f64>> = (0..initial.len())
            .map(|i| capture.capture(i).map(|c| c.time))
            .collect();
        let threshold = 2.0 * 6.0 * self.diffusion_coefficient()? * sim.time_s(); // eq. 6.24
        let last = sim.particles().positions.clone();
        let brownian = (0..initial.len())
            .map(|i| {
                capture_time_s[i].is_none() && (last[i] - initial[i]).norm_squared() < threshold
            })
            .collect();
        Ok(RunResult {
            run,
            regions,
            region_of,
            initial,
            last,
            capture_time_s,
            brownian,
            samples,
            steps,
        })
    }

    fn sample(&self, sim: &Simulation, regions: &[Region], region_of: &[Region]) -> Result<Sample> {
        let capture = captures(sim)?;
        let captured = regions
            .iter()
            .map(|r| {
                let members: Vec<usize> = (0..region_of.len())
                    .filter(|&i| region_of[i] == *r)
                    .collect();
                capture.fraction_of(&members)
            })
            .collect();
        Ok(Sample {
            time_s: sim.time_s(),
            captured,
            chains: chain_statistics(
                &sim.particles().positions,
                self.particle_radius_m,
                self.bond_factor,
            ),
        })
    }

    /// Volumes (m^3) of the regions in `regions`, for the volume-weighted average: TOP and SIDE
    /// from the region shape; the block as n lattice cells of volume d^3.
    pub fn region_volumes(&self, regions: &[Region]) -> Result<Vec<f64>> {
        let magnet = self.magnet(axis_at_angle(self.alpha))?;
        let body = CylinderBody::from_magnet(&magnet)?;
        Ok(match self.placement {
            Placement::TopSide { shape, .. } | Placement::Uniform { shape, .. } => {
                regions.iter().map(|r| shape.volume(&body, *r)).collect()
            }
            Placement::Block { n, spacing_m, .. } => {
                vec![n as f64 * spacing_m.powi(3); regions.len()]
            }
        })
    }
}

/// The captures of a simulation built by [`CaptureExperiment::setup`] (which always has them).
fn captures(sim: &Simulation) -> Result<&CaptureSet> {
    sim.capture()
        .map_or_else(|| invalid("a capture run without capture (internal)"), Ok)
}

fn present_regions(region_of: &[Region]) -> Vec<Region> {
    [Region::Top, Region::Side, Region::Block]
        .into_iter()
        .filter(|r| region_of.contains(r))
        .collect()
}

/// Mean and standard error of the mean of `values` (standard error 0 for one value).
pub fn mean_and_stderr(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Clusters of particles bonded when their centres are closer than `bond_factor` x 2R.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ChainStats {
    /// Number of clusters with at least two particles.
    pub chains: usize,
    /// Mean size of those clusters (number average; 0 without chains).
    pub mean_length: f64,
    /// Fraction of all particles that belong to a chain.
    pub fraction_in_chains: f64,
    pub longest: usize,
}

/// Chain (cluster) statistics by union–find over all pairs.
pub fn chain_statistics(pos: &[Vector3<f64>], radius: f64, bond_factor: f64) -> ChainStats {
    let n = pos.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let bond2 = (bond_factor * 2.0 * radius).powi(2);
    for i in 0..n {
        for j in (i + 1)..n {
            if (pos[i] - pos[j]).norm_squared() < bond2 {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                if ri != rj {
                    parent[ri] = rj;
                }
            }
        }
    }
    let mut size = vec![0usize; n];
    for i in 0..n {
        let r = root(&mut parent, i);
        size[r] += 1;
    }
    let chains: Vec<usize> = size.into_iter().filter(|&s| s >= 2).collect();
    let in_chains: usize = chains.iter().sum();
    ChainStats {
        chains: chains.len(),
        mean_length: if chains.is_empty() {
            0.0
        } else {
            in_chains as f64 / chains.len() as f64
        },
        fraction_in_chains: if n == 0 {
            0.0
        } else {
            in_chains as f64 / n as f64
        },
        longest: chains.iter().copied().max().unwrap_or(0),
    }
}

/// Dipolar coupling constant Gamma = mu0 mu^2 / (2 pi d^3 kT) (eq. 6.25): moment `mu` (A m^2),
/// particle diameter `d` (m), thermal energy `kt` (J).
pub fn dipolar_coupling(mu: f64, d: f64, kt: f64) -> f64 {
    MU0 * mu * mu / (2.0 * PI * d.powi(3) * kt)
}

/// Mean chain length n = sqrt(phi0 e^(Gamma - 1)) (eq. 6.26, Andreu et al.) at volume fraction
/// `phi0`; computed in logarithms so large Gamma gives a large finite number or infinity, never
/// NaN.
pub fn mean_chain_length(phi0: f64, gamma: f64) -> f64 {
    (0.5 * (phi0.ln() + gamma - 1.0)).exp()
}

/// The cascade of section 6.4.5.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CascadeMode {
    /// Each stage's cylinder axis is uniform on the sphere.
    Random,
    /// Every cylinder perpendicular to the field and parallel to the others (axis along z).
    Optimal,
}

/// One cascade run: `stages` stages of `stage_time_s` each; after each stage the free
/// particles are placed afresh around a new cylinder (TOP and SIDE in the experiment's
/// proportions, or uniform over both with [`Placement::Uniform`]). Returns (time (s),
/// cumulative captured fraction) at every sample, starting at (0, 0). Uses the experiment's
/// physics; its `alpha` and `t_max_s` are not used. One random stream ([`run_rng`]`(seed,
/// run)`) draws every stage's axis, placement and noise in turn; the hooks hear every step.
pub fn run_cascade(
    exp: &CaptureExperiment,
    mode: CascadeMode,
    stages: usize,
    stage_time_s: f64,
    seed: u64,
    run: u64,
    hooks: &mut impl Hooks<Simulation>,
) -> Result<Vec<(f64, f64)>> {
    exp.validate()?;
    require_positive(stage_time_s, || {
        format!("cascade stage time {stage_time_s} s")
    })?;
    // The free particles of each stage are placed afresh with the experiment's rule: TOP and
    // SIDE in the proportions of (n_top, n_side), or uniform over both regions.
    let (n_total, restage): (usize, Box<dyn Fn(usize) -> Placement>) = match exp.placement {
        Placement::TopSide {
            n_top,
            n_side,
            shape,
        } => {
            let n_total = n_top + n_side;
            (
                n_total,
                Box::new(move |free| {
                    let top = (free * n_top + n_total / 2) / n_total;
                    Placement::TopSide {
                        n_top: top,
                        n_side: free - top,
                        shape,
                    }
                }),
            )
        }
        Placement::Uniform { n, shape } => (
            n,
            Box::new(move |free| Placement::Uniform { n: free, shape }),
        ),
        Placement::Block { .. } => {
            return invalid("the cascade needs TOP/SIDE or uniform placement, not a block")
        }
    };
    if n_total == 0 {
        return invalid("the cascade needs at least one particle");
    }
    let mut rng = run_rng(seed, run);
    let per_sample = exp.steps_per_sample();
    let stage_steps = (stage_time_s / exp.dt_s).round().max(1.0) as u64;
    let mut free = n_total;
    let mut out = vec![(0.0, 0.0)];
    let mut t0 = 0.0;
    for _ in 0..stages {
        if free == 0 {
            break;
        }
        let axis = match mode {
            CascadeMode::Random => random_unit_vector(&mut rng),
            CascadeMode::Optimal => Vector3::z(),
        };
        let magnet = exp.magnet(axis)?;
        let body = CylinderBody::from_magnet(&magnet)?;
        let stage = CaptureExperiment {
            placement: restage(free),
            ..exp.clone()
        };
        let (pos, _) = stage.place(&body, &mut rng)?;
        let mut sim = Simulation::new(stage.setup(magnet, pos)?, rng)?;
        run_sampled(&mut sim, stage_steps, per_sample, hooks, |sim| {
            let total_captured = n_total - free + captures(sim)?.count();
            out.push((t0 + sim.time_s(), total_captured as f64 / n_total as f64));
            Ok(())
        })?;
        free -= captures(&sim)?.count();
        t0 += sim.time_s();
        rng = sim.into_stream();
    }
    Ok(out)
}

/// A unit vector uniform on the sphere.
pub fn random_unit_vector<R: Rng + ?Sized>(rng: &mut R) -> Vector3<f64> {
    let z = 2.0 * rng.gen::<f64>() - 1.0;
    let phi = TAU * rng.gen::<f64>();
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vector3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Force on a particle of moment magnitude `mu` (A m^2) aligned with the local B (section
/// 6.4.1): F = mu0 |m| (h . grad) H with h the unit total field (eq. 6.20).
pub fn aligned_dipole_force(
    magnet: &Magnet,
    h0: &Vector3<f64>,
    mu: f64,
    p: &Vector3<f64>,
) -> Vector3<f64> {
    let (h, g) = magnet.h_and_gradient(p);
    let ht = h + h0;
    let n = ht.norm();
    if n == 0.0 {
        return Vector3::zeros();
    }
    (g * ht) * (MU0 * mu / n)
}

/// A capture-volume map (section 6.4.1).
#[derive(Debug, Clone)]
pub struct CaptureVolume {
    /// Points of the x–z plane through the axis (y = 0): (x, z) (m), force (N), attractive
    /// and above the cut-off.
    pub plane: Vec<(f64, f64, Vector3<f64>, bool)>,
    /// Volume (m^3) of the region outside the cylinder where the force exceeds the cut-off and
    /// points toward the cylinder, within `margin` of its surface (midpoint rule on a grid).
    pub volume_m3: f64,
    pub cylinder_volume_m3: f64,
    /// Whether the region reaches the faces of the box: then the volume is a lower bound and
    /// the margin should grow.
    pub reaches_box: bool,
}

/// The region around `magnet` where the aligned-dipole force (moment `mu`, A m^2) exceeds
/// `cutoff_n` (N) and has a component toward the nearest point of the cylinder: a plane map on
/// `plane_points` x `plane_points` points and a volume on a `grid`^3 midpoint grid, both over
/// the box reaching `margin_m` beyond the cylinder.
pub fn capture_volume(
    magnet: &Magnet,
    h0: &Vector3<f64>,
    mu: f64,
    cutoff_n: f64,
    margin_m: f64,
    plane_points: usize,
    grid: usize,
) -> Result<CaptureVolume> {
    require_positive(cutoff_n, || format!("force cut-off {cutoff_n} N"))?;
    require_positive(margin_m, || format!("map margin {margin_m} m"))?;
    require_positive(mu, || format!("particle moment {mu} A m^2"))?;
    if plane_points < 2 || grid < 2 {
        return invalid(format!(
            "map resolution {plane_points} (plane) and {grid} (volume): need at least 2 points"
        ));
    }
    let body = CylinderBody::from_magnet(magnet)?;
    // Axis-aligned bounding box of the posed cylinder, widened by the margin.
    let a = body.axis();
    let half: Vector3<f64> = Vector3::from_fn(|i, _| {
        body.half_length * a[i].abs() + body.radius * (1.0 - a[i] * a[i]).max(0.0).sqrt() + margin_m
    });
    let lo = body.centre - half;
    let attractive = |p: &Vector3<f64>| -> Option<Vector3<f64>> {
        if body.signed_distance(p) <= 0.0 {
            return None;
        }
        let f = aligned_dipole_force(magnet, h0, mu, p);
        // Toward the cylinder: against the gradient of the distance (finite difference of the
        // exact distance function, step 1e-6 of the margin).
        let eps = 1e-6 * margin_m;
        let grad_d = Vector3::from_fn(|i, _| {
            let mut q = *p;
            q[i] += eps;
            let mut r = *p;
            r[i] -= eps;
            (body.signed_distance(&q) - body.signed_distance(&r)) / (2.0 * eps)
        });
        (f.norm() >= cutoff_n && f.dot(&grad_d) < 0.0).then_some(f)
    };
    let mut plane = Vec::with_capacity(plane_points * plane_points);
    for i in 0..plane_points {
        for k in 0..plane_points {
            let x = lo.x + 2.0 * half.x * i as f64 / (plane_points - 1) as f64;
            let z = lo.z + 2.0 * half.z * k as f64 / (plane_points - 1) as f64;
            let p = Vector3::new(x, body.centre.y, z);
            if body.signed_distance(&p) <= 0.0 {
                continue;
            }
            let f = aligned_dipole_force(magnet, h0, mu, &p);
            plane.push((x, z, f, attractive(&p).is_some()));
        }
    }
    let cell = Vector3::from_fn(|i, _| 2.0 * half[i] / grid as f64);
    let inside: Vec<usize> = {
        use rayon::prelude::*;
        (0..grid * grid * grid)
            .into_par_iter()
            .filter(|&idx| {
                let (i, j, k) = (idx % grid, (idx / grid) % grid, idx / (grid * grid));
                let p = lo
                    + Vector3::new(
                        (i as f64 + 0.5) * cell.x,
                        (j as f64 + 0.5) * cell.y,
                        (k as f64 + 0.5) * cell.z,
                    );
                attractive(&p).is_some()
            })
            .collect()
    };
    let on_face = |idx: &usize| {
        let (i, j, k) = (idx % grid, (idx / grid) % grid, idx / (grid * grid));
        [i, j, k].iter().any(|&c| c == 0 || c == grid - 1)
    };
    Ok(CaptureVolume {
        plane,
        reaches_box: inside.iter().any(on_face),
        volume_m3: inside.len() as f64 * cell.x * cell.y * cell.z,
        cylinder_volume_m3: 2.0 * PI * body.radius * body.radius * body.half_length,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_lookup_and_errors() {
        assert_eq!(table_6_1_moment(212e-9).unwrap(), 19.35e-16);
        let e = table_6_1_moment(60e-9).unwrap_err().to_string();
        assert!(e.contains("Table 6.1"), "{e}");
    }

    /// Region samples lie in their region; the sample mean of a region-volume indicator
    /// matches the closed-form volume ratio of the SIDE shell's inner and outer halves.
    #[test]
    fn regions_are_sampled_uniformly() {
        let body = CylinderBody::new(
            Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(1.0, 1.0, 0.0),
            2.0,
            5.0,
        )
        .unwrap();
        let shape = RegionShape::new(0.5, 1.0).unwrap();
        let mut rng = run_rng(3, 0);
        let n = 100_000;
        let mut inner = 0;
        for _ in 0..n {
            let p = shape.sample(&body, Region::Side, &mut rng);
            let d = body.signed_distance(&p);
            assert!((0.5 - 1e-12..=1.5 + 1e-12).contains(&d), "{d}");
            if d < 1.0 {
                inner += 1;
            }
            let q = shape.sample(&body, Region::Top, &mut rng);
            let u = (q - body.centre).dot(&body.axis());
            assert!((5.5 - 1e-12..=6.5 + 1e-12).contains(&u), "{u}");
            assert!((q - body.centre - body.axis() * u).norm() <= 2.0 + 1e-12);
        }
        // Annulus radii 2.5..3.0 against 2.5..3.5: (3^2 - 2.5^2) / (3.5^2 - 2.5^2) = 2.75 / 6.
        let expected = 2.75 / 6.0;
        let got = inner as f64 / n as f64;
        let se = (expected * (1.0 - expected) / n as f64).sqrt();
        assert!((got - expected).abs() < 5.0 * se, "{got} vs {expected}");
        assert!((shape.volume(&body, Region::Side) - PI * 6.0 * 10.0).abs() < 1e-12);
        assert!((shape.volume(&body, Region::Top) - PI * 4.0).abs() < 1e-12);
    }

    /// Uniform placement: the share of TOP particles is binomial with p = V_TOP / (V_TOP +
    /// V_SIDE) (closed-form volumes), and every particle lies in the region it is labelled with.
    #[test]
    fn uniform_placement_shares_regions_by_volume() {
        let body = CylinderBody::new(Vector3::zeros(), Vector3::z(), 2.0, 3.0).unwrap();
        let shape = RegionShape::new(0.5, 1.0).unwrap();
        // V_TOP = pi 2^2 1 = 4 pi; V_SIDE = pi (3.5^2 - 2.5^2) 6 = 36 pi: p = 0.1.
        let p = 0.1;
        let exp = CaptureExperiment {
            placement: Placement::Uniform { n: 2000, shape },
            particle_radius_m: 1e-3,
            ..test_experiment()
        };
        let mut rng = run_rng(4, 0);
        let (pos, reg) = exp.place(&body, &mut rng).unwrap();
        let n = pos.len() as f64;
        let top = reg.iter().filter(|&&r| r == Region::Top).count() as f64;
        let se = (p * (1.0 - p) / n).sqrt();
        assert!((top / n - p).abs() < 5.0 * se, "{} vs {p}", top / n);
        for (q, r) in pos.iter().zip(&reg) {
            let u = q.z;
            match r {
                Region::Top => assert!((3.5 - 1e-12..=4.5 + 1e-12).contains(&u), "{u}"),
                _ => assert!((-3.0..=3.0).contains(&u) && q.xy().norm() >= 2.5 - 1e-12),
            }
        }
    }

    /// A small experiment whose fields the tests override.
    fn test_experiment() -> CaptureExperiment {
        CaptureExperiment {
            fluid: Fluid::new(298.0, 1e-3).unwrap(),
            dt_s: 1e-4,
            particle_radius_m: 1e-7,
            moment: LangevinMoment::fixed(1e-16).unwrap(),
            placement: Placement::Uniform {
                n: 1,
                shape: RegionShape::new(1e-6, 1e-5).unwrap(),
            },
            cylinder: CylinderSetup {
                diameter_m: 600e-6,
                aspect_ratio: 20.0,
                saturation_a_per_m: 985e3,
                law: MagnetizationLaw::StonerWohlfarth,
            },
            alpha: 0.0,
            h0: Vector3::new(1.0 / MU0, 0.0, 0.0),
            hydrodynamics: Hydrodynamics::FreeDraining,
            noise: NoiseMethod::TeaHi,
            mie: None,
            dipole_cutoff_m: None,
            guard: StepGuard::Refuse { max_fraction: 0.1 },
            t_max_s: 1e-3,
            sample_every_s: 1e-3,
            bond_factor: 1.1,
        }
    }

    /// The progress hook hears of every step, not once per sample interval: ten steps in
    /// one interval are ten calls.
    #[test]
    fn progress_ticks_every_step() {
        let exp = test_experiment();
        assert_eq!((exp.steps(), exp.steps_per_sample()), (10, 10));
        /// The fractions of each interval the progress hook hears.
        struct Ticks(Vec<f64>);
        impl Hooks<Simulation> for Ticks {
            fn progress(&mut self, _: &Simulation, done: Option<f64>, _: &str) {
                self.0.push(done.unwrap_or(f64::NAN));
            }
        }
        let mut ticks = Ticks(Vec::new());
        let r = exp.run(7, 0, &mut ticks).unwrap();
        assert_eq!(r.steps, 10);
        let tenths: Vec<f64> = (1..=10).map(|k| k as f64 / 10.0).collect();
        assert_eq!(ticks.0, tenths);
    }

    #[test]
    fn chains_by_union_find() {
        let a = 1.0;
        // A chain of 3 touching spheres, a pair, and a loner.
        let pos = vec![
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(2.0, 0.0, 0.0),
            Vector3::new(4.05, 0.0, 0.0),
            Vector3::new(10.0, 0.0, 0.0),
            Vector3::new(10.0, 2.1, 0.0),
            Vector3::new(20.0, 0.0, 0.0),
        ];
        let s = chain_statistics(&pos, a, 1.1);
        assert_eq!(s.chains, 2);
        assert_eq!(s.longest, 3);
        assert!((s.mean_length - 2.5).abs() < 1e-15);
        assert!((s.fraction_in_chains - 5.0 / 6.0).abs() < 1e-15);
        assert_eq!(chain_statistics(&pos, a, 1.0).chains, 0);
    }

    /// Eq. 6.25–6.26 by hand: mu = 1e-16 A m^2, d = 100 nm, kT at 298 K.
    #[test]
    fn chain_formulas() {
        let kt = crate::consts::KB * 298.0;
        let g = dipolar_coupling(1e-16, 1e-7, kt);
        let by_hand = 1.256_637_062_12e-6 * 1e-32 / (2.0 * PI * 1e-21 * kt);
        assert!((g / by_hand - 1.0).abs() < 1e-15);
        assert!((mean_chain_length(0.1, 3.0) - (0.1f64 * 2.0f64.exp()).sqrt()).abs() < 1e-15);
        assert!(mean_chain_length(0.1, 5000.0).is_infinite());
    }

    #[test]
    fn unit_vectors_are_isotropic() {
        let mut rng = run_rng(5, 1);
        let n = 200_000;
        let mut m = Vector3::zeros();
        let mut zz = 0.0;
        for _ in 0..n {
            let v = random_unit_vector(&mut rng);
            assert!((v.norm() - 1.0).abs() < 1e-14);
            m += v;
            zz += v.z * v.z;
        }
        // <v> = 0 (each component has variance 1/3); <z^2> = 1/3 (variance 4/45).
        assert!((m / n as f64).norm() < 6.0 * (1.0 / (3.0 * n as f64)).sqrt());
        assert!((zz / n as f64 - 1.0 / 3.0).abs() < 6.0 * (4.0 / (45.0 * n as f64)).sqrt());
    }
}
