//! What a coupled run writes: the frames (particles as extended XYZ, the fluid as VTK at the
//! same time) and the summary.

use super::CoupledScene;
use crate::coupled::Coupled;
use crate::io::{vtk, xyz};
use crate::Result;
use nalgebra::Vector3;
use std::path::Path;

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

/// porosity_profile.svg: the porosity of the cell layers against height at the first, middle
/// and last time of `profile_csv` (porosity_profile.csv: `time_s,z_m,porosity`), one curve
/// each, showing how the flow consolidated the bed (a failure to draw is a warning).
pub(super) fn porosity_svg(profile_csv: &str, out: &Path) {
    let rows: Vec<&str> = profile_csv.lines().skip(1).collect();
    let time = |row: &str| row.split(',').next().unwrap_or("").to_string();
    let mut times: Vec<String> = rows.iter().map(|r| time(r)).collect();
    times.dedup();
    let picked: Vec<&String> = match times.len() {
        0 => Vec::new(),
        n => {
            let mut p = vec![&times[0], &times[n / 2], &times[n - 1]];
            p.dedup();
            p
        }
    };
    let mut text = String::from("time_s,z_m,porosity\n");
    for r in rows.iter().filter(|r| picked.contains(&&time(r))) {
        text.push_str(r);
        text.push('\n');
    }
    crate::io::plot::CsvPlot {
        title: "Porosity of the cell layers against height (coupled LBM-DEM)",
        x: "z_m",
        y: "porosity",
        group_by: &["time_s"],
        x_label: "height z (m)",
        y_label: "porosity",
        ..Default::default()
    }
    .write_or_warn(&out.join("porosity_profile.svg"), &text);
}

/// Writes frame `k`: `frame_k.xyz` (particles) and `fluid_k.vtk` (porosity, velocity, pressure).
pub(super) fn frame(c: &Coupled, out: &Path, k: usize) -> Result<()> {
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
