//! Brownian capture scenes (thesis 003, sections 6.3–6.4): TOML schema -> experiment -> files.
//!
//! Every key has the thesis default of section 6.3 unless noted; the schema is documented in
//! README ("Scene files"). `experiment` selects what runs:
//! - `"capture"`: capture fraction against time per start region for every combination of the
//!   `[sweep]` lists (alpha, particle radius, aspect ratio), `run.runs` runs each;
//! - `"cascade"`: the cascade estimate, random and/or optimal (section 6.4.5);
//! - `"capture-volume"`: capture-volume maps and volumes (section 6.4.1).
//!
//! Outputs (folder `--out`, default `target/porelab/run/<scene>/`), all written atomically:
//! `capture.csv` (or `cascade.csv`, `capture_volume.csv` + `capture_volume_plane.csv`),
//! `positions.csv` (capture scenes: start and end positions of every particle of every run),
//! `summary.json` (parameters, active terms, final results, seconds).

use super::{Builtin, RunOptions};
use crate::brownian::experiment::{
    axis_at_angle, capture_volume, dipolar_coupling, mean_and_stderr, mean_chain_length,
    run_cascade, run_ensemble, table_6_1_moment, CaptureExperiment, CascadeMode, CylinderSetup,
    MagnetizationLaw, Placement, RegionShape, RunResult,
};
use crate::brownian::{Hydrodynamics, LangevinMoment, NoiseMethod, Params, StepGuard};
use crate::consts::MU0;
use crate::error::{invalid, Error, Result};
use crate::io::plot::CsvPlot;
use crate::io::write_atomic;
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// The built-in Brownian scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "capture-thesis-6.3",
            about:
                "section 6.3 defaults: R = 75 nm, L/D = 20, alpha 0-90 deg, 30 runs x 50 s (hours)",
            toml: include_str!("builtin/capture-thesis-6.3.toml"),
        },
        Builtin {
            name: "capture-quick",
            about:
                "a one-minute capture run: R = 125 nm, L/D = 20, alpha 0 and 90 deg, 4 runs x 5 s",
            toml: include_str!("builtin/capture-quick.toml"),
        },
        Builtin {
            name: "capture-sizes",
            about: "Fig. 6.6a: final capture fraction against particle size (Table 6.1) and alpha",
            toml: include_str!("builtin/capture-sizes.toml"),
        },
        Builtin {
            name: "cascade",
            about: "section 6.4.5: random and optimal cascades, R = 125 nm, 0.5 s per stage",
            toml: include_str!("builtin/cascade.toml"),
        },
        Builtin {
            name: "capture-volume",
            about: "section 6.4.1 / Fig. 6.3: capture volumes, L/D = 5/3 and 20/3, alpha 0/45/90",
            toml: include_str!("builtin/capture-volume.toml"),
        },
        Builtin {
            name: "chains",
            about:
                "section 6.4.6: 500 particles of 75 nm in a dense block near the rim, dipoles on",
            toml: include_str!("builtin/chains.toml"),
        },
    ]
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Scene {
    #[allow(dead_code)]
    kind: String,
    #[serde(default)]
    title: String,
    #[serde(default = "d_experiment")]
    experiment: ExperimentKind,
    #[serde(default)]
    run: RunSection,
    #[serde(default)]
    fluid: Fluid,
    #[serde(default)]
    particles: ParticlesSection,
    #[serde(default)]
    cylinder: CylinderSection,
    #[serde(default)]
    field: FieldSection,
    #[serde(default)]
    forces: ForcesSection,
    #[serde(default)]
    hydrodynamics: HydroSection,
    #[serde(default)]
    sweep: Sweep,
    #[serde(default)]
    cascade: CascadeSection,
    #[serde(default)]
    capture_volume: VolumeSection,
}

fn d_experiment() -> ExperimentKind {
    ExperimentKind::Capture
}

/// String choices of the schema: serde rejects any other value, naming it and the choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
enum ExperimentKind {
    Capture,
    Cascade,
    CaptureVolume,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum GuardKind {
    Refuse,
    Substep,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum MomentLaw {
    Fixed,
    Langevin,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
enum PlacementKind {
    TopSide,
    Uniform,
    Block,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
enum MagnetizationKind {
    StonerWohlfarth,
    FixedAngle,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum MobilityKind {
    FreeDraining,
    Oseen,
    Rpy,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum NoiseKind {
    Cholesky,
    TeaHi,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum CascadeKind {
    Random,
    Optimal,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RunSection {
    seed: u64,
    runs: u64,
    t_max_s: f64,
    dt_s: f64,
    sample_every_s: f64,
    guard: GuardKind,
    max_step_radii: f64,
    max_halvings: u32,
}

impl Default for RunSection {
    fn default() -> Self {
        RunSection {
            seed: 2013,
            runs: 30,
            t_max_s: 50.0,
            dt_s: 5e-5,
            sample_every_s: 0.5,
            guard: GuardKind::Substep,
            max_step_radii: 0.5,
            max_halvings: 20,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
struct Fluid {
    temperature_K: f64,
    viscosity_Pa_s: f64,
}

impl Default for Fluid {
    fn default() -> Self {
        Fluid {
            temperature_K: 298.0,
            viscosity_Pa_s: 1.0e-3,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
struct ParticlesSection {
    radius_m: f64,
    /// Moment magnitude (A m^2); default: Table 6.1 for the radius.
    moment_A_m2: Option<f64>,
    /// Fixed (Table 6.1) or Langevin (eq. 6.22, needs domain_moment_A_m2).
    moment_law: MomentLaw,
    domain_moment_A_m2: Option<f64>,
    placement: PlacementKind,
    n_top: usize,
    n_side: usize,
    region_gap_m: f64,
    region_thickness_m: f64,
    /// Particles of the "uniform" (default 100) and "block" (default 500) placements.
    n: Option<usize>,
    concentration_g_per_mL: f64,
    density_g_per_cm3: f64,
    block_distance_m: f64,
    chain_bond_factor: f64,
}

impl Default for ParticlesSection {
    fn default() -> Self {
        ParticlesSection {
            radius_m: 75e-9,
            moment_A_m2: None,
            moment_law: MomentLaw::Fixed,
            domain_moment_A_m2: None,
            placement: PlacementKind::TopSide,
            n_top: 50,
            n_side: 50,
            region_gap_m: 1e-6,
            region_thickness_m: 300e-6,
            n: None,
            concentration_g_per_mL: 1.0,
            density_g_per_cm3: 5.0,
            block_distance_m: 100e-6,
            chain_bond_factor: 1.1,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct CylinderSection {
    diameter_m: f64,
    aspect_ratio: f64,
    alpha_deg: f64,
    magnetization: MagnetizationKind,
    magnetization_angle_deg: Option<f64>,
    saturation_a_per_m: f64,
}

impl Default for CylinderSection {
    fn default() -> Self {
        CylinderSection {
            diameter_m: 600e-6,
            aspect_ratio: 20.0,
            alpha_deg: 90.0,
            magnetization: MagnetizationKind::StonerWohlfarth,
            magnetization_angle_deg: None,
            saturation_a_per_m: 985e3,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
struct FieldSection {
    /// Applied flux density mu0 H0 (T), along +x.
    b_T: f64,
}

impl Default for FieldSection {
    fn default() -> Self {
        FieldSection { b_T: 1.0 }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
struct ForcesSection {
    mie: bool,
    mie_n: i32,
    mie_m: i32,
    mie_epsilon_kT: f64,
    dipole_pairs: bool,
    dipole_cutoff_radii: f64,
}

impl Default for ForcesSection {
    fn default() -> Self {
        ForcesSection {
            mie: true,
            mie_n: 30,
            mie_m: 15,
            mie_epsilon_kT: 100.0,
            dipole_pairs: true,
            dipole_cutoff_radii: 30.0,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct HydroSection {
    mobility: MobilityKind,
    noise: NoiseKind,
}

impl Default for HydroSection {
    fn default() -> Self {
        HydroSection {
            mobility: MobilityKind::Rpy,
            noise: NoiseKind::TeaHi,
        }
    }
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
struct Sweep {
    alpha_deg: Vec<f64>,
    radius_m: Vec<f64>,
    aspect_ratio: Vec<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct CascadeSection {
    modes: Vec<CascadeKind>,
    stages: usize,
    stage_time_s: f64,
}

impl Default for CascadeSection {
    fn default() -> Self {
        CascadeSection {
            modes: vec![CascadeKind::Random, CascadeKind::Optimal],
            stages: 20,
            stage_time_s: 0.5,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
struct VolumeSection {
    force_cutoff_N: f64,
    margin_m: f64,
    plane_points: usize,
    grid: usize,
}

impl Default for VolumeSection {
    fn default() -> Self {
        VolumeSection {
            force_cutoff_N: 0.5e-15,
            margin_m: 4e-3,
            plane_points: 101,
            grid: 64,
        }
    }
}

/// Parses a Brownian scene; unknown keys and bad values are errors naming them.
fn parse(text: &str, origin: &str) -> Result<Scene> {
    toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: e.to_string(),
    })
}

/// One point of the sweep.
#[derive(Debug, Clone, Copy)]
struct Combo {
    alpha_deg: f64,
    radius_m: f64,
    aspect_ratio: f64,
}

impl Scene {
    /// Particles of one run.
    fn particle_count(&self) -> usize {
        let p = &self.particles;
        match p.placement {
            PlacementKind::TopSide => p.n_top + p.n_side,
            PlacementKind::Uniform => p.n.unwrap_or(100),
            PlacementKind::Block => p.n.unwrap_or(500),
        }
    }

    /// Estimated memory of the runs in flight: with hydrodynamic interactions the 3N x 3N
    /// mobility and its factor (2 x 72 N^2 bytes), plus about 1 kB a particle, per parallel run.
    fn memory_estimate_bytes(&self, threads: usize) -> f64 {
        let n = self.particle_count() as f64;
        let hi = if self.hydrodynamics.mobility == MobilityKind::FreeDraining {
            0.0
        } else {
            2.0 * 72.0 * n * n
        };
        let parallel = (self.run.runs as f64).min(threads.max(1) as f64);
        parallel * (hi + 1024.0 * n)
    }

    fn combos(&self) -> Vec<Combo> {
        let or = |v: &Vec<f64>, d: f64| if v.is_empty() { vec![d] } else { v.clone() };
        let mut out = Vec::new();
        for ar in or(&self.sweep.aspect_ratio, self.cylinder.aspect_ratio) {
            for r in or(&self.sweep.radius_m, self.particles.radius_m) {
                for al in or(&self.sweep.alpha_deg, self.cylinder.alpha_deg) {
                    out.push(Combo {
                        alpha_deg: al,
                        radius_m: r,
                        aspect_ratio: ar,
                    });
                }
            }
        }
        out
    }

    /// The experiment for one sweep point.
    fn experiment(&self, c: Combo) -> Result<CaptureExperiment> {
        let r = &self.run;
        let p = &self.particles;
        // Checked here by key, before a derived quantity (the Mie energy in J, the Table 6.1
        // lookup, an empty mobility matrix) could report the problem under another name.
        let t = self.fluid.temperature_K;
        if self.forces.mie && !(t.is_finite() && t > 0.0) {
            return invalid(format!(
                "fluid.temperature_K = {t}: must be positive and finite (the Mie repulsion's \
                 strength forces.mie_epsilon_kT is in units of kB T; or set forces.mie = false)"
            ));
        }
        let key = if self.sweep.radius_m.is_empty() {
            "particles.radius_m"
        } else {
            "sweep.radius_m"
        };
        if !(c.radius_m.is_finite() && c.radius_m > 0.0) {
            return invalid(format!(
                "{key} = {:e} m: must be positive and finite",
                c.radius_m
            ));
        }
        let count = self.particle_count();
        if count == 0 {
            return invalid(match p.placement {
                PlacementKind::TopSide => {
                    "particles.n_top = 0 and particles.n_side = 0: need at least one particle"
                }
                _ => "particles.n = 0: need at least one particle",
            });
        }
        let params = Params::new(t, self.fluid.viscosity_Pa_s, r.dt_s)?;
        let moment_magnitude = match p.moment_A_m2 {
            Some(m) => m,
            None => table_6_1_moment(c.radius_m)?,
        };
        let moment = match p.moment_law {
            MomentLaw::Fixed => LangevinMoment::fixed(moment_magnitude)?,
            MomentLaw::Langevin => LangevinMoment::langevin(
                moment_magnitude,
                p.domain_moment_A_m2.ok_or_else(|| {
                    Error::InvalidInput(
                        "particles.moment_law = \"langevin\" needs particles.domain_moment_A_m2"
                            .into(),
                    )
                })?,
            )?,
        };
        let placement = match p.placement {
            PlacementKind::TopSide => Placement::TopSide {
                n_top: p.n_top,
                n_side: p.n_side,
                shape: RegionShape::new(p.region_gap_m, p.region_thickness_m)?,
            },
            PlacementKind::Uniform => {
                // Capture runs report TOP and SIDE separately and average them by volume; a
                // uniform population would leave a run's TOP empty at random.
                if self.experiment != ExperimentKind::Cascade {
                    return invalid(
                        "particles.placement = \"uniform\" is for experiment = \"cascade\"; \
                         capture runs use \"top-side\" (TOP and SIDE reported separately and \
                         averaged by volume) or \"block\"",
                    );
                }
                Placement::Uniform {
                    n: p.n.unwrap_or(100),
                    shape: RegionShape::new(p.region_gap_m, p.region_thickness_m)?,
                }
            }
            PlacementKind::Block => {
                crate::error::require_positive(p.concentration_g_per_mL, || {
                    format!(
                        "particles.concentration_g_per_mL = {}",
                        p.concentration_g_per_mL
                    )
                })?;
                let vp = 4.0 / 3.0 * std::f64::consts::PI * c.radius_m.powi(3);
                // Spacing d = (rho V_p / c)^(1/3) (section 6.4.6); g/cm^3 and g/mL cancel.
                let spacing_m = (p.density_g_per_cm3 * vp / p.concentration_g_per_mL).cbrt();
                Placement::Block {
                    n: p.n.unwrap_or(500),
                    spacing_m,
                    distance_m: p.block_distance_m,
                }
            }
        };
        let cy = &self.cylinder;
        let law = match cy.magnetization {
            MagnetizationKind::StonerWohlfarth => MagnetizationLaw::StonerWohlfarth,
            // Default angle of M from the axis: alpha, the axis' angle from the field (so M is
            // along the field, saturated; section 6.4.1 fixes M at alpha from the axis).
            MagnetizationKind::FixedAngle => MagnetizationLaw::FixedAngle(
                cy.magnetization_angle_deg
                    .unwrap_or(c.alpha_deg)
                    .to_radians(),
            ),
        };
        let hydrodynamics = match self.hydrodynamics.mobility {
            MobilityKind::FreeDraining => Hydrodynamics::FreeDraining,
            MobilityKind::Oseen => Hydrodynamics::Oseen,
            MobilityKind::Rpy => Hydrodynamics::Rpy,
        };
        let noise = match self.hydrodynamics.noise {
            NoiseKind::Cholesky => NoiseMethod::Cholesky,
            NoiseKind::TeaHi => NoiseMethod::TeaHi,
        };
        let guard = match r.guard {
            GuardKind::Refuse => StepGuard::Refuse {
                max_fraction: r.max_step_radii,
            },
            GuardKind::Substep => StepGuard::Substep {
                max_fraction: r.max_step_radii,
                max_halvings: r.max_halvings,
            },
        };
        let f = &self.forces;
        let exp = CaptureExperiment {
            params,
            particle_radius_m: c.radius_m,
            moment,
            placement,
            cylinder: CylinderSetup {
                diameter_m: cy.diameter_m,
                aspect_ratio: c.aspect_ratio,
                saturation_a_per_m: cy.saturation_a_per_m,
                law,
            },
            alpha: c.alpha_deg.to_radians(),
            h0: Vector3::new(self.field.b_T / MU0, 0.0, 0.0),
            hydrodynamics,
            noise,
            mie: f.mie.then_some((f.mie_n, f.mie_m, f.mie_epsilon_kT)),
            dipole_cutoff_m: f.dipole_pairs.then_some(f.dipole_cutoff_radii * c.radius_m),
            guard,
            t_max_s: r.t_max_s,
            sample_every_s: r.sample_every_s,
            bond_factor: p.chain_bond_factor,
        };
        exp.validate()?;
        if r.runs == 0 {
            return invalid("run.runs = 0: need at least one run");
        }
        Ok(exp)
    }
}

fn progress(total: u64, quiet: bool, what: &str) -> ProgressBar {
    let pb = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total)
    };
    pb.set_style(
        ProgressStyle::with_template(
            "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} steps (eta {eta})",
        )
        .expect("valid template"),
    );
    pb.set_message(what.to_string());
    // Redrawn every 200 ms from the start, so a run whose first steps are slow (placing and
    // stepping 1e5 particles) shows its bar and elapsed time within the first second.
    if !quiet {
        pb.enable_steady_tick(std::time::Duration::from_millis(200));
    }
    pb
}

/// Parses a Brownian scene and builds (and so validates) the experiment of every point of
/// its size/angle sweep, without running anything.
fn prepare(text: &str, origin: &str) -> Result<(Scene, Vec<Combo>, Vec<CaptureExperiment>)> {
    let scene = parse(text, origin)?;
    let combos = scene.combos();
    let exps = combos
        .iter()
        .map(|c| scene.experiment(*c))
        .collect::<Result<Vec<_>>>()
        .map_err(|e| match e {
            Error::InvalidInput(m) if !m.starts_with(origin) => {
                Error::InvalidInput(format!("{origin}: {m}"))
            }
            other => other,
        })?;
    Ok((scene, combos, exps))
}

/// Checks a Brownian scene as [`run_scene`] does before it runs (`porelab sweep plan`).
pub fn check_scene(text: &str, origin: &str) -> Result<()> {
    prepare(text, origin).map(|_| ())
}

/// Runs a Brownian scene and writes its outputs to `out`.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let started = Instant::now();
    // Build (and so validate) every sweep point before running anything.
    let (scene, combos, exps) = prepare(text, origin)?;
    let first = &exps[0];
    let terms = if scene.experiment == ExperimentKind::CaptureVolume {
        vec!["force on a moment aligned with the local field (eq. 6.20); no dynamics".to_string()]
    } else {
        first
            .simulation(
                first.magnet(axis_at_angle(first.alpha))?,
                vec![Vector3::new(1.0, 1.0, 1.0)],
            )?
            .active_terms()
    };
    let threads = opts.threads.unwrap_or_else(rayon::current_num_threads);
    super::check_memory(
        origin,
        &format!(
            "{} particles per run, mobility \"{}\", {} runs in parallel",
            scene.particle_count(),
            first.hydrodynamics.scene_name(),
            threads.min(scene.run.runs as usize)
        ),
        scene.memory_estimate_bytes(threads),
    )?;
    // Only now, with every sweep point built: a refused scene leaves no empty folder behind.
    crate::io::create_dir(out)?;
    if !opts.quiet {
        eprintln!("porelab run {origin}: {}", scene.title);
        eprintln!("  experiment: {}", serde_json::json!(scene.experiment));
        eprintln!("  active terms: {}", terms.join("; "));
    }
    let mut summary = serde_json::json!({
        "scene": origin,
        "title": scene.title,
        "experiment": scene.experiment,
        "porelab_version": env!("CARGO_PKG_VERSION"),
        "seed": scene.run.seed,
        "runs": scene.run.runs,
        "threads": opts.threads.unwrap_or_else(rayon::current_num_threads),
        "active_terms": terms,
        "parameters": {
            "dt_s": scene.run.dt_s, "t_max_s": scene.run.t_max_s,
            "temperature_K": scene.fluid.temperature_K,
            "viscosity_Pa_s": scene.fluid.viscosity_Pa_s,
            "b_T": scene.field.b_T,
            "cylinder_diameter_m": scene.cylinder.diameter_m,
            "saturation_A_per_m": scene.cylinder.saturation_a_per_m,
            "magnetization": scene.cylinder.magnetization,
            "placement": scene.particles.placement,
            "region_gap_m": scene.particles.region_gap_m,
            "region_thickness_m": scene.particles.region_thickness_m,
        },
    });
    // Finished runs are kept under out/runs/: a killed ensemble resumes where it stopped.
    let store = super::run_store::RunStore::new(out, text);
    store.check_folder()?;
    let results = match scene.experiment {
        ExperimentKind::Capture => run_capture(&scene, &combos, &exps, out, opts, &store)?,
        ExperimentKind::Cascade => run_cascades(&scene, &exps, out, opts, &store)?,
        ExperimentKind::CaptureVolume => run_volumes(&scene, &combos, &exps, out)?,
    };
    summary["results"] = results;
    summary["seconds"] = serde_json::json!(started.elapsed().as_secs_f64());
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .expect("plain JSON")
            .as_bytes(),
    )?;
    if !opts.quiet {
        eprintln!(
            "  wrote {} ({:.1} s)",
            out.display(),
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

fn run_capture(
    scene: &Scene,
    combos: &[Combo],
    exps: &[CaptureExperiment],
    out: &Path,
    opts: &RunOptions,
    store: &super::run_store::RunStore,
) -> Result<serde_json::Value> {
    let runs = scene.run.runs;
    let total: u64 = exps.iter().map(|e| e.steps() * runs).sum();
    let pb = progress(total, opts.quiet, "capture");
    let mut csv = String::from(
        "aspect_ratio,radius_m,alpha_deg,region,time_s,runs,captured_fraction_mean,captured_fraction_stderr,mean_chain_length,fraction_in_chains\n",
    );
    let mut pos_csv = String::from(
        "aspect_ratio,radius_m,alpha_deg,run,particle,region,x0_m,y0_m,z0_m,x_m,y_m,z_m,captured,capture_time_s,brownian\n",
    );
    let mut finals = Vec::new();
    for (point, (c, exp)) in combos.iter().zip(exps).enumerate() {
        let results: Vec<RunResult> = run_ensemble(runs, opts.threads, |run| {
            let (r, loaded) = store.load_or_run(&format!("point{point:03}-run{run:04}"), || {
                exp.run(scene.run.seed, run, &|k| pb.inc(k))
            })?;
            if loaded {
                pb.inc(exp.steps());
            }
            Ok(r)
        })?;
        let regions = results[0].regions.clone();
        let volumes = exp.region_volumes(&regions)?;
        let key = format!("{},{:e},{}", c.aspect_ratio, c.radius_m, c.alpha_deg);
        let n_samples = results[0].samples.len();
        // Per region, plus the volume-weighted average of TOP and SIDE ("ALL").
        let weighted = |s: &crate::brownian::experiment::Sample| -> f64 {
            let w: f64 = volumes.iter().sum();
            s.captured
                .iter()
                .zip(&volumes)
                .map(|(f, v)| f * v)
                .sum::<f64>()
                / w
        };
        for k in 0..n_samples {
            let t = results[0].samples[k].time_s;
            let chain_len: Vec<f64> = results
                .iter()
                .map(|r| r.samples[k].chains.mean_length)
                .collect();
            let chain_frac: Vec<f64> = results
                .iter()
                .map(|r| r.samples[k].chains.fraction_in_chains)
                .collect();
            let (cl, _) = mean_and_stderr(&chain_len);
            let (cf, _) = mean_and_stderr(&chain_frac);
            let mut rows: Vec<(&str, Vec<f64>)> = regions
                .iter()
                .enumerate()
                .map(|(ri, r)| {
                    (
                        r.name(),
                        results.iter().map(|x| x.samples[k].captured[ri]).collect(),
                    )
                })
                .collect();
            if regions.len() > 1 {
                rows.push((
                    "ALL",
                    results.iter().map(|x| weighted(&x.samples[k])).collect(),
                ));
            }
            for (name, vals) in rows {
                let (m, se) = mean_and_stderr(&vals);
                writeln!(
                    csv,
                    "{key},{name},{t:.6e},{runs},{m:.6},{se:.6},{cl:.4},{cf:.4}"
                )
                .unwrap();
            }
        }
        for r in &results {
            for i in 0..r.initial.len() {
                let (p0, p1) = (r.initial[i], r.last[i]);
                writeln!(
                    pos_csv,
                    "{key},{},{i},{},{:e},{:e},{:e},{:e},{:e},{:e},{},{},{}",
                    r.run,
                    r.region_of[i].name(),
                    p0.x,
                    p0.y,
                    p0.z,
                    p1.x,
                    p1.y,
                    p1.z,
                    r.capture_time_s[i].is_some(),
                    r.capture_time_s[i].map_or(String::new(), |t| format!("{t:e}")),
                    r.brownian[i]
                )
                .unwrap();
            }
        }
        let mut per_region = serde_json::Map::new();
        for (ri, reg) in regions.iter().enumerate() {
            let finals_r: Vec<f64> = results
                .iter()
                .map(|x| x.samples[n_samples - 1].captured[ri])
                .collect();
            let brown: Vec<f64> = results
                .iter()
                .map(|x| {
                    let idx: Vec<usize> = (0..x.region_of.len())
                        .filter(|&i| x.region_of[i] == *reg)
                        .collect();
                    idx.iter().filter(|&&i| x.brownian[i]).count() as f64 / idx.len().max(1) as f64
                })
                .collect();
            let (m, se) = mean_and_stderr(&finals_r);
            let (bm, bse) = mean_and_stderr(&brown);
            per_region.insert(
                reg.name().into(),
                serde_json::json!({"captured_fraction": m, "stderr": se,
                                   "brownian_fraction_eq_6_24": bm, "brownian_stderr": bse,
                                   "region_volume_m3": volumes[ri]}),
            );
        }
        if regions.len() > 1 {
            let all: Vec<f64> = results
                .iter()
                .map(|x| weighted(&x.samples[n_samples - 1]))
                .collect();
            let (m, se) = mean_and_stderr(&all);
            per_region.insert(
                "ALL".into(),
                serde_json::json!({"captured_fraction": m, "stderr": se}),
            );
        }
        let mu = match exp.moment {
            LangevinMoment::Fixed(m) => m,
            LangevinMoment::Langevin { saturation, .. } => saturation,
        };
        let gamma = dipolar_coupling(mu, 2.0 * c.radius_m, exp.params.kt());
        let mut entry = serde_json::json!({
            "aspect_ratio": c.aspect_ratio, "radius_m": c.radius_m, "alpha_deg": c.alpha_deg,
            "moment_A_m2": mu,
            "magnetization_A_per_m": exp.magnet(axis_at_angle(exp.alpha))?.magnetization.as_slice(),
            "final": per_region,
            "dipolar_coupling_gamma_eq_6_25": gamma,
        });
        if let Placement::Block { spacing_m, .. } = exp.placement {
            let phi0 = 4.0 / 3.0 * std::f64::consts::PI * c.radius_m.powi(3) / spacing_m.powi(3);
            let chains: Vec<f64> = results
                .iter()
                .map(|r| {
                    r.samples
                        .iter()
                        .map(|s| s.chains.mean_length)
                        .fold(0.0, f64::max)
                })
                .collect();
            entry["block"] = serde_json::json!({
                "lattice_spacing_m": spacing_m, "volume_fraction": phi0,
                "mean_chain_length_eq_6_26": mean_chain_length(phi0, gamma),
                "largest_mean_chain_length_observed": mean_and_stderr(&chains).0,
            });
        }
        finals.push(entry);
    }
    pb.finish_and_clear();
    write_atomic(&out.join("capture.csv"), csv.as_bytes())?;
    write_atomic(&out.join("positions.csv"), pos_csv.as_bytes())?;
    CsvPlot {
        title: "Captured fraction (mean over runs, one standard error)",
        x: "time_s",
        y: "captured_fraction_mean",
        y_err: Some("captured_fraction_stderr"),
        group_by: &["aspect_ratio", "radius_m", "alpha_deg", "region"],
        x_label: "time (s)",
        y_label: "captured fraction",
        ..Default::default()
    }
    .write_or_warn(&out.join("capture.svg"), &csv);
    // The results on stdout (even with --quiet, which hides progress), the report on stderr.
    for f in &finals {
        println!(
            "L/D = {}, R = {} m, alpha = {} deg: {}",
            f["aspect_ratio"], f["radius_m"], f["alpha_deg"], f["final"]
        );
    }
    Ok(serde_json::Value::Array(finals))
}

fn run_cascades(
    scene: &Scene,
    exps: &[CaptureExperiment],
    out: &Path,
    opts: &RunOptions,
    store: &super::run_store::RunStore,
) -> Result<serde_json::Value> {
    let cs = &scene.cascade;
    let modes = cs
        .modes
        .iter()
        .map(|m| match m {
            CascadeKind::Random => CascadeMode::Random,
            CascadeKind::Optimal => CascadeMode::Optimal,
        })
        .collect::<Vec<_>>();
    if exps.len() != 1 {
        return invalid("the cascade takes no [sweep] lists (one particle size and aspect ratio)");
    }
    let exp = &exps[0];
    let runs = scene.run.runs;
    let stage_steps = (cs.stage_time_s / exp.params.dt).round() as u64;
    let pb = progress(
        modes.len() as u64 * runs * cs.stages as u64 * stage_steps,
        opts.quiet,
        "cascade",
    );
    let mut csv =
        String::from("mode,time_s,runs,captured_fraction_mean,captured_fraction_stderr\n");
    let mut summary = serde_json::Map::new();
    for mode in modes {
        let curves = run_ensemble(runs, opts.threads, |run| {
            let tag = format!("cascade-{mode:?}-run{run:04}").to_lowercase();
            let (curve, loaded) = store.load_or_run(&tag, || {
                run_cascade(
                    exp,
                    mode,
                    cs.stages,
                    cs.stage_time_s,
                    scene.run.seed,
                    run,
                    &|k| pb.inc(k),
                )
            })?;
            if loaded {
                pb.inc(cs.stages as u64 * stage_steps);
            }
            Ok(curve)
        })?;
        // Curves stop early when every particle is captured: extend them at 1.
        let len = curves.iter().map(|c| c.len()).max().unwrap_or(0);
        let times: Vec<f64> = curves
            .iter()
            .find(|c| c.len() == len)
            .map(|c| c.iter().map(|x| x.0).collect())
            .unwrap_or_default();
        let name = format!("{mode:?}").to_lowercase();
        let mut t90 = None;
        for (k, t) in times.iter().enumerate() {
            let vals: Vec<f64> = curves
                .iter()
                .map(|c| c.get(k).map_or(1.0, |x| x.1))
                .collect();
            let (m, se) = mean_and_stderr(&vals);
            if t90.is_none() && m >= 0.9 {
                t90 = Some(*t);
            }
            writeln!(csv, "{name},{t:.6e},{runs},{m:.6},{se:.6}").unwrap();
        }
        summary.insert(name, serde_json::json!({"time_to_90_percent_s": t90}));
    }
    pb.finish_and_clear();
    write_atomic(&out.join("cascade.csv"), csv.as_bytes())?;
    CsvPlot {
        title: "Cascade: captured fraction (mean over runs, one standard error)",
        x: "time_s",
        y: "captured_fraction_mean",
        y_err: Some("captured_fraction_stderr"),
        group_by: &["mode"],
        x_label: "time (s)",
        y_label: "captured fraction",
        ..Default::default()
    }
    .write_or_warn(&out.join("cascade.svg"), &csv);
    println!(
        "time to 90% capture: {}",
        serde_json::Value::Object(summary.clone())
    );
    Ok(serde_json::Value::Object(summary))
}

fn run_volumes(
    scene: &Scene,
    combos: &[Combo],
    exps: &[CaptureExperiment],
    out: &Path,
) -> Result<serde_json::Value> {
    let v = &scene.capture_volume;
    let mut csv = String::from(
        "aspect_ratio,radius_m,alpha_deg,capture_volume_m3,cylinder_volume_m3,ratio,reaches_box\n",
    );
    let mut plane =
        String::from("aspect_ratio,radius_m,alpha_deg,x_m,z_m,fx_N,fy_N,fz_N,force_N,captured\n");
    let mut rows = Vec::new();
    for (c, exp) in combos.iter().zip(exps) {
        let magnet = exp.magnet(axis_at_angle(exp.alpha))?;
        let mu = match exp.moment {
            LangevinMoment::Fixed(m) => m,
            LangevinMoment::Langevin { saturation, .. } => saturation,
        };
        let cv = capture_volume(
            &magnet,
            &exp.h0,
            mu,
            v.force_cutoff_N,
            v.margin_m,
            v.plane_points,
            v.grid,
        )?;
        let key = format!("{},{:e},{}", c.aspect_ratio, c.radius_m, c.alpha_deg);
        let ratio = cv.volume_m3 / cv.cylinder_volume_m3;
        writeln!(
            csv,
            "{key},{:e},{:e},{ratio:.6},{}",
            cv.volume_m3, cv.cylinder_volume_m3, cv.reaches_box
        )
        .unwrap();
        if cv.reaches_box {
            eprintln!(
                "  warning: L/D = {}, alpha = {} deg: the capture volume reaches the map box; \
                 it is a lower bound (increase capture_volume.margin_m)",
                c.aspect_ratio, c.alpha_deg
            );
        }
        for (x, z, f, cap) in &cv.plane {
            writeln!(
                plane,
                "{key},{x:e},{z:e},{:e},{:e},{:e},{:e},{cap}",
                f.x,
                f.y,
                f.z,
                f.norm()
            )
            .unwrap();
        }
        rows.push(serde_json::json!({"aspect_ratio": c.aspect_ratio, "radius_m": c.radius_m,
            "alpha_deg": c.alpha_deg, "capture_volume_m3": cv.volume_m3, "ratio_to_cylinder": ratio, "reaches_box": cv.reaches_box}));
    }
    write_atomic(&out.join("capture_volume.csv"), csv.as_bytes())?;
    write_atomic(&out.join("capture_volume_plane.csv"), plane.as_bytes())?;
    Ok(serde_json::Value::Array(rows))
}

/// `kind = "brownian"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "brownian"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("run.seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        check_scene(text, origin)
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_and_builds() {
        for b in builtins() {
            let s = parse(b.toml, b.name).unwrap_or_else(|e| panic!("{}: {e}", b.name));
            for c in s.combos() {
                s.experiment(c)
                    .unwrap_or_else(|e| panic!("{}: {e}", b.name));
            }
        }
    }

    #[test]
    fn unknown_keys_are_named() {
        let e = parse("kind = \"brownian\"\n[run]\nseeed = 3\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("seeed"), "{e}");
        let e = parse("kind = \"brownian\"\n[cylinder]\nalpha = 3\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("alpha"), "{e}");
    }

    #[test]
    fn bad_values_are_named() {
        let e = parse(
            "kind = \"brownian\"\n[hydrodynamics]\nmobility = \"rotne\"\n",
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("rotne") && e.contains("rpy"), "{e}");
        let s = parse(
            "kind = \"brownian\"\n[particles]\nradius_m = 60e-9\n",
            "x.toml",
        )
        .unwrap();
        let e = s.experiment(s.combos()[0]).unwrap_err().to_string();
        assert!(e.contains("Table 6.1"), "{e}");
        let s = parse(
            "kind = \"brownian\"\n[particles]\nplacement = \"uniform\"\n",
            "x.toml",
        )
        .unwrap();
        let e = s.experiment(s.combos()[0]).unwrap_err().to_string();
        assert!(e.contains("uniform") && e.contains("cascade"), "{e}");
    }

    /// The outputs depend only on the seed: one worker thread and two give identical files.
    #[test]
    fn outputs_do_not_depend_on_thread_count() {
        let scene = "kind = \"brownian\"\n[run]\nseed = 9\nruns = 3\nt_max_s = 0.05\n\
                     dt_s = 5e-4\nsample_every_s = 0.01\n[particles]\nradius_m = 212e-9\n\
                     n_top = 3\nn_side = 3\nregion_thickness_m = 20e-6\n\
                     [hydrodynamics]\nmobility = \"free-draining\"\n";
        let base = std::env::temp_dir().join(format!("porelab-threads-{}", std::process::id()));
        let mut outputs = Vec::new();
        for threads in [1, 2] {
            let out = base.join(threads.to_string());
            let opts = RunOptions {
                out: None,
                threads: Some(threads),
                quiet: true,
                checkpoint_every_seconds: None,
            };
            run_scene(scene, "test", &out, &opts).unwrap();
            let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
            outputs.push((read("capture.csv"), read("positions.csv")));
        }
        std::fs::remove_dir_all(&base).ok();
        assert_eq!(outputs[0], outputs[1]);
        assert!(outputs[0].1.lines().count() == 1 + 3 * 6);
    }

    /// A killed ensemble resumes from its finished runs and ends with the same outputs as an
    /// uninterrupted run; a run file of another scene is refused.
    #[test]
    fn resumes_from_finished_runs() {
        let scene = "kind = \"brownian\"\n[run]\nseed = 11\nruns = 3\nt_max_s = 0.05\n\
                     dt_s = 5e-4\nsample_every_s = 0.01\n[particles]\nradius_m = 212e-9\n\
                     n_top = 3\nn_side = 3\nregion_thickness_m = 20e-6\n\
                     [hydrodynamics]\nmobility = \"free-draining\"\n";
        let base = std::env::temp_dir().join(format!("porelab-resume-{}", std::process::id()));
        // a folder left by an earlier process of the same id would be resumed from
        std::fs::remove_dir_all(&base).ok();
        let opts = RunOptions {
            quiet: true,
            ..Default::default()
        };
        let read = |out: &Path| {
            ["capture.csv", "positions.csv"].map(|f| std::fs::read_to_string(out.join(f)).unwrap())
        };
        let whole = base.join("whole");
        run_scene(scene, "test", &whole, &opts).unwrap();
        // The "killed" run: run 1 never finished (its file is gone, a stale temporary stays),
        // and no outputs were written.
        let killed = base.join("killed");
        run_scene(scene, "test", &killed, &opts).unwrap();
        let runs = killed.join("runs");
        std::fs::remove_file(runs.join("point000-run0001.json")).unwrap();
        std::fs::write(runs.join(".point000-run0001.json.tmp-1-0"), b"{half").unwrap();
        for f in ["capture.csv", "positions.csv", "summary.json"] {
            std::fs::remove_file(killed.join(f)).unwrap();
        }
        run_scene(scene, "test", &killed, &opts).unwrap();
        assert!(read(&whole) == read(&killed), "resumed outputs differ");
        // The same folder with another scene text is refused, naming the run file.
        let other = scene.replace("seed = 11", "seed = 12");
        let e = run_scene(&other, "test", &killed, &opts)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("different scene") && e.contains("run0000.json"),
            "{e}"
        );
        std::fs::remove_dir_all(&base).ok();
    }
}
