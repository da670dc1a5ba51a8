//! Coupled LBM–DEM scenes (`kind = "coupled"`): a DEM bed (the `[dem]` table is a DEM scene,
//! [`super::dem`], without its `kind`) in a lattice-Boltzmann fluid driven by a pressure
//! gradient, two-way coupled by [`crate::coupled`]. SI units; z is the vertical.
//!
//! ```toml
//! kind = "coupled"
//! title = "..."
//! [dem]                               # a DEM scene: particles, box, contact, drivers, run
//! ...                                 # (drivers.fluid_density_kg_m3 is set to the fluid's)
//! [fluid]
//! dx_m = 4e-4                         # lattice spacing: lx, ly whole multiples (required)
//! tau = 0.8                           # BGK relaxation time [0.8]; dt = (tau - 1/2)/3 dx^2/nu
//! density_kg_m3 = 1000.0              # [1000]
//! viscosity_pa_s = 1e-3               # [1e-3]
//! pressure_gradient_pa_m = [0, 0, 0]  # imposed mean grad p; flow goes down for +z [0]
//! balance_weight = false              # add the gradient carrying the particles' weight [false]
//! [fluid.basesheet]                   # permeable bottom under the DEM floor [none]
//! thickness_m = 1e-3                  # h, whole cells; the lattice spans z = -h .. top
//! permeability_m2 = 1e-10             # K: Darcy drag -(mu/K) u, drop mu U h / K
//! [coupling]
//! overlap = "exact"                   # "exact" sphere-cube | "seed-lens" [exact]
//! drag_switch = "blend"               # "blend" (Huilin-Gidaspow) | "sharp" [blend]
//! eps_min = 0.1                       # porosity floor per cell [0.1]
//! dem_steps_per_lbm_step = 100        # M [100]
//! max_move_cells = 0.1                # refusal: displacement per coupling step [0.1]
//! max_relaxation = 0.5                # refusal: gamma dt_LBM / m [0.5]
//! frozen = false                      # fixed bed: particles do not move [false]
//! [output]
//! time_s = 0.1                        # simulated time (required)
//! frames_every_s = 0.05               # XYZ + VTK frames [time_s]
//! profile_every_s = 0.01              # porosity-profile rows [time_s / 20]
//! ```
//!
//! Outputs: `frame_NNNN.xyz` (particles) and `fluid_NNNN.vtk` (porosity, velocity m/s,
//! pressure deviation Pa) at the same times, `porosity_profile.csv` (time, z of each layer,
//! porosity), `summary.json`.

use super::{dem as dem_scene, on_threads, parse_checkpoint, Builtin, RunOptions};
use crate::coupled::checkpoint::CoupledState;
use crate::coupled::{Basesheet, Coupled, CoupledSetup, Overlap, Switch};
use crate::error::{invalid, Error};
use crate::io::{vtk, write_atomic, xyz};
use crate::Result;
use nalgebra::Vector3;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "coupled-quick",
            about:
                "coupled LBM-DEM: 300 spheres d = 400 um consolidated by a drainage flow (seconds)",
            toml: include_str!("builtin/coupled-quick.toml"),
        },
        Builtin {
            name: "coupled-seed-bed",
            about:
                "coupled LBM-DEM: seed 002 Fig. 12, 2014 spheres d = 400 um under a pressure drop",
            toml: include_str!("builtin/coupled-seed-bed.toml"),
        },
    ]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    kind: String,
    #[serde(default)]
    title: String,
    dem: toml::Table,
    fluid: FluidSpec,
    #[serde(default)]
    coupling: CouplingSpec,
    output: OutputSpec,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct FluidSpec {
    dx_m: f64,
    tau: Option<f64>,
    density_kg_m3: Option<f64>,
    viscosity_pa_s: Option<f64>,
    pressure_gradient_pa_m: Option<[f64; 3]>,
    balance_weight: Option<bool>,
    basesheet: Option<BasesheetSpec>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct BasesheetSpec {
    thickness_m: f64,
    permeability_m2: f64,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct CouplingSpec {
    overlap: Option<String>,
    drag_switch: Option<String>,
    eps_min: Option<f64>,
    dem_steps_per_lbm_step: Option<u64>,
    max_move_cells: Option<f64>,
    max_relaxation: Option<f64>,
    frozen: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputSpec {
    time_s: f64,
    frames_every_s: Option<f64>,
    profile_every_s: Option<f64>,
}

/// A parsed coupled scene.
pub struct CoupledScene {
    pub title: String,
    pub dem: dem_scene::DemScene,
    pub setup: CoupledSetup,
    pub time_s: f64,
    pub frames_every_s: f64,
    pub profile_every_s: f64,
}

pub fn parse_scene(text: &str, origin: &str) -> Result<CoupledScene> {
    let f: SceneFile = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("coupled scene: {e}"),
    })?;
    if f.kind != "coupled" {
        return invalid(format!(
            "{origin}: kind = \"{}\": a coupled scene needs kind = \"coupled\"",
            f.kind
        ));
    }
    let rho_f = f.fluid.density_kg_m3.unwrap_or(1000.0);
    let mut dem = f.dem.clone();
    dem.insert("kind".into(), toml::Value::String("dem".into()));
    let drivers = dem
        .entry("drivers")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let Some(drivers) = drivers.as_table_mut() else {
        return invalid(format!("{origin}: dem.drivers must be a table"));
    };
    for key in [
        "viscosity_pa_s",
        "fluid_velocity_m_s",
        "fluid_density_kg_m3",
    ] {
        if drivers.contains_key(key) {
            return invalid(format!(
                "{origin}: dem.drivers.{key}: not allowed in a coupled scene (the fluid is the \
                 [fluid] table's lattice-Boltzmann flow)"
            ));
        }
    }
    drivers.insert("fluid_density_kg_m3".into(), toml::Value::Float(rho_f));
    let dem_text = toml::to_string(&dem).map_err(|e| Error::InvalidInput(e.to_string()))?;
    let dem = dem_scene::parse_scene(&dem_text, &format!("{origin} [dem]"))?;
    let c = &f.coupling;
    let overlap = match c.overlap.as_deref().unwrap_or("exact") {
        "exact" => Overlap::Exact,
        "seed-lens" => Overlap::SeedLens,
        o => {
            return invalid(format!(
                "{origin}: coupling.overlap = \"{o}\": must be \"exact\" or \"seed-lens\""
            ))
        }
    };
    let switch = match c.drag_switch.as_deref().unwrap_or("blend") {
        "blend" => Switch::Blend,
        "sharp" => Switch::Sharp,
        o => {
            return invalid(format!(
                "{origin}: coupling.drag_switch = \"{o}\": must be \"blend\" or \"sharp\""
            ))
        }
    };
    let dx = f.fluid.dx_m;
    if !(dx.is_finite() && dx > 0.0) {
        return invalid(format!("{origin}: fluid.dx_m = {dx}: must be positive"));
    }
    let time_s = f.output.time_s;
    if !(time_s.is_finite() && time_s > 0.0) {
        return invalid(format!(
            "{origin}: output.time_s = {time_s}: must be positive"
        ));
    }
    let frames = f.output.frames_every_s.unwrap_or(time_s);
    let prof = f.output.profile_every_s.unwrap_or(time_s / 20.0);
    for (k, v) in [
        ("output.frames_every_s", frames),
        ("output.profile_every_s", prof),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return invalid(format!("{origin}: {k} = {v}: must be positive"));
        }
    }
    let g = f.fluid.pressure_gradient_pa_m.unwrap_or([0.0; 3]);
    let setup = CoupledSetup {
        dx_m: dx,
        tau: f.fluid.tau.unwrap_or(0.8),
        fluid_density_kg_m3: rho_f,
        viscosity_pa_s: f.fluid.viscosity_pa_s.unwrap_or(1e-3),
        nz: ((dem.height_m / dx) * (1.0 - 1e-12)).ceil().max(1.0) as usize,
        overlap,
        switch,
        eps_min: c.eps_min.unwrap_or(0.1),
        grad_p_pa_m: Vector3::from(g),
        balance_weight: f.fluid.balance_weight.unwrap_or(false),
        dem_steps: c.dem_steps_per_lbm_step.unwrap_or(100),
        max_move_cells: c.max_move_cells.unwrap_or(0.1),
        max_relaxation: c.max_relaxation.unwrap_or(0.5),
        frozen: c.frozen.unwrap_or(false),
        basesheet: f.fluid.basesheet.as_ref().map(|b| Basesheet {
            thickness_m: b.thickness_m,
            permeability_m2: b.permeability_m2,
        }),
    };
    Ok(CoupledScene {
        title: f.title,
        dem,
        setup,
        time_s,
        frames_every_s: frames,
        profile_every_s: prof,
    })
}

/// The coupled system of a parsed scene (the DEM's random dispersion in the lattice).
pub fn build(scene: &CoupledScene) -> Result<Coupled> {
    let dem = dem_scene::build(&scene.dem)?;
    Coupled::new(dem, scene.setup.clone())
}

/// The run's summary (summary.json).
#[derive(Debug, Clone, serde::Serialize)]
pub struct CoupledSummary {
    pub porelab_version: &'static str,
    pub threads: usize,
    pub title: String,
    pub n: usize,
    pub lattice: [usize; 3],
    pub dx_m: f64,
    pub dt_lbm_s: f64,
    pub dt_dem_s: f64,
    pub dem_steps_per_lbm_step: u64,
    pub overlap: &'static str,
    pub drag_switch: &'static str,
    pub coupling_steps: u64,
    pub simulated_time_s: f64,
    pub seconds: f64,
    pub timing: crate::coupled::Timing,
    pub coupling_share: f64,
    pub momentum_imbalance: f64,
    pub fluid_mass_drift: f64,
    pub max_move_cells: f64,
    pub mean_particle_velocity_m_s: [f64; 3],
    pub mean_fluid_velocity_m_s: [f64; 3],
}

fn frame(c: &Coupled, out: &Path, k: usize) -> Result<()> {
    let parts: Vec<xyz::XyzParticle> = (0..c.dem.p.len())
        .map(|i| xyz::XyzParticle::sphere(c.dem.p.pos[i], c.dem.p.radius[i]))
        .collect();
    let d = c.dims;
    let dx = c.setup.dx_m;
    // the lattice starts at the basesheet's bottom, z = -h
    let z0 = c.sheet_cells as f64 * dx;
    let cell = xyz::Cell {
        lengths: [d.nx as f64 * dx, d.ny as f64 * dx, d.nz as f64 * dx],
        origin: [0.0, 0.0, -z0],
        pbc: [true, true, false],
    };
    xyz::write(
        &out.join(format!("frame_{k:04}.xyz")),
        &cell,
        &parts,
        &[("Time", format!("{}", c.time_s))],
    )?;
    let u = c.velocity_si();
    let p = c.pressure_si();
    vtk::write_image_data(
        &out.join(format!("fluid_{k:04}.vtk")),
        &format!("porelab coupled t = {} s", c.time_s),
        [d.nx, d.ny, d.nz],
        dx,
        [0.0, 0.0, -z0],
        &[
            vtk::CellField::Scalar("porosity", &c.eps),
            vtk::CellField::Vector("velocity_m_s", &u),
            vtk::CellField::Scalar("pressure_deviation_pa", &p),
        ],
    )
}

/// Runs a parsed scene from the system's current step to the end of its time, calling
/// `on_step` after each coupling step; `on_step` returns false to stop the run there.
pub fn run(
    scene: &CoupledScene,
    c: &mut Coupled,
    mut on_step: impl FnMut(&Coupled) -> Result<bool>,
) -> Result<()> {
    let steps = total_steps(scene, c);
    while c.steps < steps {
        c.step()?;
        if !on_step(c)? {
            break;
        }
    }
    Ok(())
}

/// Coupling steps of the whole run.
fn total_steps(scene: &CoupledScene, c: &Coupled) -> u64 {
    (scene.time_s / c.units.dt).ceil() as u64
}

/// The checkpoint file: the scene's fingerprint, the outputs written so far (porosity rows,
/// frame count), the initial fluid mass (the summary's drift) and the engine state.
#[derive(serde::Serialize, serde::Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: u64,
    mass0: u64,
    frames: usize,
    profile: String,
    /// Wall-clock seconds per part so far (the summary's shares; not part of the result).
    timing: crate::coupled::Timing,
    state: CoupledState,
}

/// Format 2: the neighbour-list pairs keep no forces (those are recomputed every step).
const CHECKPOINT_FORMAT: u32 = 2;

/// Restores `c` from the checkpoint at `path`: (seconds so far, initial mass, frames written,
/// porosity rows so far).
fn read_checkpoint(
    path: &Path,
    fingerprint: &str,
    c: &mut Coupled,
) -> Result<(f64, f64, usize, String)> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let bytes =
        std::fs::read(path).map_err(|e| file_err(format!("cannot read the checkpoint: {e}")))?;
    let k: Checkpoint = parse_checkpoint(&bytes, CHECKPOINT_FORMAT, "coupled").map_err(file_err)?;
    if k.scene != fingerprint {
        return Err(file_err(
            "written by a different scene (its text differs): delete it to start afresh, or \
             choose another output folder with --out"
                .into(),
        ));
    }
    c.load_state(&k.state)
        .map_err(|e| file_err(e.to_string()))?;
    c.timing = k.timing;
    Ok((
        f64::from_bits(k.seconds),
        f64::from_bits(k.mass0),
        k.frames,
        k.profile,
    ))
}

pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    run_scene_limited(text, origin, out, opts, None)
}

/// Runs (or resumes from `out/checkpoint.json`) a scene; with `max_steps` it stops after that
/// many coupling steps of this call, leaving the checkpoint behind as an interrupted run would
/// (for tests). A checkpoint is written with the porosity rows, at most every
/// `--checkpoint-every` seconds, and removed when the outputs are complete.
pub(crate) fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_steps: Option<u64>,
) -> Result<()> {
    opts.check_checkpoint_interval()?;
    let scene = parse_scene(text, origin)?;
    let mut c = build(&scene)?;
    let fingerprint = format!("{:016x}", crate::io::fnv1a64(text.as_bytes()));
    let ckpt_path = out.join("checkpoint.json");
    let (base_seconds, mass0, mut frames, mut profile) = if ckpt_path.exists() {
        let r = read_checkpoint(&ckpt_path, &fingerprint, &mut c)?;
        if !opts.quiet {
            eprintln!(
                "resuming {origin} from {} (coupling step {}, t = {:e} s)",
                ckpt_path.display(),
                c.steps,
                c.time_s
            );
        }
        r
    } else {
        (0.0, c.lbm.mass(), 0, String::from("time_s,z_m,porosity\n"))
    };
    let d = c.dims;
    eprintln!(
        "coupled: {} spheres, lattice {} x {} x {} (dx = {:e} m), dt_LBM = {:e} s, M = {} DEM \
         steps of dt_DEM = {:e} s; porosity {}, drag switch {}; DEM terms: {}",
        c.dem.p.len(),
        d.nx,
        d.ny,
        d.nz,
        c.setup.dx_m,
        c.units.dt,
        c.setup.dem_steps,
        c.dt_dem_s,
        c.setup.overlap.name(),
        c.setup.switch.name(),
        c.dem.active().names().join(", ")
    );
    crate::io::create_dir(out)?;
    let total = total_steps(&scene, &c);
    let bar = if opts.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} [{elapsed_precise}] {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.set_position(c.steps);
        b
    };
    let frame_steps = ((scene.frames_every_s / c.units.dt).round() as u64).max(1);
    let prof_steps = ((scene.profile_every_s / c.units.dt).round() as u64).max(1);
    let start = Instant::now();
    let mut last_checkpoint = Instant::now();
    let first_step = c.steps;
    let save = |c: &Coupled, frames: usize, profile: &str| -> Result<()> {
        let k = Checkpoint {
            format: CHECKPOINT_FORMAT,
            scene: fingerprint.clone(),
            seconds: (base_seconds + start.elapsed().as_secs_f64()).to_bits(),
            mass0: mass0.to_bits(),
            frames,
            profile: profile.to_string(),
            timing: c.timing,
            state: c.save_state(),
        };
        let bytes = serde_json::to_vec(&k).map_err(|e| Error::InvalidInput(e.to_string()))?;
        write_atomic(&ckpt_path, &bytes)
    };
    let body = || -> Result<bool> {
        if c.steps == 0 {
            c.update_porosity()?;
            frame(&c, out, frames)?;
            frames += 1;
        }
        let mut interrupted = false;
        run(&scene, &mut c, |c| {
            if c.steps % prof_steps == 0 {
                let dz = c.setup.dx_m;
                let z0 = c.sheet_cells as f64 * dz;
                for (k, e) in c.porosity_profile().iter().enumerate() {
                    let z = (k as f64 + 0.5) * dz - z0;
                    let _ = writeln!(profile, "{},{},{}", c.time_s, z, e);
                }
            }
            if c.steps % frame_steps == 0 {
                frame(c, out, frames)?;
                frames += 1;
            }
            if c.steps % prof_steps == 0
                && c.steps < total
                && opts
                    .checkpoint_every_seconds
                    .is_none_or(|t| last_checkpoint.elapsed().as_secs_f64() >= t)
            {
                save(c, frames, &profile)?;
                last_checkpoint = Instant::now();
            }
            bar.set_position(c.steps);
            bar.set_message(format!(
                "t = {:.4e} s, imbalance {:.1e}",
                c.time_s, c.worst_balance
            ));
            if max_steps.is_some_and(|m| c.steps - first_step >= m) && c.steps < total {
                interrupted = true;
                return Ok(false);
            }
            Ok(true)
        })?;
        Ok(interrupted)
    };
    let interrupted = on_threads(opts.threads, body)?;
    bar.finish_and_clear();
    if interrupted {
        // the checkpoint holds the state reached
        return save(&c, frames, &profile);
    }
    let seconds = base_seconds + start.elapsed().as_secs_f64();
    write_atomic(&out.join("porosity_profile.csv"), profile.as_bytes())?;
    let summary = summarize(&scene, &c, seconds, mass0, opts.threads);
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    // the outputs are complete: the checkpoint is no longer needed
    if ckpt_path.exists() {
        std::fs::remove_file(&ckpt_path).map_err(|e| Error::File {
            path: ckpt_path.display().to_string(),
            msg: format!("cannot remove the finished run's checkpoint: {e}"),
        })?;
    }
    println!(
        "{origin}: {} coupling steps ({:.3e} s simulated) in {:.1} s; shares LBM {:.1} %, DEM \
         {:.1} %, coupling {:.1} %; momentum imbalance (walls included) {:.1e}, mass drift {:.1e}",
        summary.coupling_steps,
        summary.simulated_time_s,
        seconds,
        100.0 * summary.timing.lbm_s / seconds,
        100.0 * summary.timing.dem_s / seconds,
        100.0 * summary.coupling_share,
        summary.momentum_imbalance,
        summary.fluid_mass_drift
    );
    println!("outputs in {}", out.display());
    Ok(())
}

pub fn summarize(
    scene: &CoupledScene,
    c: &Coupled,
    seconds: f64,
    mass0: f64,
    threads: Option<usize>,
) -> CoupledSummary {
    let n = c.dem.p.len().max(1) as f64;
    let vp = c.dem.p.vel.iter().fold(Vector3::zeros(), |a, v| a + v) / n;
    let u = c.velocity_si();
    let mut uf = [0.0; 3];
    for v in &u {
        for k in 0..3 {
            uf[k] += v[k] / u.len() as f64;
        }
    }
    let t = c.timing;
    CoupledSummary {
        porelab_version: env!("CARGO_PKG_VERSION"),
        threads: threads.unwrap_or_else(rayon::current_num_threads),
        title: scene.title.clone(),
        n: c.dem.p.len(),
        lattice: [c.dims.nx, c.dims.ny, c.dims.nz],
        dx_m: c.setup.dx_m,
        dt_lbm_s: c.units.dt,
        dt_dem_s: c.dt_dem_s,
        dem_steps_per_lbm_step: c.setup.dem_steps,
        overlap: c.setup.overlap.name(),
        drag_switch: c.setup.switch.name(),
        coupling_steps: c.steps,
        simulated_time_s: c.time_s,
        seconds,
        timing: t,
        coupling_share: t.coupling_s / (t.lbm_s + t.dem_s + t.coupling_s).max(1e-300),
        momentum_imbalance: c.worst_balance,
        fluid_mass_drift: (c.lbm.mass() - mass0).abs() / mass0,
        max_move_cells: c.max_move_seen_cells,
        mean_particle_velocity_m_s: [vp.x, vp.y, vp.z],
        mean_fluid_velocity_m_s: uf,
    }
}

/// `kind = "coupled"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "coupled"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("dem.seed")
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
    use super::*;

    fn quiet() -> RunOptions {
        RunOptions {
            quiet: true,
            ..Default::default()
        }
    }

    /// A run stopped after 30 coupling steps and resumed from its checkpoint writes bitwise
    /// the outputs of the uninterrupted run (all but the wall-clock figures of the summary);
    /// a checkpoint of another scene is refused, naming the file.
    #[test]
    fn interrupted_run_resumes_to_the_same_result() {
        let base =
            std::env::temp_dir().join(format!("porelab-coupled-resume-{}", std::process::id()));
        let (whole, killed) = (base.join("whole"), base.join("killed"));
        let text = include_str!("builtin/coupled-quick.toml")
            .replace("time_s = 0.25", "time_s = 0.1")
            .replace("frames_every_s = 0.125", "frames_every_s = 0.05");
        run_scene(&text, "test", &whole, &quiet()).unwrap();
        run_scene_limited(&text, "test", &killed, &quiet(), Some(30)).unwrap();
        assert!(killed.join("checkpoint.json").exists());
        assert!(!killed.join("summary.json").exists());
        // a second interruption, from the checkpoint, then the rest
        run_scene_limited(&text, "test", &killed, &quiet(), Some(17)).unwrap();
        run_scene(&text, "test", &killed, &quiet()).unwrap();
        assert!(!killed.join("checkpoint.json").exists());
        let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
        for f in [
            "porosity_profile.csv",
            "frame_0000.xyz",
            "frame_0001.xyz",
            "frame_0002.xyz",
            "fluid_0001.vtk",
            "fluid_0002.vtk",
        ] {
            assert!(read(&whole, f) == read(&killed, f), "{f} differs");
        }
        let strip = |d: &Path| -> serde_json::Value {
            let mut v: serde_json::Value =
                serde_json::from_slice(&read(d, "summary.json")).unwrap();
            for k in ["seconds", "timing", "coupling_share", "threads"] {
                v.as_object_mut().unwrap().remove(k);
            }
            v
        };
        let s = strip(&whole);
        assert_eq!(s["coupling_steps"], 80);
        assert_eq!(s, strip(&killed));
        run_scene_limited(&text, "test", &killed, &quiet(), Some(5)).unwrap();
        let e = run_scene(
            &text.replace("seed = 1", "seed = 2"),
            "test",
            &killed,
            &quiet(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("checkpoint.json") && e.contains("different scene"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&base);
    }

    #[test]
    fn builtins_parse_and_bad_keys_are_named() {
        for b in builtins() {
            parse_scene(b.toml, b.name).unwrap_or_else(|e| panic!("{}: {e}", b.name));
        }
        let bad = include_str!("builtin/coupled-quick.toml")
            .replace("[coupling]", "[coupling]\nbogus = 1");
        let e = parse_scene(&bad, "t").err().unwrap().to_string();
        assert!(e.contains("bogus"), "{e}");
        let bad = include_str!("builtin/coupled-quick.toml")
            .replace("overlap = \"exact\"", "overlap = \"cube\"");
        let e = parse_scene(&bad, "t").err().unwrap().to_string();
        assert!(e.contains("coupling.overlap"), "{e}");
    }
}
