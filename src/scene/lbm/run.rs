//! Running an LBM scene: the plan's problem built and driven to its steady state by the
//! engine, on the scene's threads, then the outputs. The steady run saves its state in
//! `checkpoint.json` ([`super::checkpoint`]) and resumes from it bitwise.

use super::checkpoint::Resumable;
use super::outputs::{write_flow, write_packing, Outcome};
use super::schema::{prepare, FlowPlan, PackingPlan, Plan, Problem};
use crate::driver::Hooks;
use crate::error::Result;
use crate::lbm::flows::{
    channel_coordinate, channel_mask, sphere_array_fractions, sphere_array_mask,
};
use crate::lbm::pore::{pore_permeability, report, setup_line};
use crate::lbm::problems::{permeability, ChannelFlow};
use crate::lbm::units::describe;
use crate::lbm::voxels::voxelise;
use crate::lbm::{Dims, Domain, Lbm};
use crate::scene::{on_threads, RunOptions};
use std::path::Path;

/// Checks an LBM scene as [`run_scene`] does before it runs (`porelab sweep plan`).
pub fn check_scene(text: &str, origin: &str) -> Result<()> {
    prepare(text, origin).map(|_| ())
}

pub fn run_scene(text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
    run_scene_limited(text, origin, out, opts, None)
}

/// Runs (or resumes from `out/checkpoint.json`) a scene; with `max_checks` it stops after
/// that many checks, leaving the checkpoint behind as an interrupted run would (for tests).
pub(super) fn run_scene_limited(
    text: &str,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    max_checks: Option<u64>,
) -> Result<()> {
    let plan = prepare(text, origin)?;
    let mut hooks = Resumable::open(out, text, opts, max_checks)?;
    if let (Some(step), false) = (hooks.resumes_at(), opts.quiet) {
        eprintln!(
            "resuming {origin} from {} (step {step})",
            hooks.path().display()
        );
    }
    let written = match plan {
        Plan::Flow(p) => run_flow(&p, origin, out, opts, &mut hooks)?,
        Plan::Packing(p) => run_packing(&p, origin, out, opts, &mut hooks)?,
    };
    // the outputs are complete: the checkpoint is no longer needed
    if written {
        hooks.remove()?;
    }
    Ok(())
}

/// Runs a flow and writes its outputs (true), or leaves its checkpoint when stopped (false).
fn run_flow(
    p: &FlowPlan,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    hooks: &mut Resumable,
) -> Result<bool> {
    let (u, tau, h) = (&p.units, p.collision.tau.get(), p.n as f64);
    println!(
        "lbm scene {origin}: {} {} {}, {} cells across {} m (dx = {:e} m, dt = {:e} s)",
        p.flow,
        p.lattice.name(),
        p.collision.name(),
        p.n,
        p.length_m,
        u.dx,
        u.dt
    );
    println!("  estimate: {}", describe(tau, p.u_est, h));
    let o = on_threads(opts.threads, || solve(p, hooks))?;
    if hooks.was_stopped()? {
        return Ok(false);
    }
    let st = &o.steady;
    println!(
        "  steady after {} steps (residual {:.2e}{}); measured: {}",
        st.steps,
        st.residual,
        if st.converged { "" } else { ", NOT converged" },
        describe(tau, st.u_max, h)
    );
    write_flow(p, &o, out)?;
    Ok(true)
}

/// Runs the plan's problem to its steady state; the fields the outputs write beside it.
fn solve(p: &FlowPlan, bar: &mut dyn Hooks<Lbm>) -> Result<Outcome> {
    let (lat, coll, ctl, n) = (p.lattice, p.collision, p.ctl, p.n);
    // the rows of profile.csv across a channel with halfway walls
    let walls = || (1..=n).map(|y| (y, channel_coordinate(y))).collect();
    let open_or_solid = |mask: &[bool], eps: f64| -> Vec<f64> {
        mask.iter().map(|&s| if s { 0.0 } else { eps }).collect()
    };
    Ok(match &p.problem {
        Problem::Couette(couette) => {
            let (_, steady) = couette.steady(lat, coll, ctl, bar)?;
            Outcome {
                steady,
                solid: vec![false; n + 1],
                porosity_field: vec![couette.porous.0; n + 1],
                dims: couette.dims()?,
                k: None,
                profile_x: 0,
                rows: (0..=n).map(|y| (y, y as f64)).collect(),
            }
        }
        Problem::SphereArray {
            solid_fraction,
            g,
            walls,
        } => {
            let radius = n as f64 * (3.0 * solid_fraction / (4.0 * std::f64::consts::PI)).cbrt();
            let d = Dims::new(n, n, n)?;
            let mask = sphere_array_mask(n, radius);
            let walls = walls.walls(|| sphere_array_fractions(n, radius))?;
            let domain = Domain::with_solid(d, mask.clone())?.with_walls(walls)?;
            let perm = permeability(lat, coll, domain, *g, ctl, bar)?;
            Outcome {
                k: Some(perm.k),
                steady: perm.steady,
                porosity_field: open_or_solid(&mask, 1.0),
                solid: mask,
                dims: d,
                profile_x: 0,
                rows: Vec::new(),
            }
        }
        Problem::Driven(ch) => {
            let steady = ch.steady(lat, coll, ctl, bar)?;
            let d = ch.dims()?;
            let solid = channel_mask(d);
            Outcome {
                steady,
                porosity_field: open_or_solid(&solid, 1.0),
                solid,
                dims: d,
                k: None,
                profile_x: ch.length / 2,
                rows: walls(),
            }
        }
        Problem::Channel(ch) => {
            let (_, steady) = ch.steady(lat, coll, ctl, bar)?;
            let d = ch.dims()?;
            let solid = channel_mask(d);
            let eps = ch.porous.map_or(1.0, |p| p.0);
            Outcome {
                steady,
                porosity_field: open_or_solid(&solid, eps),
                solid,
                dims: d,
                k: None,
                profile_x: 0,
                rows: walls(),
            }
        }
    })
}

/// The permeability of a configuration: what `porelab permeability` does at one resolution
/// (true), or its checkpoint left when stopped (false).
fn run_packing(
    p: &PackingPlan,
    origin: &str,
    out: &Path,
    opts: &RunOptions,
    hooks: &mut Resumable,
) -> Result<bool> {
    let (o, resolution, source, cell) = (&p.options, p.resolution, &p.source, &p.cell);
    println!("lbm scene {origin}: packing {source}, resolution {resolution}");
    let mut text = setup_line(cell, &p.parts, o);
    print!("{text}");
    let v = voxelise(cell, &p.parts, resolution)?;
    let r = on_threads(opts.threads, || pore_permeability(&v, o, hooks))?;
    if hooks.was_stopped()? {
        return Ok(false);
    }
    let lines = report(&v, &r, o, p.unit_m);
    print!("{lines}");
    text += &lines;
    write_packing(p, &v, &r, &text, out)?;
    Ok(true)
}
