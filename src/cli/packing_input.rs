//! The packing `porelab permeability` reads, refused up front where it cannot give a
//! meaningful permeability: the options first, then the file (any format of
//! [`crate::io::configuration`]), its particles, the resolution against the smallest particle,
//! the periodic box, and overlaps.

use crate::error::{invalid, Error, Result};
use crate::io::configuration::{self, check_overlaps};
use crate::io::xyz::{contact_shape, inscribed_radius, Cell, XyzParticle};
use std::path::Path;

/// What the command line says about the packing to read.
#[derive(Debug, Clone, Copy)]
pub struct PackingInput<'a> {
    pub path: &'a Path,
    /// `--frame`: 0 the first, -1 the last.
    pub frame: i64,
    /// `--resolution`: cells along the box's x edge.
    pub resolution: usize,
    /// `--unit-m`: the file's length unit in metres.
    pub unit_m: Option<f64>,
    /// `--max-overlap`: the deepest overlap allowed, as a fraction of the smaller particle's
    /// size.
    pub max_overlap: f64,
}

/// The largest `--max-overlap`: deeper, two spheres share more than half a radius.
const MAX_OVERLAP_LIMIT: f64 = 0.25;

/// Reads and checks the packing; prints what was read and the overlap found (stdout).
/// Refused (each an `Err` naming the option, or the file and line, and the rule): a
/// `--unit-m` not positive and finite, a `--max-overlap` outside [0, 0.25], an unreadable
/// file, a frame with no particles, a `--resolution` whose cell spacing dx leaves the smallest
/// particle without a cell centre where it sits (its inscribed radius must be at least
/// sqrt(3)/2 dx, the covering radius of the cubic lattice), a box that is not periodic or
/// whose edges are not whole numbers of cells, and overlaps ([`check_overlaps`]).
pub fn read_packing(input: &PackingInput) -> Result<(Cell, Vec<XyzParticle>)> {
    if let Some(u) = input.unit_m {
        if !(u.is_finite() && u > 0.0) {
            return invalid(format!(
                "--unit-m {u}: must be positive and finite (the file's length unit in metres)"
            ));
        }
    }
    let m = input.max_overlap;
    if !(0.0..=MAX_OVERLAP_LIMIT).contains(&m) {
        return invalid(format!(
            "--max-overlap {m}: must lie in [0, {MAX_OVERLAP_LIMIT}] (a fraction of the smaller \
             particle's size)"
        ));
    }
    let origin = input.path.display().to_string();
    let conf = configuration::read(input.path, input.frame, "--frame")?;
    println!("{}", conf.summary(&origin));
    let f = &conf.data;
    let file = |msg: String| Error::File {
        path: origin.clone(),
        msg,
    };
    if f.particles.is_empty() {
        return Err(file(
            "no particles in the frame read: there is nothing to voxelise".into(),
        ));
    }
    // the smallest particle against the lattice spacing
    let mut smallest = (f64::INFINITY, 0);
    for (p, line) in f.particles.iter().zip(&f.lines) {
        let s = contact_shape(p).map_err(|m| file(format!("line {line}: {m}")))?;
        let r = inscribed_radius(&s);
        if r < smallest.0 {
            smallest = (r, *line);
        }
    }
    let n = input.resolution;
    let lx = f.cell.lengths[0];
    let dx = lx / n as f64;
    let covering = 0.5 * 3f64.sqrt();
    if n == 0 || smallest.0 < covering * dx {
        let needed = (covering * lx / smallest.0).ceil();
        return invalid(format!(
            "--resolution {n}: cells of dx = {dx:.4} ({origin}: box edge x {lx} / {n}) do not \
             resolve the particle on line {} (inscribed radius {}): it must be at least \
             sqrt(3)/2 dx so that it holds a cell centre wherever it sits; use --resolution >= \
             {needed}",
            smallest.1, smallest.0
        ));
    }
    crate::lbm::voxels::voxel_dims(&f.cell, n)?;
    let r = check_overlaps(f, &origin, m)?;
    println!(
        "overlap check: {} pairs within reach, deepest overlap {:.2e} of the smaller particle's \
         size (at most {m:e}){}",
        r.pairs_within_reach,
        r.deepest,
        if r.undecided > 0 {
            format!(
                "; {} pairs left undecided by the contact kernels (their inscribed spheres do \
                 not overlap)",
                r.undecided
            )
        } else {
            String::new()
        }
    );
    Ok((f.cell, f.particles.clone()))
}
