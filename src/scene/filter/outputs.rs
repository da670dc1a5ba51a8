//! What a filter run writes: `summary.json`, `penetration.csv` and its plot
//! `penetration.svg`, `captures.csv` and `captures.xyz` (extended XYZ, OVITO).

use super::flow::BedFlow;
use super::schema::Scene;
use crate::error::Error;
use crate::filter::{Fate, Filter};
use crate::io::plot::CsvPlot;
use crate::io::xyz::{self, XyzParticle};
use crate::io::{write_atomic, CsvTable};
use crate::Result;
use std::fmt::Display;
use std::path::Path;

/// What the run reached besides the engine's state: the flow and how the run ended.
pub(super) struct Outcome {
    pub flow: BedFlow,
    pub superficial_velocity_m_s: f64,
    pub pressure_drop_pa: f64,
    pub reynolds: f64,
    /// The fibres' field (None without an applied field).
    pub field: Option<super::field::FieldReport>,
    pub stop: crate::filter::driver::Stop,
    pub seconds: f64,
}

/// Depths of `penetration.csv` per cell of the bed.
const DEPTHS_PER_CELL: usize = 4;

/// Writes every file under `out` and returns the summary's JSON text.
pub(super) fn write_outputs(
    out: &Path,
    origin: &str,
    scene: &Scene,
    f: &Filter,
    o: &Outcome,
) -> Result<String> {
    let lz = f.bed().lengths_m()[2];
    let mut pen = CsvTable::new(&["depth_m", "penetration", "standard_error"]);
    for k in 0..=DEPTHS_PER_CELL * f.cells_deep() {
        let z = k as f64 * lz / DEPTHS_PER_CELL as f64;
        let (p, se) = f.penetration(z);
        pen.row([z, p, se]);
    }
    pen.write(&out.join("penetration.csv"))?;
    CsvPlot {
        title: "Penetration of the bed: fraction of the fed particles reaching each depth",
        x: "depth_m",
        y: "penetration",
        y_err: Some("standard_error"),
        x_label: "depth along the flow (m)",
        y_label: "penetration P (1 standard error)",
        log_y: true,
        ..Default::default()
    }
    .write_or_warn(&out.join("penetration.svg"), pen.as_str());
    let a = f.bed().particle_radius_m();
    let mut caps = CsvTable::new(&["x_m", "y_m", "depth_m", "time_s", "fibre"]);
    let mut spheres = Vec::new();
    for t in f.tracers() {
        if let Fate::Captured {
            fibre,
            time_s,
            position,
        } = t.fate
        {
            caps.row([
                &position.x as &dyn Display,
                &position.y,
                &position.z,
                &time_s,
                &fibre,
            ]);
            spheres.push(XyzParticle::sphere(position, a));
        }
    }
    caps.write(&out.join("captures.csv"))?;
    let l = f.bed().lengths_m();
    let cell = xyz::Cell {
        lengths: [l[0], l[1], f.depth_m()],
        origin: [0.0; 3],
        pbc: [true, true, false],
    };
    xyz::write(
        &out.join("captures.xyz"),
        &cell,
        &spheres,
        &[("captured", spheres.len().to_string())],
    )?;
    let c = f.counts();
    // lambda of a run that ended (with particles inside, the cells' counts are not final)
    let coefficient = f.filter_coefficient().filter(|_| c.inside == 0);
    let fibres = f.bed().fibres();
    let field_model = match &o.field {
        Some(r) if r.table_tolerance.is_some() => {
            "the fibres' fields superposed from one cylinder table (every counting image)"
        }
        _ => "exact superposition of the fibres' fields",
    };
    let summary = serde_json::json!({
        "scene": origin,
        "title": scene.title,
        "porelab_version": env!("CARGO_PKG_VERSION"),
        "threads": rayon::current_num_threads(),
        "model": format!(
            "dilute overdamped Brownian particles (no particle-particle forces or \
             hydrodynamics); fibres magnetized by the applied field alone (Stoner-Wohlfarth \
             with demagnetizing factors; mutual magnetization neglected); {field_model}; Stokes \
             flow from the lattice scaled to U"
        ),
        "bed": {
            "source": match (&scene.bed.xyz, &scene.bed.packing) {
                (Some(xyz), _) => xyz.clone(),
                (None, Some(packing)) => format!("packing scene {packing}, bed/final.xyz"),
                (None, None) => String::new(),
            },
            "fibres": fibres.len(),
            "fibre_radius_m": fibres[0].radius,
            "fibre_length_m": 2.0 * fibres[0].half_length,
            "cell_m": l,
            "cells_deep": f.cells_deep(),
            "depth_m": f.depth_m(),
        },
        "flow": {
            "voxels": o.flow.voxels,
            "voxel_m": o.flow.voxel_m,
            "porosity_voxels": o.flow.porosity,
            "permeability_m2": o.flow.permeability_m2,
            "superficial_velocity_m_s": o.superficial_velocity_m_s,
            "pressure_drop_pa": o.pressure_drop_pa,
            "fibre_reynolds": o.reynolds,
            "lattice_steps": o.flow.steady_steps,
            "lattice_residual": o.flow.residual,
        },
        "applied_field_T": scene.field.applied_T,
        "field": o.field.map(|r| serde_json::json!({
            "method": r.method,
            "cutoff_m": r.cutoff_m,
            "table_tolerance": r.table_tolerance,
            "images_listed_per_point": r.images_per_bin,
        })),
        "fed": c.fed,
        "captured": c.captured,
        "passed": c.passed,
        "inside": c.inside,
        "ended": format!("{:?}", o.stop),
        "time_s": f.time_s(),
        "steps": f.steps(),
        "penetration": f.penetration(f.depth_m()).0,
        "penetration_standard_error": f.penetration(f.depth_m()).1,
        "filter_coefficient_per_m": coefficient.map(|k| k.per_m),
        "filter_coefficient_standard_error_per_m": coefficient.map(|k| k.standard_error_per_m),
        "cell_survival": coefficient.map(|k| k.cell_survival),
        "seconds": o.seconds,
    });
    let text =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::Validation(e.to_string()))?;
    write_atomic(&out.join("summary.json"), text.as_bytes())?;
    Ok(text)
}
