//! The run of a filter scene: the plan checked, the flow through the bed from the lattice
//! Boltzmann engine, then the filter engine's driver ([`filter::driver::run_to_end`]) with a
//! progress bar and `checkpoint.json` ([`super::checkpoint`]: a killed run resumes bitwise),
//! then the outputs.

use super::checkpoint::Resumable;
use super::field::build_field;
use super::flow::{bed_flow, fibre_reynolds, LatticeOptions};
use super::outputs::{write_outputs, Outcome};
use super::schema::{parse, read_packing, read_xyz, BedSource, Drive, Plan};
use crate::error::{invalid, Error, Result};
use crate::filter::{self, Filter, Setup};
use crate::lbm::{SteadyBar, SteadyControl};
use crate::scene::packing::run_for_configuration;
use crate::scene::{on_threads, RunOptions};
use std::path::Path;
use std::time::Instant;

/// Checks a filter scene as [`run_scene`] does before it runs. A bed from a packing scene is
/// checked as that scene (it exists only once the packing has run).
pub fn check_scene(text: &str, origin: &str) -> Result<()> {
    let scene = parse(text, origin)?;
    match scene.bed_source(origin)? {
        BedSource::Xyz(xyz) => scene.plan(text, origin, read_xyz(xyz, origin)?).map(|_| ()),
        BedSource::Packing(packing) => {
            let (where_, packing_text) = read_packing(packing, origin)?;
            crate::scene::packing::parse_scene(&packing_text, &where_).map(|_| ())
        }
    }
}

/// Runs (or resumes from `out/checkpoint.json`) a filter scene; a run stopped by a signal
/// leaves its checkpoint and no outputs. A bed from a packing scene is packed first into
/// `out/bed/` (resumable as any packing run) and taken from its `final.xyz`.
pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    let scene = parse(text, origin)?;
    let bed = match scene.bed_source(origin)? {
        BedSource::Xyz(xyz) => read_xyz(xyz, origin)?,
        BedSource::Packing(packing) => {
            let (where_, packing_text) = read_packing(packing, origin)?;
            if !opts.quiet {
                eprintln!(
                    "filter: packing the bed ({where_}) into {}",
                    out.join("bed").display()
                );
            }
            let bed_out = out.join("bed");
            let packed = on_threads(opts.threads, || {
                run_for_configuration(&packing_text, &where_, &bed_out, opts)
            })?;
            let Some(final_xyz) = packed else {
                return Ok(());
            };
            let text = std::fs::read_to_string(&final_xyz).map_err(|e| Error::File {
                path: final_xyz.display().to_string(),
                msg: format!("the packed bed: {e}"),
            })?;
            (final_xyz.display().to_string(), text)
        }
    };
    let plan = scene.plan(text, origin, bed)?;
    let mut hooks = Resumable::open(out, text, opts)?;
    let t0 = Instant::now();
    on_threads(opts.threads, || {
        let Some((f, o)) = run_plan(plan, opts.quiet, t0, &mut hooks)? else {
            return Ok(());
        };
        crate::io::create_dir(out)?;
        let summary = write_outputs(out, origin, &scene, &f, &o)?;
        hooks.remove()?;
        println!("{summary}");
        if !opts.quiet {
            eprintln!("outputs in {}", out.display());
        }
        Ok(())
    })
}

/// The flow, then the particles to the end (None: stopped, the checkpoint written).
fn run_plan(
    plan: Plan,
    quiet: bool,
    t0: Instant,
    hooks: &mut Resumable,
) -> Result<Option<(Filter, Outcome)>> {
    let fo = &plan.flow;
    let options = LatticeOptions {
        lattice: fo.lattice,
        collision: fo.collision,
        tau: fo.tau,
        force_lattice: fo.force_lattice,
        ctl: SteadyControl {
            check_every: fo.check_every,
            tol: fo.tol,
            max_steps: fo.max_steps,
        },
    };
    let mu = plan.fluid.viscosity_pa_s();
    let radius = plan.bed.fibres()[0].radius;
    let depth_m = plan.cells_deep as f64 * plan.bed.lengths_m()[2];
    if !quiet {
        eprintln!(
            "filter: {} fibres (R = {radius:e} m) from {} in a periodic cell {:?} m, {} deep; \
             flow lattice {:?} voxels",
            plan.bed.fibres().len(),
            plan.source,
            plan.bed.lengths_m(),
            plan.cells_deep,
            plan.voxels
        );
    }
    let flow = bed_flow(&plan.bed, plan.voxels, &options, &mut SteadyBar::new(quiet))?;
    if !flow.converged {
        return invalid(format!(
            "flow.max_steps = {}: the lattice flow through the bed did not reach \
             flow.tol = {:e} (residual {:.3e} after {} steps); raise flow.max_steps",
            fo.max_steps, fo.tol, flow.residual, flow.steady_steps
        ));
    }
    // Darcy over the whole depth: U = k dp / (mu depth)
    let (u, dp) = match fo.drive {
        Drive::Superficial(u) => (u, u * mu * depth_m / flow.permeability_m2),
        Drive::PressureDrop(dp) => (flow.permeability_m2 * dp / (mu * depth_m), dp),
    };
    let reynolds = fibre_reynolds(u, plan.density_kg_m3, radius, mu)?;
    let (field, field_report) = match plan.field {
        Some(fp) => {
            let (source, report) = build_field(fp)?;
            (Some(source), Some(report))
        }
        None => (None, None),
    };
    // no slip on the exact fibre surfaces within one voxel (crate::filter::wall)
    let flow_term =
        "carrier flow (lattice, trilinear; no slip on the exact fibres within one voxel)";
    let terms = match &field_report {
        Some(r) => format!(
            "{flow_term}, magnetic force mu0 (m.grad)H of all fibres ({}), thermal noise",
            r.describe()
        ),
        None => format!("{flow_term}, thermal noise; no field"),
    };
    if !quiet {
        eprintln!(
            "flow: k = {:.4e} m^2, porosity {:.4}, U = {u:.4e} m/s, pressure drop {dp:.4e} Pa, \
             Re_fibre = {reynolds:.3e} ({} lattice steps); terms: {terms}{}",
            flow.permeability_m2,
            flow.porosity,
            flow.steady_steps,
            if plan.fluid.temperature_k() > 0.0 {
                ""
            } else {
                " (temperature 0: no noise)"
            }
        );
    }
    let setup = Setup {
        flow: flow.at(u)?,
        // no slip on the exact fibre surfaces within one voxel (crate::filter::wall)
        wall_layer_m: flow.voxel_m,
        bed: plan.bed,
        field,
        moment: plan.moment,
        fluid: plan.fluid,
        particles: plan.particles,
        cells_deep: plan.cells_deep,
        dt_s: plan.dt_s,
        max_step_fraction: plan.max_step_fraction,
        seed: plan.seed,
    };
    let mut f = Filter::new(setup)?;
    let stop = filter::driver::run_to_end(&mut f, plan.max_steps, hooks)?;
    if hooks.was_stopped()? {
        return Ok(None);
    }
    Ok(Some((
        f,
        Outcome {
            flow,
            superficial_velocity_m_s: u,
            pressure_drop_pa: dp,
            reynolds,
            field: field_report,
            stop,
            seconds: t0.elapsed().as_secs_f64(),
        },
    )))
}
