//! What a DEM scene writes: the history row of each check, trajectory frames, and at the end
//! the porosity profile, g(r), pore sizes, the final configuration and the summary (README,
//! "Output formats").

use super::schema::DemScene;
use crate::analysis::{pore_size, rdf, rdf::Bed};
use crate::dem::{observe, Check, Dem, Progress};
use crate::error::Error;
use crate::io::plot::CsvPlot;
use crate::io::{write_atomic, xyz, CsvTable};
use crate::Result;
use std::path::Path;

/// The columns of `history.csv`, one row per check.
pub(super) const HISTORY_COLUMNS: [&str; 9] = [
    "time_s",
    "kinetic_energy_J",
    "bed_top_m",
    "top_wall_z_m",
    "top_pressure_Pa",
    "floor_force_N",
    "floor_force_check_mean_N",
    "force_imbalance",
    "max_overlap_over_diameter",
];

/// An empty history table.
pub(super) fn history_table() -> CsvTable {
    CsvTable::new(&HISTORY_COLUMNS)
}

/// A history table holding the rows of `text` (a history written by [`history_table`] and
/// kept in a checkpoint), cell by cell as they were written.
pub(super) fn history_resumed(text: &str) -> CsvTable {
    let mut t = history_table();
    for line in text.lines().skip(1) {
        t.row(line.split(','));
    }
    t
}

/// Appends the row of a check to the history.
pub(super) fn history_row(hist: &mut CsvTable, scene: &DemScene, c: &Check) {
    let d = c.dem;
    let z: Vec<f64> = d.p.pos.iter().map(|p| p.z).collect();
    hist.row([
        d.time_s,
        c.kinetic_energy_j,
        observe::bed_top(&z, &d.p.radius),
        d.top_z_m,
        d.top_force_n / area(scene),
        d.floor_force_n,
        c.progress.floor_force_mean_n,
        c.progress.imbalance,
        c.max_overlap_ratio,
    ]);
}

/// The periodic base of the bed (m^2).
fn area(scene: &DemScene) -> f64 {
    scene.setup.lx_m * scene.setup.ly_m
}

/// The result of a scene run (also written as summary.json).
#[derive(Debug, Clone, serde::Serialize)]
pub struct DemSummary {
    pub title: String,
    pub n: usize,
    pub active_terms: Vec<&'static str>,
    pub dt_s: f64,
    pub steps: u64,
    pub simulated_time_s: f64,
    pub seconds: f64,
    pub neighbour_share: f64,
    pub neighbour_builds: usize,
    pub stop: String,
    pub bed_top_m: f64,
    pub porosity_below_top: f64,
    pub bulk_region_m: Option<(f64, f64)>,
    pub porosity_bulk: Option<f64>,
    pub mean_coordination: f64,
    /// Mean sphere–sphere contacts of the spheres with centres in the bulk region.
    pub coordination_bulk: Option<f64>,
    pub max_overlap_over_diameter: f64,
    /// The mean floor force over the last check / the buoyant weight (a run's summary; `None`
    /// without gravity).
    pub floor_force_over_weight: Option<f64>,
    /// The last check's force imbalance of the walls against the load at rest (a run's
    /// summary; see [`crate::dem::Balance`]).
    pub force_imbalance: Option<f64>,
    pub top_wall_z_m: f64,
    pub top_pressure_pa: f64,
    pub kinetic_energy_j: f64,
    /// r / <D> of the highest bin of g(r) (the nearest-neighbour peak), when g was computed.
    pub rdf_peak_r_over_d: Option<f64>,
    /// Pore sizes (local thickness) between the lowest and highest centres, when computed.
    pub pores: Option<PoreSummary>,
}

/// The pore-size part of the summary.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PoreSummary {
    pub voxel_m: [f64; 3],
    pub grid: [usize; 3],
    pub z_range_m: (f64, f64),
    pub grid_porosity: f64,
    /// Pore-volume-weighted mean and median of the pore diameter 2 LT over <D>.
    pub mean_diameter_over_d: f64,
    pub median_diameter_over_d: f64,
}

/// The summary of a finished run (without g(r), pore sizes and the last check's force balance,
/// which [`write_results`] adds).
pub fn summarize(scene: &DemScene, dem: &Dem, stop: String, seconds: f64) -> DemSummary {
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let r = &dem.p.radius;
    let area = area(scene);
    let top = observe::bed_top(&z, r);
    let bulk = observe::bulk_region(&z, r, top);
    let counts = dem.contact_counts();
    DemSummary {
        title: scene.title.clone(),
        n: dem.p.len(),
        active_terms: dem.active().names(),
        dt_s: dem.dt_s(),
        steps: dem.steps,
        simulated_time_s: dem.time_s,
        seconds,
        neighbour_share: dem.neighbour_seconds / seconds.max(1e-12),
        neighbour_builds: dem.nl.builds,
        stop,
        bed_top_m: top,
        porosity_below_top: observe::slab_porosity(&z, r, area, 0.0, top),
        bulk_region_m: bulk,
        porosity_bulk: bulk.map(|(a, b)| observe::slab_porosity(&z, r, area, a, b)),
        mean_coordination: counts.iter().sum::<usize>() as f64 / counts.len().max(1) as f64,
        coordination_bulk: bulk
            .and_then(|(a, b)| rdf::mean_coordination_in(&dem.p.pos, &counts, a, b)),
        max_overlap_over_diameter: dem.max_overlap_ratio(),
        floor_force_over_weight: None,
        force_imbalance: None,
        top_wall_z_m: dem.top_z_m,
        top_pressure_pa: dem.top_force_n / area,
        kinetic_energy_j: dem.kinetic_energy(),
        rdf_peak_r_over_d: None,
        pores: None,
    }
}

/// The bed of `dem` in the scene's periodic box.
fn bed<'a>(scene: &DemScene, dem: &'a Dem) -> Bed<'a> {
    Bed {
        pos: &dem.p.pos,
        radius: &dem.p.radius,
        lx_m: scene.setup.lx_m,
        ly_m: scene.setup.ly_m,
    }
}

/// g(r) of a bed over its bulk region (`Err` with the reason when it cannot be formed).
pub fn bed_rdf(scene: &DemScene, dem: &Dem) -> std::result::Result<Vec<(f64, f64)>, String> {
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let top = observe::bed_top(&z, &dem.p.radius);
    let bed = bed(scene, dem);
    let half_side = 0.5 * scene.setup.lx_m.min(scene.setup.ly_m) / bed.mean_diameter();
    let r_max = scene.outputs.rdf_max_over_d.unwrap_or(half_side.min(3.0));
    let (a, b) = observe::bulk_region(&z, &dem.p.radius, top)
        .ok_or_else(|| "no bulk region (the bed is thinner than 4 <d>)".to_string())?;
    rdf::slab_rdf(&bed, a, b, r_max, scene.outputs.rdf_bins).map_err(|e| e.to_string())
}

/// The pore-size distribution of a bed between its lowest and highest centres: rows (pore
/// diameter 2 LT in m, pore volume fraction) and the grid (`Err` with the reason when not
/// computed).
pub fn bed_pore_sizes(
    scene: &DemScene,
    dem: &Dem,
) -> std::result::Result<(Vec<(f64, f64)>, PoreSummary), String> {
    if scene.outputs.pore_voxels_per_d == 0.0 {
        return Err("run.pore_voxels_per_d = 0".into());
    }
    pore_sizes(&bed(scene, dem), scene.outputs.pore_voxels_per_d)
}

/// The pore-size distribution (local thickness, periodic laterally) of `bed` between its lowest
/// and highest centres (seed 002, Fig. 11: "between the centres of the lowest and highest
/// particles") on cubic voxels of edge <D> / `voxels_per_d`: rows (pore diameter 2 LT in m,
/// pore volume fraction), diameters increasing, and the summary.
pub fn pore_sizes(
    bed: &Bed,
    voxels_per_d: f64,
) -> std::result::Result<(Vec<(f64, f64)>, PoreSummary), String> {
    let d = bed.mean_diameter();
    let (lo, hi) = bed
        .pos
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.z), b.max(p.z))
        });
    let grid = pore_size::voxelize_bed(bed, lo, hi, d / voxels_per_d).map_err(|e| e.to_string())?;
    let rows: Vec<(f64, f64)> = pore_size::pore_size_distribution(&grid)
        .map_err(|e| e.to_string())?
        .into_iter()
        .map(|(r, f)| (2.0 * r, f))
        .collect();
    let mean = rows.iter().map(|(dp, f)| dp * f).sum::<f64>() / d;
    let summary = PoreSummary {
        voxel_m: grid.spacing_m,
        grid: grid.n,
        z_range_m: (lo, hi),
        grid_porosity: grid.porosity(),
        mean_diameter_over_d: mean,
        median_diameter_over_d: pore_size::distribution_quantile(&rows, 0.5) / d,
    };
    Ok((rows, summary))
}

/// The particles of a DEM system as extended-XYZ rows (radius per particle).
fn xyz_frame(scene: &DemScene, dem: &Dem) -> (xyz::Cell, Vec<xyz::XyzParticle>) {
    let parts = (0..dem.p.len())
        .map(|i| xyz::XyzParticle::sphere(dem.p.pos[i], dem.p.radius[i]))
        .collect();
    let cell = xyz::Cell {
        lengths: [scene.setup.lx_m, scene.setup.ly_m, dem.top_z_m],
        origin: [0.0; 3],
        pbc: [true, true, false],
    };
    (cell, parts)
}

/// Writes trajectory frame `k` (`trajectory/frame_NNNNNN.xyz`, atomically).
pub(super) fn write_frame(out: &Path, scene: &DemScene, dem: &Dem, k: u64) -> Result<()> {
    let (cell, parts) = xyz_frame(scene, dem);
    xyz::write(
        &out.join("trajectory").join(format!("frame_{k:06}.xyz")),
        &cell,
        &parts,
        &[
            ("Time", format!("{}", dem.time_s)),
            ("Step", format!("{}", dem.steps)),
        ],
    )
}

/// Writes the outputs of a finished run under `out`: `history.csv` (from `hist`),
/// `profile.csv`, `rdf.csv`, `pore_sizes.csv` (each with its plot), `final.xyz` and
/// `summary.json`; returns the summary.
pub(super) fn write_results(
    out: &Path,
    scene: &DemScene,
    dem: &Dem,
    progress: &Progress,
    hist: &CsvTable,
    stop: String,
    seconds: f64,
) -> Result<DemSummary> {
    let mut summary = summarize(scene, dem, stop, seconds);
    let w = dem.buoyant_weight_n();
    summary.floor_force_over_weight = (w > 0.0).then(|| progress.floor_force_mean_n / w);
    summary.force_imbalance = Some(progress.imbalance);
    hist.write(&out.join("history.csv"))?;
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let mut prof = CsvTable::new(&["z_lo_m", "z_hi_m", "porosity"]);
    for (a, b, e) in observe::porosity_profile(
        &z,
        &dem.p.radius,
        area(scene),
        0.0,
        dem.top_z_m,
        scene.outputs.profile_bins,
    ) {
        prof.row([a, b, e]);
    }
    prof.write(&out.join("profile.csv"))?;
    CsvPlot {
        title: "Porosity profile of the bed (exact sphere-slab volumes)",
        x: "z_lo_m",
        y: "porosity",
        x_label: "height of the slab's lower face (m)",
        y_label: "porosity",
        ..Default::default()
    }
    .write_or_warn(&out.join("profile.svg"), prof.as_str());
    CsvPlot {
        title: "Kinetic energy of the particles",
        x: "time_s",
        y: "kinetic_energy_J",
        x_label: "time (s)",
        y_label: "kinetic energy (J)",
        log_y: true,
        ..Default::default()
    }
    .write_or_warn(&out.join("history.svg"), hist.as_str());
    match bed_rdf(scene, dem) {
        Ok(g) => {
            let mut t = CsvTable::new(&["r_over_mean_d", "g"]);
            for (r, v) in &g {
                t.row([r, v]);
            }
            t.write(&out.join("rdf.csv"))?;
            CsvPlot {
                title: "Radial distribution function of the bulk (seed 002 Fig. 3)",
                x: "r_over_mean_d",
                y: "g",
                x_label: "r / <D>",
                y_label: "g(r)",
                ..Default::default()
            }
            .write_or_warn(&out.join("rdf.svg"), t.as_str());
            summary.rdf_peak_r_over_d = g.iter().max_by(|a, b| a.1.total_cmp(&b.1)).map(|x| x.0);
        }
        Err(why) => eprintln!("dem: g(r) not computed: {why}"),
    }
    match bed_pore_sizes(scene, dem) {
        Ok((rows, ps)) => {
            let d = scene.mean_diameter_m();
            let mut t = CsvTable::new(&[
                "pore_diameter_m",
                "pore_diameter_over_mean_d",
                "pore_volume_fraction",
            ]);
            for (dp, f) in &rows {
                t.row([*dp, dp / d, *f]);
            }
            t.write(&out.join("pore_sizes.csv"))?;
            CsvPlot {
                title: "Pore size distribution (local thickness, seed 002 Fig. 11)",
                x: "pore_diameter_over_mean_d",
                y: "pore_volume_fraction",
                x_label: "pore diameter / <D>",
                y_label: "fraction of the pore volume",
                ..Default::default()
            }
            .write_or_warn(&out.join("pore_sizes.svg"), t.as_str());
            summary.pores = Some(ps);
        }
        Err(why) => eprintln!("dem: pore sizes not computed: {why}"),
    }
    let (cell, parts) = xyz_frame(scene, dem);
    xyz::write(
        &out.join("final.xyz"),
        &cell,
        &parts,
        &[("Time", format!("{}", dem.time_s))],
    )?;
    let json =
        serde_json::to_string_pretty(&summary).map_err(|e| Error::InvalidInput(e.to_string()))?;
    write_atomic(&out.join("summary.json"), json.as_bytes())?;
    Ok(summary)
}

/// The run's result in one line on stdout, and where the outputs are.
pub(super) fn print_summary(origin: &str, summary: &DemSummary, out: &Path) {
    println!(
        "{}: {} steps, dt = {:e} s, {:.1} s ({}); porosity below top {:.4}, bulk {}; coordination {:.2} (bulk {}); max overlap/d {:.2e}; force imbalance {}",
        origin,
        summary.steps,
        summary.dt_s,
        summary.seconds,
        summary.stop,
        summary.porosity_below_top,
        summary.porosity_bulk.map_or("-".into(), |e| format!("{e:.4}")),
        summary.mean_coordination,
        summary.coordination_bulk.map_or("-".into(), |c| format!("{c:.2}")),
        summary.max_overlap_over_diameter,
        summary
            .force_imbalance
            .map_or("-".into(), |b| format!("{b:.1e}"))
    );
    println!("outputs in {}", out.display());
}
