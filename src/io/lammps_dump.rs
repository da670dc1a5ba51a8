//! LAMMPS and LIGGGHTS text dump files of spheres (`dump custom`, and `dump atom` where it
//! carries a size).
//!
//! The format (LAMMPS manual, `dump` command; LAMMPS `DumpCustom::header_item`, whose header
//! LIGGGHTS-PUBLIC's `dump_custom.cpp` keeps): frames follow each other, each
//!
//! ```text
//! ITEM: TIMESTEP
//! 1000
//! ITEM: NUMBER OF ATOMS
//! 64
//! ITEM: BOX BOUNDS pp pp ff
//! xlo xhi
//! ylo yhi
//! zlo zhi
//! ITEM: ATOMS id type x y z radius
//! 1 1 0.5 0.5 0.5 0.5
//! ...
//! ```
//!
//! The boundary flags are two letters per axis (p periodic, f fixed, s and m shrink-wrapped);
//! an axis is periodic when both are p. A triclinic box (`ITEM: BOX BOUNDS xy xz yz ..`, three
//! numbers a line) is read when its tilt factors are 0 and refused otherwise. LAMMPS may
//! precede a frame with `ITEM: UNITS` and `ITEM: TIME`, LIGGGHTS with `ITEM: LABEL`; their
//! values are skipped. Positions are the first of `x y z`, `xu yu zu` (unwrapped), `xs ys zs`
//! (scaled: x = xlo + xs (xhi - xlo)) and `xsu ysu zsu`; the size is `radius` or `diameter`;
//! the type name is the `type` column (a number or a type label). Columns of non-spherical
//! particles (`shapex`, `quatw`, LIGGGHTS's `quat1` and `roundness1`, ...) are refused: only
//! dumps of spheres are read.

use super::xyz::{shaped, Cell, Frame, ReadColumns};
use crate::error::Error;
use crate::Result;

/// Where one frame sits in the file (0-based line indices).
#[derive(Debug, Clone, Copy)]
pub struct FrameAt {
    pub timestep: Option<u64>,
    pub count: usize,
    box_line: usize,
    atoms_line: usize,
}

fn file_err(origin: &str, line: usize, msg: String) -> Error {
    Error::File {
        path: origin.to_string(),
        msg: format!("line {line}: {msg}"),
    }
}

/// Every frame of a dump, in file order, found by its `ITEM:` lines (the particle lines are
/// skipped, not parsed).
pub fn frames(lines: &[&str], origin: &str) -> Result<Vec<FrameAt>> {
    let err = |i: usize, msg: String| file_err(origin, i + 1, msg);
    let value = |i: usize, what: &str| -> Result<u64> {
        lines
            .get(i + 1)
            .and_then(|l| l.trim().parse().ok())
            .ok_or_else(|| err(i + 1, format!("{what} must be a whole number")))
    };
    let mut out = Vec::new();
    let (mut timestep, mut count, mut box_line) = (None, None, None);
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i].trim();
        if l.is_empty() {
            i += 1;
            continue;
        }
        let item = l
            .strip_prefix("ITEM:")
            .ok_or_else(|| err(i, format!("`{l}`: expected an `ITEM:` line")))?
            .trim();
        if item == "TIMESTEP" {
            timestep = Some(value(i, "the timestep")?);
            i += 2;
        } else if item == "NUMBER OF ATOMS" {
            count = Some(value(i, "the number of atoms")? as usize);
            i += 2;
        } else if item.starts_with("BOX BOUNDS") {
            box_line = Some(i);
            i += 4;
        } else if item.starts_with("ATOMS") {
            let (Some(n), Some(b)) = (count, box_line) else {
                return Err(err(
                    i,
                    "ITEM: ATOMS before ITEM: NUMBER OF ATOMS and ITEM: BOX BOUNDS".into(),
                ));
            };
            out.push(FrameAt {
                timestep,
                count: n,
                box_line: b,
                atoms_line: i,
            });
            (timestep, count, box_line) = (None, None, None);
            i += 1 + n;
        } else if matches!(item, "UNITS" | "TIME" | "LABEL") {
            i += 2;
        } else {
            return Err(err(
                i,
                format!("`ITEM: {item}` is not an item of a LAMMPS dump of atoms"),
            ));
        }
    }
    if out.is_empty() {
        return Err(err(
            lines.len(),
            "no `ITEM: ATOMS` section: no frame".into(),
        ));
    }
    Ok(out)
}

/// The box of the `ITEM: BOX BOUNDS` line `b` (0-based) and the three lines after it.
fn box_of(lines: &[&str], b: usize, origin: &str) -> Result<Cell> {
    let err = |i: usize, msg: String| file_err(origin, i + 1, msg);
    let words: Vec<&str> = lines[b]
        .trim()
        .trim_start_matches("ITEM:")
        .split_whitespace()
        .skip(2)
        .collect();
    let triclinic = words.len() >= 3 && words[..3] == ["xy", "xz", "yz"];
    let flags = if triclinic { &words[3..] } else { &words[..] };
    if flags.len() != 3 {
        return Err(err(
            b,
            format!(
                "`{}`: expected three boundary flags such as `pp pp pp` (older dumps without \
                 them cannot tell whether the box is periodic)",
                lines[b].trim()
            ),
        ));
    }
    let mut pbc = [false; 3];
    for (k, f) in flags.iter().enumerate() {
        if f.len() != 2 || !f.chars().all(|c| matches!(c, 'p' | 'f' | 's' | 'm')) {
            return Err(err(
                b,
                format!("boundary flag `{f}`: must be two of p, f, s, m"),
            ));
        }
        pbc[k] = *f == "pp";
    }
    let (mut lengths, mut origin_) = ([0.0; 3], [0.0; 3]);
    for k in 0..3 {
        let i = b + 1 + k;
        let v: Vec<f64> = lines
            .get(i)
            .map(|l| l.split_whitespace().map(str::parse).collect())
            .unwrap_or(Ok(Vec::new()))
            .map_err(|_| err(i, "box bounds must be numbers".into()))?;
        let want = if triclinic { 3 } else { 2 };
        if v.len() != want || v.iter().any(|x: &f64| !x.is_finite()) {
            return Err(err(
                i,
                format!(
                    "expected {want} finite numbers (lo hi{})",
                    if triclinic { " tilt" } else { "" }
                ),
            ));
        }
        if triclinic && v[2] != 0.0 {
            return Err(err(
                i,
                format!(
                    "tilt factor {} of a triclinic box: only orthorhombic boxes are read",
                    v[2]
                ),
            ));
        }
        if v[1] <= v[0] {
            return Err(err(
                i,
                format!(
                    "box bounds {} {}: the upper bound must exceed the lower",
                    v[0], v[1]
                ),
            ));
        }
        origin_[k] = v[0];
        lengths[k] = v[1] - v[0];
    }
    Ok(Cell {
        lengths,
        origin: origin_,
        pbc,
    })
}

/// Columns that describe non-spherical particles (LAMMPS ellipsoids and bodies, LIGGGHTS
/// superquadrics).
const NON_SPHERE_COLUMNS: [&str; 13] = [
    "shapex",
    "shapey",
    "shapez",
    "quatw",
    "quati",
    "quatj",
    "quatk",
    "quat1",
    "quat2",
    "quat3",
    "quat4",
    "roundness1",
    "roundness2",
];

/// Reads frame `f` of the dump's `lines`.
pub fn read_frame(lines: &[&str], f: &FrameAt, origin: &str) -> Result<Frame> {
    let err = |i: usize, msg: String| file_err(origin, i + 1, msg);
    let cell = box_of(lines, f.box_line, origin)?;
    let a = f.atoms_line;
    let names: Vec<&str> = lines[a]
        .trim()
        .trim_start_matches("ITEM:")
        .split_whitespace()
        .skip(1)
        .collect();
    let col = |name: &str| names.iter().position(|n| *n == name);
    if let Some(n) = names.iter().find(|n| NON_SPHERE_COLUMNS.contains(n)) {
        return Err(err(
            a,
            format!(
                "column `{n}` describes non-spherical particles: only dumps of spheres are read"
            ),
        ));
    }
    let sets = [
        (["x", "y", "z"], false),
        (["xu", "yu", "zu"], false),
        (["xs", "ys", "zs"], true),
        (["xsu", "ysu", "zsu"], true),
    ];
    let (pos, scaled) = sets
        .iter()
        .find_map(|(s, scaled)| Some(([col(s[0])?, col(s[1])?, col(s[2])?], *scaled)))
        .ok_or_else(|| {
            err(
                a,
                "no position columns (x y z, xu yu zu, xs ys zs or xsu ysu zsu)".into(),
            )
        })?;
    let (size, halve) = match (col("radius"), col("diameter")) {
        (Some(c), _) => (c, false),
        (None, Some(c)) => (c, true),
        (None, None) => {
            return Err(err(
                a,
                "no `radius` or `diameter` column: the sphere sizes are not in the dump \
                 (write it with `dump custom ... radius`)"
                    .into(),
            ))
        }
    };
    let label = col("type").or_else(|| col("element"));
    let mut particles = Vec::with_capacity(f.count);
    let mut at = Vec::with_capacity(f.count);
    for k in 0..f.count {
        let i = a + 1 + k;
        let t: Vec<&str> = lines
            .get(i)
            .ok_or_else(|| {
                err(
                    i,
                    format!(
                        "the file ends after {k} atoms; NUMBER OF ATOMS says {}",
                        f.count
                    ),
                )
            })?
            .split_whitespace()
            .collect();
        if t.len() != names.len() {
            return Err(err(
                i,
                format!("{} columns; ITEM: ATOMS names {}", t.len(), names.len()),
            ));
        }
        let num = |c: usize| -> Result<f64> {
            t[c].parse::<f64>().map_err(|_| {
                err(
                    i,
                    format!("`{}` value `{}` is not a number", names[c], t[c]),
                )
            })
        };
        let mut position = [0.0; 3];
        for k in 0..3 {
            let v = num(pos[k])?;
            position[k] = if scaled {
                cell.origin[k] + v * cell.lengths[k]
            } else {
                v
            };
        }
        let s = num(size)?;
        let columns = ReadColumns {
            label: label.map(|c| t[c]),
            position,
            radius: Some(if halve { 0.5 * s } else { s }),
            ..ReadColumns::default()
        };
        particles.push(shaped(&columns).map_err(|m| err(i, m))?);
        at.push(i + 1);
    }
    Ok(Frame {
        cell,
        particles,
        lines: at,
    })
}
