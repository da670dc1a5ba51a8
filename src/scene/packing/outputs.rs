//! What a run writes: the files of a finished run (`final.xyz`, `summary.json`,
//! `phi_history.csv`, `gr.csv`, the orientation histogram and the plots) with the measures of
//! [`packing::measure`], and `checkpoint.json`, the state of an unfinished one.

use super::schema::PackingScene;
use crate::analysis;
use crate::contact::ContactShape;
use crate::error::Error;
use crate::io::csv_table::CsvTable;
use crate::io::plot::CsvPlot;
use crate::io::{write_atomic, xyz};
use crate::packing::measure::{measure, Measures};
use crate::packing::{Container, McmState, Packing, ParticleShapes, StepRecord};
use crate::Result;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::fmt::Display;
use std::path::Path;

/// One line per species kind: "1000 sphere d = 1", "750 superquadric a = [..] g = [..]"; a
/// polydisperse species (one particle per table entry) is summarised by its diameter range.
pub(super) fn describe_particles(p: &ParticleShapes) -> String {
    let counts = p.counts();
    if p.shapes.len() > 8 {
        let d: Vec<f64> = p
            .shapes
            .iter()
            .filter_map(analysis::rod_parameters)
            .map(|(r, _)| 2.0 * r)
            .collect();
        let (lo, hi) = d
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        return format!(
            "{} species, polydisperse, diameters {lo:.4}..{hi:.4}",
            p.shapes.len()
        );
    }
    p.shapes
        .iter()
        .zip(counts)
        .map(|(s, c)| match *s {
            ContactShape::Sphere { radius } => format!("{c} sphere d = {}", 2.0 * radius),
            ContactShape::Spherocylinder { radius, length } => {
                format!("{c} spherocylinder d = {} L = {length}", 2.0 * radius)
            }
            ContactShape::Ellipsoid { semi_axes } => format!("{c} ellipsoid a = {semi_axes:?}"),
            ContactShape::Superquadric {
                semi_axes,
                exponents,
            } => format!("{c} superquadric a = {semi_axes:?} g = {exponents:?}"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The XYZ columns of one particle shape: type name, OVITO Aspherical Shape, radius (bounding
/// radius for non-rods), cylinder length and Superquadric Roundness (README "Output formats" lists them).
fn xyz_columns(s: &ContactShape) -> (&'static str, [f64; 3], f64, f64, [f64; 2]) {
    match *s {
        ContactShape::Sphere { radius } => ("sphere", [radius; 3], radius, 0.0, [1.0, 1.0]),
        ContactShape::Spherocylinder { radius, length } => (
            "spherocylinder",
            [radius, radius, length],
            radius,
            length,
            [1.0, 1.0],
        ),
        ContactShape::Ellipsoid { semi_axes } => {
            let r = semi_axes.iter().cloned().fold(0.0, f64::max);
            ("ellipsoid", semi_axes, r, 0.0, [1.0, 1.0])
        }
        ContactShape::Superquadric {
            semi_axes,
            exponents,
        } => {
            let r = crate::shape::bounding_radius_of(s).unwrap_or(f64::NAN);
            (
                "superquadric",
                semi_axes,
                r,
                0.0,
                [2.0 / exponents[0], 2.0 / exponents[2]],
            )
        }
    }
}

#[derive(Serialize)]
struct Summary<'a> {
    scene: &'a str,
    title: &'a str,
    porelab_version: &'static str,
    /// Worker threads of the run (the analysis and the relaxation's force loop); the results
    /// do not depend on it.
    threads: usize,
    shape: &'static str,
    n: usize,
    /// Equal spheres / spherocylinders of diameter 1 only.
    #[serde(skip_serializing_if = "Option::is_none")]
    length_over_diameter: Option<f64>,
    seed: u64,
    scheme: String,
    box_length: f64,
    #[serde(flatten)]
    measures: Measures,
    compression_steps: usize,
    failed_steps: usize,
    total_tries: u64,
    jammed: bool,
    /// The last stage ended on its `stage_budget_per_particle`, not on its halvings.
    stage_budget_spent: bool,
    seconds: f64,
}

pub(super) fn write_outputs(
    out: &Path,
    origin: &str,
    scene: &PackingScene,
    state: &McmState,
    seconds: f64,
) -> Result<(String, bool)> {
    let p = &state.packing;
    let prm = &scene.setup;
    let a = &scene.analysis;
    let m = measure(p, &a.cutoffs, a.rattler_min_contacts, a.s4_trials)?;
    let parts: Vec<xyz::XyzParticle> = (0..p.n())
        .map(|i| {
            let (name, shape, radius, cylinder_length, roundness) =
                xyz_columns(p.particles.shape(i));
            xyz::XyzParticle {
                species: name.to_string(),
                position: p.positions[i],
                orientation: p.orientations[i],
                aspherical_shape: shape,
                radius,
                cylinder_length,
                roundness,
            }
        })
        .collect();
    let cell = match p.container {
        Container::Periodic => xyz::Cell::cubic(p.box_length),
        Container::Cylinder { diameter } => xyz::Cell {
            lengths: [diameter, diameter, p.box_length],
            origin: [-0.5 * diameter, -0.5 * diameter, 0.0],
            pbc: [false, false, true],
        },
        Container::Wedge { length, angle_rad } => xyz::Cell {
            lengths: [length, length * angle_rad.tan(), p.box_length],
            origin: [0.0, 0.0, 0.0],
            pbc: [false, false, true],
        },
    };
    xyz::write(
        &out.join("final.xyz"),
        &cell,
        &parts,
        &[
            ("packing_fraction", format!("{}", m.packing_fraction)),
            ("seed", format!("{}", prm.seed)),
        ],
    )?;
    let mut csv = CsvTable::new(&["step", "delta_v_D3", "packing_fraction", "tries"]);
    for h in &state.history {
        csv.row([
            &h.step as &dyn Display,
            &h.delta_v,
            &h.packing_fraction,
            &h.tries,
        ]);
    }
    csv.write(&out.join("phi_history.csv"))?;
    CsvPlot {
        title: "Packing fraction after each accepted compression step",
        x: "step",
        y: "packing_fraction",
        x_label: "compression step",
        y_label: "packing fraction",
        ..Default::default()
    }
    .write_or_warn(&out.join("phi_history.svg"), csv.as_str());
    if p.container == Container::Periodic {
        let rmax = a.gr_r_max.unwrap_or(3.0).min(0.5 * p.box_length);
        let g = analysis::radial_distribution(&p.view(), rmax, a.gr_bins)?;
        let mut gcsv = CsvTable::new(&["r_D", "g"]);
        for (rc, v) in g {
            gcsv.row([rc, v]);
        }
        gcsv.write(&out.join("gr.csv"))?;
        CsvPlot {
            title: "Radial distribution function of the centres",
            x: "r_D",
            y: "g",
            x_label: "r (particle diameters D)",
            y_label: "g(r)",
            ..Default::default()
        }
        .write_or_warn(&out.join("gr.svg"), gcsv.as_str());
    }
    let h = analysis::orientation_histogram(&p.axes(), 9, 18)?;
    let mut hcsv = CsvTable::new(&[
        "theta_lo_deg",
        "theta_hi_deg",
        "phi_lo_deg",
        "phi_hi_deg",
        "count",
    ]);
    for (kt, row) in h.iter().enumerate() {
        for (kp, c) in row.iter().enumerate() {
            let bin = [kt * 10, (kt + 1) * 10, kp * 10, (kp + 1) * 10];
            hcsv.row([&bin[0] as &dyn Display, &bin[1], &bin[2], &bin[3], c]);
        }
    }
    hcsv.write(&out.join("orientation_histogram.csv"))?;
    let rattler_free_mean_defined = m.contacts_extrapolated_no_rattlers.is_some();
    let s = Summary {
        scene: origin,
        title: &scene.title,
        porelab_version: env!("CARGO_PKG_VERSION"),
        threads: rayon::current_num_threads(),
        shape: match p.particles.shapes.as_slice() {
            [one] => one.name(),
            _ => "mixture",
        },
        n: p.n(),
        length_over_diameter: p.monodisperse_length(),
        seed: prm.seed,
        scheme: format!("{:?}", prm.scheme).to_lowercase(),
        box_length: p.box_length,
        measures: m,
        compression_steps: state.history.len(),
        failed_steps: state.failed_steps,
        total_tries: state.total_tries,
        // Ended by its schedule after compressing at all: a run whose every step failed
        // (Delta V too large for the start) did not jam, it did nothing.
        jammed: state.finished == Some(true) && !state.history.is_empty(),
        stage_budget_spent: state.stage_budget_spent,
        seconds,
    };
    let json = serde_json::to_string_pretty(&s).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    Ok((json, rattler_free_mean_defined))
}

/// The checkpoint: the scene fingerprint and the full [`McmState`], every f64 stored as its
/// IEEE bits so the resumed run starts from bitwise the same state.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    format: u32,
    scene: String,
    seconds: f64,
    box_length: u64,
    positions: Vec<[u64; 3]>,
    /// Quaternion (w, i, j, k) bits.
    orientations: Vec<[u64; 4]>,
    delta_v: u64,
    halvings_left: u32,
    stage: u32,
    /// (step, packing fraction bits, Delta V bits, tries) per accepted step.
    history: Vec<(usize, u64, u64, u64)>,
    failed_steps: usize,
    total_tries: u64,
    /// Moves in the running stage (absent in checkpoints written before stage budgets: 0,
    /// which is exact for their scenes, as they had no budget).
    #[serde(default)]
    stage_tries: u64,
    #[serde(default)]
    stage_budget_spent: bool,
    finished: Option<bool>,
}

pub(super) fn write_checkpoint(
    path: &Path,
    scene: &PackingScene,
    s: &McmState,
    seconds: f64,
) -> Result<()> {
    let p = &s.packing;
    let c = Checkpoint {
        format: 2,
        scene: scene.fingerprint.clone(),
        seconds,
        box_length: p.box_length.to_bits(),
        positions: p
            .positions
            .iter()
            .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
            .collect(),
        orientations: p
            .orientations
            .iter()
            .map(|q| {
                let q = q.quaternion();
                [q.w.to_bits(), q.i.to_bits(), q.j.to_bits(), q.k.to_bits()]
            })
            .collect(),
        delta_v: s.delta_v.to_bits(),
        halvings_left: s.halvings_left,
        stage: s.stage,
        history: s
            .history
            .iter()
            .map(|h| {
                (
                    h.step,
                    h.packing_fraction.to_bits(),
                    h.delta_v.to_bits(),
                    h.tries,
                )
            })
            .collect(),
        failed_steps: s.failed_steps,
        total_tries: s.total_tries,
        stage_tries: s.stage_tries,
        stage_budget_spent: s.stage_budget_spent,
        finished: s.finished,
    };
    let text = serde_json::to_vec(&c).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(path, &text)
}

pub(super) fn read_checkpoint(path: &Path, scene: &PackingScene) -> Result<(McmState, f64)> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let text =
        std::fs::read(path).map_err(|e| file_err(format!("cannot read the checkpoint: {e}")))?;
    let c: Checkpoint = serde_json::from_slice(&text)
        .map_err(|e| file_err(format!("not a packing checkpoint: {e}")))?;
    if c.format != 2 {
        return Err(file_err(format!(
            "checkpoint format {}: this porelab reads format 2",
            c.format
        )));
    }
    if c.scene != scene.fingerprint {
        return Err(file_err(
            "written by a different scene (parameters differ): delete it to start afresh, or \
             choose another output folder with --out"
                .into(),
        ));
    }
    let f = f64::from_bits;
    if c.positions.len() != scene.setup.n || c.orientations.len() != scene.setup.n {
        return Err(file_err(format!(
            "{} positions, {} orientations: the scene has n = {}",
            c.positions.len(),
            c.orientations.len(),
            scene.setup.n
        )));
    }
    let packing = Packing {
        container: scene.setup.container,
        box_length: f(c.box_length),
        particles: scene.setup.particles(),
        positions: c
            .positions
            .iter()
            .map(|b| Vector3::new(f(b[0]), f(b[1]), f(b[2])))
            .collect(),
        orientations: c
            .orientations
            .iter()
            .map(|b| {
                UnitQuaternion::new_unchecked(Quaternion::new(f(b[0]), f(b[1]), f(b[2]), f(b[3])))
            })
            .collect(),
    };
    let state = McmState {
        packing,
        delta_v: f(c.delta_v),
        halvings_left: c.halvings_left,
        history: c
            .history
            .iter()
            .map(|h| StepRecord {
                step: h.0,
                packing_fraction: f(h.1),
                delta_v: f(h.2),
                tries: h.3,
            })
            .collect(),
        failed_steps: c.failed_steps,
        total_tries: c.total_tries,
        stage_tries: c.stage_tries,
        stage_budget_spent: c.stage_budget_spent,
        stage: c.stage,
        finished: c.finished,
    };
    Ok((state, c.seconds))
}
