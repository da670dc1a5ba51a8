//! The output files of an LBM scene: `fields.vtk`, `profile.csv` and `profile.svg` (channels,
//! beside the closed form or the finite-difference reference), `summary.json`; for a packing
//! `permeability.txt` and `configuration.xyz`.

use super::schema::{FlowPlan, PackingPlan, Problem};
use crate::error::{Error, Result};
use crate::io::plot::CsvPlot;
use crate::io::vtk::{write_image_data, CellField};
use crate::io::{write_atomic, CsvTable};
use crate::lbm::flows::{brinkman_couette, brinkman_poiseuille, drag_coefficient};
use crate::lbm::pore::{kozeny_constant, write_fields_vtk, PoreResult};
use crate::lbm::problems::Inlet;
use crate::lbm::voxels::Voxels;
use crate::lbm::{Dims, Steady};
use std::path::Path;

/// What a flow's run leaves for the outputs besides the steady fields.
pub(super) struct Outcome {
    pub steady: Steady,
    pub solid: Vec<bool>,
    pub porosity_field: Vec<f64>,
    pub dims: Dims,
    /// Sphere array: k (lattice units).
    pub k: Option<f64>,
    /// The x index of the section written to profile.csv.
    pub profile_x: usize,
    /// The rows of profile.csv: (y index, distance from the lower wall in cells).
    pub rows: Vec<(usize, f64)>,
}

/// The porous Couette profile at the nodes y = 0..=n (lattice units) for a wall at `u_wall`
/// and the medium (eps, K, Forchheimer on): without the Forchheimer term the closed form
/// [`brinkman_couette`]; with it, the finite differences of `reference::porous_couette` (the
/// oracle of validation case 809) on grids of at least 4096 and twice as many intervals,
/// Richardson-extrapolated at the nodes.
fn couette_reference(
    n: usize,
    u_wall: f64,
    nu: f64,
    (eps, k, forch): (f64, f64, bool),
) -> Vec<f64> {
    let h = n as f64;
    if !forch {
        return (0..=n)
            .map(|y| brinkman_couette(y as f64, h, u_wall, eps, k))
            .collect();
    }
    use crate::reference::porous_couette::solve;
    let m = 4096usize.div_ceil(n);
    let (re, da) = (u_wall.abs() * h / nu, k / (h * h));
    let (a, b) = (solve(n * m, eps, re, da), solve(2 * n * m, eps, re, da));
    (0..=n)
        .map(|y| u_wall * (4.0 * b[2 * m * y] - a[m * y]) / 3.0)
        .collect()
}

/// The reference profile of a channel (lattice units) at the rows `rows` (y index, distance
/// from the lower wall), None where there is none (the porous channel with the Forchheimer
/// term), and what it is.
fn reference_profile(p: &FlowPlan, rows: &[(usize, f64)]) -> (Vec<Option<f64>>, &'static str) {
    let (h, nu) = (p.n as f64, p.units.nu_lattice());
    match &p.problem {
        Problem::Couette(c) => {
            let exact = couette_reference(p.n, c.u_wall, nu, c.porous);
            let what = if c.porous.2 {
                "finite differences"
            } else {
                "closed form"
            };
            (rows.iter().map(|&(y, _)| Some(exact[y])).collect(), what)
        }
        problem => {
            let exact = |yc: f64| match problem {
                Problem::Driven(ch) => match ch.inlet {
                    Inlet::Density(rho_in) => Some(
                        (rho_in - ch.rho_out) / (3.0 * ch.length as f64) * yc * (h - yc)
                            / (2.0 * nu),
                    ),
                    Inlet::Parabola(um) => Some(4.0 * um * yc * (h - yc) / (h * h)),
                },
                Problem::Channel(ch) => match ch.porous {
                    None => Some(ch.g * yc * (h - yc) / (2.0 * nu) + ch.wall_u * yc / h),
                    Some((eps, k, false)) => Some(brinkman_poiseuille(yc, h, ch.g, nu, eps, k)),
                    Some(_) => None,
                },
                _ => None,
            };
            (
                rows.iter().map(|&(_, yc)| exact(yc)).collect(),
                "closed form",
            )
        }
    }
}

/// fields.vtk, summary.json and, for a channel, profile.csv and profile.svg.
pub(super) fn write_flow(p: &FlowPlan, o: &Outcome, out: &Path) -> Result<()> {
    let (u, st) = (&p.units, &o.steady);
    let (h, nu) = (p.n as f64, u.nu_lattice());
    std::fs::create_dir_all(out)?;
    let vel: Vec<[f64; 3]> = st
        .fields
        .u
        .iter()
        .map(|v| v.map(|c| u.velocity_to_si(c)))
        .collect();
    let rho: Vec<f64> = st.fields.rho.iter().map(|r| r * u.rho).collect();
    let solid: Vec<f64> = o.solid.iter().map(|&s| if s { 1.0 } else { 0.0 }).collect();
    let d = o.dims;
    write_image_data(
        &out.join("fields.vtk"),
        &format!("porelab lbm {}", p.flow),
        [d.nx, d.ny, d.nz],
        u.dx,
        [0.0; 3],
        &[
            CellField::Vector("velocity_m_s", &vel),
            CellField::Scalar("density_kg_m3", &rho),
            CellField::Scalar("porosity", &o.porosity_field),
            CellField::Scalar("solid", &solid),
        ],
    )?;
    let mut summary = serde_json::json!({
        "flow": p.flow, "lattice": p.lattice.name(), "collision": p.collision.name(),
        "tau": p.collision.tau.get(), "dx_m": u.dx, "dt_s": u.dt, "steps": st.steps,
        "residual": st.residual, "converged": st.converged, "mach": st.u_max * 3f64.sqrt(),
        "u_max_m_s": u.velocity_to_si(st.u_max), "re": st.u_max * h / nu,
    });
    if let (Some(k), Problem::SphereArray { solid_fraction, .. }) = (o.k, &p.problem) {
        let phi = *solid_fraction;
        let a = h * (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
        summary["permeability_m2"] = serde_json::json!(u.area_to_si(k));
        summary["drag_coefficient_K"] = serde_json::json!(drag_coefficient(k, a, phi));
        println!(
            "  permeability k = {:.6e} m^2 (= {:.6e} cells^2), drag coefficient K = {:.4}",
            u.area_to_si(k),
            k,
            drag_coefficient(k, a, phi)
        );
        return write_summary(out, &summary);
    }
    let (exact, reference) = reference_profile(p, &o.rows);
    let mut csv = CsvTable::new(&["y_m", "u_m_s", "u_exact_m_s"]);
    // largest |u - exact| and |exact| (m/s)
    let (mut err, mut peak) = (0.0f64, 0.0f64);
    for (&(y, yc), exact) in o.rows.iter().zip(exact) {
        let v = vel[d.cell(o.profile_x, y, 0)];
        let exact = exact.map(|e| u.velocity_to_si(e));
        if let Some(e) = exact {
            err = err.max((v[0] - e).abs());
            peak = peak.max(e.abs());
        }
        let e = exact.map_or(String::new(), |e| e.to_string());
        csv.row([(yc * u.dx).to_string(), v[0].to_string(), e]);
    }
    csv.write(&out.join("profile.csv"))?;
    if peak > 0.0 {
        summary["profile_max_error_rel"] = serde_json::json!(err / peak);
        summary["profile_reference"] = serde_json::json!(reference);
        println!(
            "  profile: largest |u - u_exact| = {:.3e} of the peak ({reference})",
            err / peak
        );
    }
    profile_svg(csv.as_str(), reference, out)?;
    write_summary(out, &summary)
}

/// profile.svg: the lattice profile and the reference as two labelled series of one picture
/// (a failure to draw is a warning).
fn profile_svg(csv: &str, reference: &str, out: &Path) -> Result<()> {
    let column = |y: &'static str| CsvPlot {
        title: "Velocity profile across the channel",
        x: "y_m",
        y,
        x_label: "y (m)",
        y_label: "u (m/s)",
        ..Default::default()
    };
    let mut series = Vec::new();
    for (y, label) in [("u_m_s", "lattice Boltzmann"), ("u_exact_m_s", reference)] {
        let built = column(y).build(csv)?;
        series.extend(built.series.into_iter().map(|mut s| {
            s.label = label.into();
            s
        }));
    }
    let plot = crate::io::plot::Plot {
        series,
        ..column("u_m_s").build("y_m,u_m_s\n")?
    };
    if let Err(e) = crate::io::plot::write_svg(&out.join("profile.svg"), &plot) {
        eprintln!("warning: profile.svg not written: {e}");
    }
    Ok(())
}

/// permeability.txt (`report`: what was printed), configuration.xyz, fields.vtk (lattice
/// units; spacing in m with unit_m) and summary.json of a packing.
pub(super) fn write_packing(
    p: &PackingPlan,
    v: &Voxels,
    r: &PoreResult,
    report: &str,
    out: &Path,
) -> Result<()> {
    let (o, cell) = (&p.options, &p.cell);
    std::fs::create_dir_all(out)?;
    write_atomic(&out.join("permeability.txt"), report.as_bytes())?;
    write_atomic(&out.join("configuration.xyz"), p.text.as_bytes())?;
    write_fields_vtk(
        &out.join("fields.vtk"),
        "porelab lbm packing (lattice units)",
        v,
        &r.run.steady.fields,
        cell.origin,
        p.unit_m,
    )?;
    let kozeny = |phi: f64| v.v_over_s.map(|vs| kozeny_constant(r.k, phi, vs));
    let summary = serde_json::json!({
        "flow": p.flow, "xyz": p.source, "lattice": o.lattice.name(),
        "collision": o.collision.name(), "tau": o.collision.tau.get(), "force_lattice": o.force(),
        "resolution": p.resolution, "dims": [v.dims.nx, v.dims.ny, v.dims.nz], "dx_unit": v.dx,
        "k_unit2": r.k, "k_m2": p.unit_m.map(|u| r.k * u * u),
        "porosity": r.porosity, "porosity_particles": 1.0 - v.phi_particles, "re": r.re,
        "v_over_s_unit": v.v_over_s,
        "kozeny_constant": kozeny(v.phi_particles),
        "kozeny_constant_voxel_phi": kozeny(1.0 - r.porosity),
        "steps": r.run.steps, "residual": r.run.residual, "converged": r.run.converged,
        "mach": r.run.u_max * 3f64.sqrt(),
    });
    write_summary(out, &summary)
}

fn write_summary(out: &Path, summary: &serde_json::Value) -> Result<()> {
    write_atomic(
        &out.join("summary.json"),
        serde_json::to_string_pretty(summary)
            .map_err(|e| Error::InvalidInput(e.to_string()))?
            .as_bytes(),
    )?;
    println!("  wrote {}", out.display());
    Ok(())
}
