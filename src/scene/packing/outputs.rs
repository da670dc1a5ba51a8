//! What a finished (or interrupted) run writes: the measures of the final configuration and
//! the files `final.xyz`, `summary.json`, `phi_history.csv`, `gr.csv`, the orientation
//! histogram and the plots.

use super::schema::PackingScene;
use crate::analysis;
use crate::contact::ContactShape;
use crate::error::Error;
use crate::io::plot::CsvPlot;
use crate::io::{write_atomic, xyz};
use crate::packing::{self, Container, McmState, Packing, Particles};
use crate::Result;
use serde::Serialize;
use std::path::Path;

/// One line per species kind: "1000 sphere d = 1", "750 superquadric a = [..] g = [..]"; a
/// polydisperse species (one particle per table entry) is summarised by its diameter range.
pub(super) fn describe_particles(p: &Particles) -> String {
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

/// Observables of a final configuration (thesis sec. 2.2.5, 3.3, eq. 2.11, 4.17).
#[derive(Debug, Clone, Serialize)]
pub struct Measures {
    pub packing_fraction: f64,
    /// Deepest overlap (>= 0) by the analysis' pair search ([`analysis::pair_gaps`], independent
    /// of the engine; equal to the brute force over all pairs and images).
    pub deepest_overlap: f64,
    pub contact_cutoffs: Vec<f64>,
    /// Mean contacts at each cut-off, all particles.
    pub contacts_at_cutoffs: Vec<f64>,
    /// Linear extrapolation to zero cut-off, all particles counted (rattlers included).
    pub contacts_extrapolated: f64,
    /// The same with rattlers removed repeatedly (fewer than `rattler_min_contacts`); `None`
    /// (JSON null) when that removes every particle at some cut-off, as it does for hypostatic
    /// packings (superballs with the default threshold 5): there is no mean to report.
    pub contacts_extrapolated_no_rattlers: Option<f64>,
    pub rattler_min_contacts: usize,
    /// Rattlers at the smallest cut-off.
    pub rattlers: usize,
    pub nematic_s: f64,
    pub cubatic_s4: f64,
    /// Cylinder and wedge: fraction of the particles within D of a wall whose axis is
    /// tangential to it within 4 degrees (thesis sec. 2.2.5, Fig. 2.6, 2.14), and how many are
    /// in that layer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_aligned_fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_layer_particles: Option<usize>,
    /// Ellipsoids / superquadrics only: deepest penetration proven by the solver-free sampled
    /// check ([`analysis::sampled_overlap`], 0 when no sample lies inside another particle)
    /// and the sample spacing, its resolution.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampled_deepest_overlap: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sample_spacing: Option<f64>,
}

/// Measures a configuration with [`crate::analysis`].
pub fn measure(
    p: &Packing,
    cutoffs: &[f64],
    min_contacts: usize,
    s4_trials: usize,
) -> Result<Measures> {
    let v = p.view();
    let dmax = cutoffs.iter().cloned().fold(0.0, f64::max);
    let gaps = analysis::pair_gaps(&v, dmax)?;
    let deepest = gaps.iter().map(|g| -g.gap).fold(0.0f64, f64::max);
    let contacts_at: Vec<f64> = cutoffs
        .iter()
        .map(|&d| analysis::mean_contacts(v.n(), &gaps, d, None).0)
        .collect();
    let (c0, _) = analysis::extrapolated_contacts(v.n(), &gaps, cutoffs, None)?;
    let c0r = if analysis::cutoff_where_all_rattle(v.n(), &gaps, cutoffs, min_contacts).is_some() {
        None
    } else {
        Some(analysis::extrapolated_contacts(v.n(), &gaps, cutoffs, Some(min_contacts))?.0)
    };
    let dmin = cutoffs.iter().cloned().fold(f64::INFINITY, f64::min);
    let (_, rattlers) = analysis::mean_contacts(v.n(), &gaps, dmin, Some(min_contacts));
    let wall = match p.container {
        Container::Periodic => None,
        Container::Cylinder { .. } | Container::Wedge { .. } => Some(
            analysis::wall_aligned_fraction(&v, 2.0 * packing::RADIUS, 4f64.to_radians())?,
        ),
    };
    let sampled = if p.particles.has_superquadrics() {
        Some(analysis::sampled_overlap(&v, analysis::OVERLAP_SAMPLES)?)
    } else {
        None
    };
    Ok(Measures {
        sampled_deepest_overlap: sampled.map(|s| s.worst.map_or(0.0, |w| w.2)),
        sample_spacing: sampled.map(|s| s.spacing),
        packing_fraction: p.packing_fraction(),
        deepest_overlap: deepest,
        contact_cutoffs: cutoffs.to_vec(),
        contacts_at_cutoffs: contacts_at,
        contacts_extrapolated: c0,
        contacts_extrapolated_no_rattlers: c0r,
        rattler_min_contacts: min_contacts,
        rattlers,
        nematic_s: analysis::nematic_order(&p.axes())?,
        cubatic_s4: analysis::cubatic_order(&p.orientations, s4_trials)?,
        wall_aligned_fraction: wall.map(|w| w.0),
        wall_layer_particles: wall.map(|w| w.1),
    })
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
    let prm = &scene.params;
    let m = measure(
        p,
        &scene.cutoffs,
        scene.rattler_min_contacts,
        scene.s4_trials,
    )?;
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
    let mut csv = String::from("step,delta_v_D3,packing_fraction,tries\n");
    for h in &state.history {
        csv.push_str(&format!(
            "{},{},{},{}\n",
            h.step, h.delta_v, h.packing_fraction, h.tries
        ));
    }
    write_atomic(&out.join("phi_history.csv"), csv.as_bytes())?;
    CsvPlot {
        title: "Packing fraction after each accepted compression step",
        x: "step",
        y: "packing_fraction",
        x_label: "compression step",
        y_label: "packing fraction",
        ..Default::default()
    }
    .write_or_warn(&out.join("phi_history.svg"), &csv);
    if p.container == Container::Periodic {
        let rmax = scene.gr_r_max.unwrap_or(3.0).min(0.5 * p.box_length);
        let g = analysis::radial_distribution(&p.view(), rmax, scene.gr_bins)?;
        let mut gcsv = String::from("r_D,g\n");
        for (rc, v) in g {
            gcsv.push_str(&format!("{rc},{v}\n"));
        }
        write_atomic(&out.join("gr.csv"), gcsv.as_bytes())?;
        CsvPlot {
            title: "Radial distribution function of the centres",
            x: "r_D",
            y: "g",
            x_label: "r (particle diameters D)",
            y_label: "g(r)",
            ..Default::default()
        }
        .write_or_warn(&out.join("gr.svg"), &gcsv);
    }
    let h = analysis::orientation_histogram(&p.axes(), 9, 18)?;
    let mut hcsv = String::from("theta_lo_deg,theta_hi_deg,phi_lo_deg,phi_hi_deg,count\n");
    for (kt, row) in h.iter().enumerate() {
        for (kp, c) in row.iter().enumerate() {
            hcsv.push_str(&format!(
                "{},{},{},{},{c}\n",
                kt * 10,
                (kt + 1) * 10,
                kp * 10,
                (kp + 1) * 10
            ));
        }
    }
    write_atomic(&out.join("orientation_histogram.csv"), hcsv.as_bytes())?;
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
