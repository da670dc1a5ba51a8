//! `porelab field`: the field of one posed cylinder at the points of a CSV file.
//!
//! Input: CSV with header `x,y,z` or `x_m,y_m,z_m` (m). Output on stdout: CSV with header
//! `x_m,y_m,z_m,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m,Bx_T,By_T,Bz_T` and, with `--gradient`, nine
//! more columns `dHx_dx_A_per_m2,...,dHz_dz_A_per_m2`, 17 significant digits. Bad input is one line on stderr naming
//! the problem (and the CSV line) with exit status 2 (see `main.rs`).

use crate::error::{invalid, Error, Result};
use crate::magnetics::{Cylinder, Magnet};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::io::Write;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct FieldArgs {
    /// Cylinder radius R in m.
    #[arg(long, allow_hyphen_values = true)]
    pub radius: f64,
    /// Cylinder semi-length L in m (the cylinder spans [-L, L] along its axis).
    #[arg(long = "half-length", allow_hyphen_values = true)]
    pub half_length: f64,
    /// Magnetization MX,MY,MZ in A/m (world frame).
    #[arg(long, allow_hyphen_values = true)]
    pub magnetization: String,
    /// Centre X,Y,Z in m.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub centre: String,
    /// Axis direction AX,AY,AZ.
    #[arg(long, default_value = "0,0,1", allow_hyphen_values = true)]
    pub axis: String,
    /// Also write the nine components dH_i/dx_j in A/m^2.
    #[arg(long)]
    pub gradient: bool,
    /// CSV file with header x,y,z (m).
    #[arg(long)]
    pub points: std::path::PathBuf,
}

/// Parses "a,b,c" into a finite vector; `what` names the option in the error.
pub fn parse_triple(text: &str, what: &str) -> Result<Vector3<f64>> {
    Ok(Vector3::from(crate::io::parse_three(text, what)?))
}

/// Reads the points of a CSV file with header x,y,z; errors name the file and line.
pub fn read_points(path: &std::path::Path) -> Result<Vec<Vector3<f64>>> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let text = std::fs::read_to_string(path).map_err(|e| file_err(e.to_string()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| file_err("empty file: expected header x,y,z".into()))?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    if cols != ["x", "y", "z"] && cols != ["x_m", "y_m", "z_m"] {
        return Err(file_err(format!(
            "line 1: header must be x,y,z or x_m,y_m,z_m (metres), found '{header}'"
        )));
    }
    let mut points = Vec::new();
    for (i, line) in lines {
        let lineno = i + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != 3 {
            return Err(file_err(format!(
                "line {lineno}: expected 3 values, found {}",
                cells.len()
            )));
        }
        let mut v = [0.0; 3];
        for k in 0..3 {
            v[k] = cells[k]
                .parse::<f64>()
                .map_err(|_| file_err(format!("line {lineno}: '{}' is not a number", cells[k])))?;
            if !v[k].is_finite() {
                return Err(file_err(format!(
                    "line {lineno}: '{}' is not finite",
                    cells[k]
                )));
            }
        }
        points.push(Vector3::new(v[0], v[1], v[2]));
    }
    Ok(points)
}

pub fn run_field(args: &FieldArgs) -> Result<ExitCode> {
    let cylinder = Cylinder::new(args.radius, args.half_length)?;
    let magnet = Magnet::new(
        cylinder,
        parse_triple(&args.centre, "centre")?,
        parse_triple(&args.axis, "axis")?,
        parse_triple(&args.magnetization, "magnetization")?,
    )?;
    let points = read_points(&args.points)?;
    let rows: Vec<String> = points
        .par_iter()
        .map(|p| {
            let h = magnet.h_field(p);
            let b = magnet.b_from_h(p, &h);
            let mut cells: Vec<f64> = vec![p.x, p.y, p.z, h.x, h.y, h.z, b.x, b.y, b.z];
            if args.gradient {
                let g = magnet.h_gradient(p);
                for i in 0..3 {
                    for j in 0..3 {
                        cells.push(g[(i, j)]);
                    }
                }
            }
            cells
                .iter()
                .map(|v| format!("{v:.16e}"))
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    for (i, (row, p)) in rows.iter().zip(&points).enumerate() {
        if row.contains("inf") || row.contains("NaN") {
            return invalid(format!(
                "{}: line {}: the field or its gradient is not finite at point ({}, {}, {}) m: on a rim \
                 circle of the cylinder it is infinite; anywhere else this is a porelab defect, \
                 please report the point",
                args.points.display(),
                i + 2,
                p.x,
                p.y,
                p.z
            ));
        }
    }
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    // Units in the column names, as in every porelab table.
    let mut header = String::from("x_m,y_m,z_m,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m,Bx_T,By_T,Bz_T");
    if args.gradient {
        for i in ["x", "y", "z"] {
            for j in ["x", "y", "z"] {
                header.push_str(&format!(",dH{i}_d{j}_A_per_m2"));
            }
        }
    }
    writeln!(out, "{header}")?;
    for row in rows {
        writeln!(out, "{row}")?;
    }
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}
