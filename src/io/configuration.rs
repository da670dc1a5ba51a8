//! A particle configuration from another tool's file, its format told by the content (not the
//! extension), and the checks that make it a packing porelab can voxelise.
//!
//! Formats ([`Format`]):
//! - extended XYZ ([`super::xyz`]): the libAtoms/QUIP convention that ASE (`ase.io.extxyz`,
//!   "Extended XYZ support", whose `Properties=species:S:1:pos:R:3` header and `Lattice`,
//!   `pbc` keys it writes) and OVITO (manual, "XYZ file reader": extended XYZ with
//!   `Properties`, `Lattice`, `Origin`, `pbc`; "Non-spherical particle shapes": Radius,
//!   Aspherical Shape, Orientation X Y Z W, Superquadric Roundness) read and write; any
//!   column order, with or without orientation and shape columns. Told by a first line that is
//!   a particle count.
//! - LAMMPS / LIGGGHTS text dumps of spheres ([`super::lammps_dump`]; LAMMPS manual, `dump`
//!   command). Told by a first line `ITEM: ...`.
//!
//! A file of several frames (an XYZ trajectory, a dump written every N steps) gives its last
//! frame unless another is chosen (`frame`: 0 the first, -1 the last, -2 the one before).
//!
//! [`check_overlaps`] refuses overlapping and coincident particles: a pair whose overlap depth
//! exceeds `max_overlap` times the smaller particle's size (its diameter; for a non-sphere
//! twice its inscribed radius) is an error. Spheres are compared in closed form; other shapes
//! through the contact kernels of [`crate::contact`] (common-normal overlap depth). Candidate
//! pairs come from a periodic cell list, so the check is O(N).

use super::lammps_dump;
use super::xyz::{self, contact_shape, inscribed_radius, Frame};
use crate::contact::{contact_perturbed, CellList, ContactShape, Pose};
use crate::error::{invalid, Error};
use crate::Result;
use nalgebra::Vector3;
use std::path::Path;

/// A file format porelab reads particle configurations from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    ExtendedXyz,
    LammpsDump,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::ExtendedXyz => "extended XYZ",
            Format::LammpsDump => "LAMMPS dump",
        }
    }
}

/// The format of `text` by its first non-blank line: `ITEM:` (LAMMPS dump) or a whole number
/// (XYZ); None for anything else.
pub fn detect(text: &str) -> Option<Format> {
    let first = text.lines().find(|l| !l.trim().is_empty())?.trim();
    if first.starts_with("ITEM:") {
        Some(Format::LammpsDump)
    } else if first.parse::<usize>().is_ok() {
        Some(Format::ExtendedXyz)
    } else {
        None
    }
}

/// One frame of a file, with where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Configuration {
    pub format: Format,
    /// The frame read (0-based) and the number of frames in the file.
    pub frame: usize,
    pub frames: usize,
    /// The dump's timestep of the frame (LAMMPS dumps only).
    pub timestep: Option<u64>,
    pub data: Frame,
}

impl Configuration {
    /// One line naming what was read, e.g. "read packing.dump: LAMMPS dump, frame 3 of 3
    /// (timestep 2000), 64 particles, box 6 x 6 x 6 (periodic T T T)".
    pub fn summary(&self, origin: &str) -> String {
        let c = &self.data.cell;
        let tf = |b: bool| if b { "T" } else { "F" };
        format!(
            "read {origin}: {}, frame {} of {}{}, {} particles, box {} x {} x {} (periodic {} {} {})",
            self.format.name(),
            self.frame + 1,
            self.frames,
            self.timestep
                .map(|t| format!(" (timestep {t})"))
                .unwrap_or_default(),
            self.data.particles.len(),
            c.lengths[0],
            c.lengths[1],
            c.lengths[2],
            tf(c.pbc[0]),
            tf(c.pbc[1]),
            tf(c.pbc[2]),
        )
    }
}

/// The frame index of `wanted` (0 first, -1 last) among `count` frames, or an error naming
/// `option`.
fn frame_index(wanted: i64, count: usize, option: &str) -> Result<usize> {
    let k = if wanted < 0 {
        count as i64 + wanted
    } else {
        wanted
    };
    if k < 0 || k >= count as i64 {
        return invalid(format!(
            "{option} {wanted}: the file has {count} frame{} (0 to {}, or -1 the last)",
            if count == 1 { "" } else { "s" },
            count as i64 - 1
        ));
    }
    Ok(k as usize)
}

/// Reads frame `frame` (0 the first, -1 the last; `frame_option` names it in errors) of the
/// configuration in `text`; `origin` names the file in errors.
pub fn parse(text: &str, origin: &str, frame: i64, frame_option: &str) -> Result<Configuration> {
    let lines: Vec<&str> = text.lines().collect();
    match detect(text) {
        Some(Format::ExtendedXyz) => {
            let starts = xyz::frame_starts(&lines, origin)?;
            let k = frame_index(frame, starts.len(), frame_option)?;
            Ok(Configuration {
                format: Format::ExtendedXyz,
                frame: k,
                frames: starts.len(),
                timestep: None,
                data: xyz::read_frame_at(&lines, starts[k], origin)?,
            })
        }
        Some(Format::LammpsDump) => {
            let all = lammps_dump::frames(&lines, origin)?;
            let k = frame_index(frame, all.len(), frame_option)?;
            Ok(Configuration {
                format: Format::LammpsDump,
                frame: k,
                frames: all.len(),
                timestep: all[k].timestep,
                data: lammps_dump::read_frame(&lines, &all[k], origin)?,
            })
        }
        None => Err(Error::File {
            path: origin.to_string(),
            msg: format!(
                "line 1: `{}` is neither a particle count (extended XYZ) nor `ITEM: ...` \
                 (LAMMPS dump)",
                text.lines().next().unwrap_or("").trim()
            ),
        }),
    }
}

/// [`parse`] of the file at `path`.
pub fn read(path: &Path, frame: i64, frame_option: &str) -> Result<Configuration> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| Error::File {
        path: origin.clone(),
        msg: e.to_string(),
    })?;
    parse(&text, &origin, frame, frame_option)
}

/// What [`check_overlaps`] found in a configuration that passed.
#[derive(Debug, Clone, PartialEq)]
pub struct OverlapReport {
    /// Pairs whose bounding spheres meet (periodic images included).
    pub pairs_within_reach: usize,
    /// The deepest overlap found, as a fraction of the smaller particle's size (0: none).
    pub deepest: f64,
    /// Pairs the contact kernels could not decide (no query for the pair, or no converged
    /// answer); their inscribed spheres do not overlap beyond the tolerance.
    pub undecided: usize,
}

/// One particle ready for the pair tests.
struct Body {
    shape: ContactShape,
    /// Twice the inscribed radius: the size an overlap is measured against.
    size: f64,
    bounding: f64,
}

/// Refuses a configuration with particles that overlap deeper than `max_overlap` times the
/// smaller particle's size (coincident particles included), naming the two lines. Periodic
/// axes are wrapped (minimum image; a particle also meets its own images where the box is
/// smaller than it).
pub fn check_overlaps(f: &Frame, origin: &str, max_overlap: f64) -> Result<OverlapReport> {
    let bodies: Vec<Body> = f
        .particles
        .iter()
        .zip(&f.lines)
        .map(|(p, line)| {
            let shape = contact_shape(p).map_err(|m| Error::File {
                path: origin.to_string(),
                msg: format!("line {line}: {m}"),
            })?;
            Ok(Body {
                shape,
                size: 2.0 * inscribed_radius(&shape),
                bounding: crate::shape::bounding_radius_of(&shape)?,
            })
        })
        .collect::<Result<_>>()?;
    let mut report = OverlapReport {
        pairs_within_reach: 0,
        deepest: 0.0,
        undecided: 0,
    };
    let reach = 2.0 * bodies.iter().map(|b| b.bounding).fold(0.0, f64::max);
    if bodies.is_empty() {
        return Ok(report);
    }
    let cell = &f.cell;
    let shortest = (0..3)
        .filter(|&k| cell.pbc[k])
        .map(|k| cell.lengths[k])
        .fold(f64::INFINITY, f64::min);
    let pos: Vec<Vector3<f64>> = f.particles.iter().map(|p| p.position).collect();
    let mut test = |i: usize, j: usize, d: Vector3<f64>| -> Result<()> {
        pair_test(&bodies, f, origin, max_overlap, (i, j, d), &mut report)
    };
    if cell.pbc == [true; 3] && reach <= 0.5 * shortest {
        for (i, j, d) in CellList::orthorhombic(cell.lengths, reach)?.pairs(&pos) {
            test(i, j, d)?;
        }
    } else {
        // a box smaller than two particles across, or open axes: every pair, and every
        // particle with itself, at the periodic images -1, 0, +1 of each periodic axis
        let shifts: Vec<Vector3<f64>> = (0..27)
            .map(|s| {
                Vector3::new(
                    (s % 3) as f64 - 1.0,
                    ((s / 3) % 3) as f64 - 1.0,
                    (s / 9) as f64 - 1.0,
                )
            })
            .filter(|s| (0..3).all(|k| cell.pbc[k] || s[k] == 0.0))
            .map(|s| Vector3::from_fn(|k, _| s[k] * cell.lengths[k]))
            .collect();
        for i in 0..pos.len() {
            for j in i..pos.len() {
                for s in &shifts {
                    if i == j && *s == Vector3::zeros() {
                        continue;
                    }
                    let d = pos[j] + s - pos[i];
                    if d.norm() < bodies[i].bounding + bodies[j].bounding {
                        test(i, j, d)?;
                    }
                }
            }
        }
    }
    Ok(report)
}

/// The overlap test of particles i and j at separation d = r_j - r_i.
fn pair_test(
    bodies: &[Body],
    f: &Frame,
    origin: &str,
    max_overlap: f64,
    (i, j, d): (usize, usize, Vector3<f64>),
    report: &mut OverlapReport,
) -> Result<()> {
    let (a, b) = (&bodies[i], &bodies[j]);
    let dist = d.norm();
    if dist >= a.bounding + b.bounding {
        return Ok(());
    }
    report.pairs_within_reach += 1;
    let size = a.size.min(b.size);
    // the inscribed spheres give a lower bound of the depth for every pair of shapes
    let mut depth = 0.5 * (a.size + b.size) - dist;
    let exact = match (a.shape, b.shape) {
        (ContactShape::Sphere { .. }, ContactShape::Sphere { .. }) => true,
        _ => {
            let pa = Pose::new(Vector3::zeros(), f.particles[i].orientation);
            let pb = Pose::new(d, f.particles[j].orientation);
            match contact_perturbed(&a.shape, &pa, &b.shape, &pb, 1e-9) {
                Ok(c) => {
                    depth = -c.gap;
                    true
                }
                Err(_) => false,
            }
        }
    };
    if !exact && depth <= max_overlap * size {
        report.undecided += 1;
        return Ok(());
    }
    let fraction = depth / size;
    if fraction > max_overlap {
        let (li, lj) = (f.lines[i], f.lines[j]);
        let who = if i == j {
            format!("the particle on line {li} overlaps its own periodic image")
        } else if dist <= 1e-9 * size {
            format!("the particles on lines {li} and {lj} are at the same position (coincident)")
        } else {
            format!("the particles on lines {li} and {lj} overlap")
        };
        return Err(Error::File {
            path: origin.to_string(),
            msg: format!(
                "{who}: depth {:.3e} of the smaller particle's size {size} (centres {dist:.6} \
                 apart); at most {max_overlap:e} is allowed (--max-overlap: a soft-sphere DEM \
                 packing overlaps at its contacts)",
                fraction
            ),
        });
    }
    report.deepest = report.deepest.max(fraction);
    Ok(())
}
