//! Legacy VTK (ASCII) image data: a regular grid of cells with scalar and vector cell fields,
//! the format ParaView opens as `.vtk` (STRUCTURED_POINTS, CELL_DATA; VTK File Formats,
//! Kitware, "Simple Legacy Formats"). Numbers are written in Rust's shortest round-trip form.

use crate::error::{invalid, Result};
use std::fmt::Write as _;
use std::path::Path;

/// One cell field.
pub enum CellField<'a> {
    Scalar(&'a str, &'a [f64]),
    Vector(&'a str, &'a [[f64; 3]]),
}

/// The text of an image of `dims` cells of edge `spacing` (m) with lower corner `origin`.
pub fn image_data(
    title: &str,
    dims: [usize; 3],
    spacing: f64,
    origin: [f64; 3],
    fields: &[CellField],
) -> Result<String> {
    let cells = dims[0] * dims[1] * dims[2];
    let mut s = String::new();
    let title = title.replace('\n', " ");
    let _ = write!(
        s,
        "# vtk DataFile Version 3.0\n{title}\nASCII\nDATASET STRUCTURED_POINTS\n\
         DIMENSIONS {} {} {}\nORIGIN {} {} {}\nSPACING {spacing} {spacing} {spacing}\nCELL_DATA {cells}\n",
        dims[0] + 1,
        dims[1] + 1,
        dims[2] + 1,
        origin[0],
        origin[1],
        origin[2]
    );
    for f in fields {
        match f {
            CellField::Scalar(name, v) => {
                check(name, v.len(), cells)?;
                let _ = writeln!(s, "SCALARS {name} double 1\nLOOKUP_TABLE default");
                for (i, x) in v.iter().enumerate() {
                    finite(name, i, *x)?;
                    let _ = writeln!(s, "{x}");
                }
            }
            CellField::Vector(name, v) => {
                check(name, v.len(), cells)?;
                let _ = writeln!(s, "VECTORS {name} double");
                for (i, x) in v.iter().enumerate() {
                    for c in x {
                        finite(name, i, *c)?;
                    }
                    let _ = writeln!(s, "{} {} {}", x[0], x[1], x[2]);
                }
            }
        }
    }
    Ok(s)
}

fn finite(name: &str, cell: usize, x: f64) -> Result<()> {
    if !x.is_finite() {
        return invalid(format!(
            "VTK field {name}: cell {cell} holds {x}, not a finite number"
        ));
    }
    Ok(())
}

fn check(name: &str, len: usize, cells: usize) -> Result<()> {
    if name.is_empty() || name.contains(char::is_whitespace) {
        return invalid(format!(
            "VTK field name `{name}` must be non-empty without spaces"
        ));
    }
    if len != cells {
        return invalid(format!(
            "VTK field {name} has {len} values for {cells} cells"
        ));
    }
    Ok(())
}

/// Writes [`image_data`] atomically to `path`.
pub fn write_image_data(
    path: &Path,
    title: &str,
    dims: [usize; 3],
    spacing: f64,
    origin: [f64; 3],
    fields: &[CellField],
) -> Result<()> {
    super::write_atomic(
        path,
        image_data(title, dims, spacing, origin, fields)?.as_bytes(),
    )
}
