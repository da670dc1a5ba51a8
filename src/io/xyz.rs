//! Extended XYZ (the format OVITO, ASE and others read) for particle configurations in an
//! orthorhombic cell (a periodic cubic box, or the bounding box of a cylinder, periodic along
//! its axis only).
//!
//! Header line 2 (README, "Output formats", lists every column):
//! `Lattice="Lx 0 0 0 Ly 0 0 0 Lz" Origin="x0 y0 z0" pbc="T T T"
//! Properties=type:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:radius:R:1:cylinder_length:R:1:superquadric_roundness:R:2`
//! plus any `key=value` pairs the caller adds. Orientation is the body-to-world unit quaternion
//! as X, Y, Z, W (OVITO's order); the particle axis is the body z axis. Numbers are written
//! in Rust's shortest round-trip form, so reading the file back gives the same f64 values.
//!
//! The names are the ones the two common readers understand. OVITO 3.x maps `type` to
//! Particle Type, `pos`, `orientation`, `aspherical_shape` and `radius` to its standard
//! properties by name (QUIP's extended-XYZ conventions); it has no extended-XYZ name for
//! Superquadric Roundness nor for a particle type's display shape, so `superquadric_roundness`
//! arrives as a property of that name for the user to map (README, "Output formats"). ASE
//! reads `type` as a string array and, with no `species` column, gives every particle the
//! dummy symbol X instead of misreading a shape name as a chemical element.
//!
//! The reader ([`read_frame_at`], [`parse`]) takes any extended XYZ whose `Properties=`
//! describes the particles, in any column order: porelab's layout, the first layout (columns
//! `species` and `roundness`, [`LEGACY_PROPERTIES`]), OVITO's export (`radius` first, `species`
//! for the type, `aspherical_shape` 0 0 0 for spheres; OVITO manual, "XYZ file reader" and
//! "Non-spherical particle shapes") and ASE's (`species:S:1:pos:R:3` plus the arrays the user
//! added, `Lattice`, `pbc`; ASE `ase.io.extxyz`). [`shaped`] turns one line's columns into a
//! particle and [`contact_shape`] into the convex shape the voxeliser and the contact kernels
//! see.

use crate::contact::ContactShape;
use crate::error::{invalid, Error};
use crate::Result;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::fmt::Write as _;
use std::path::Path;

/// An orthorhombic cell: edge lengths, origin (lowest corner) and periodicity per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub lengths: [f64; 3],
    pub origin: [f64; 3],
    pub pbc: [bool; 3],
}

impl Cell {
    /// The periodic cube [0, l)^3.
    pub fn cubic(l: f64) -> Cell {
        Cell {
            lengths: [l; 3],
            origin: [0.0; 3],
            pbc: [true; 3],
        }
    }
}

/// The columns of one particle.
#[derive(Debug, Clone, PartialEq)]
pub struct XyzParticle {
    /// Particle type name (no whitespace; the `type` column), e.g. `sphere` or
    /// `spherocylinder`.
    pub species: String,
    pub position: Vector3<f64>,
    /// Body -> world.
    pub orientation: UnitQuaternion<f64>,
    /// OVITO's Aspherical Shape: ellipsoid semi-axes; for a spherocylinder (R, R, L) with L
    /// the cylinder length (OVITO: X = radius, Z = length of the cylindrical part).
    pub aspherical_shape: [f64; 3],
    pub radius: f64,
    /// Cylinder length between the hemisphere centres (0 for spheres).
    pub cylinder_length: f64,
    /// OVITO's Superquadric Roundness (e, n) = (2 / g_xy, 2 / g_z) for a superquadric with
    /// exponents g (1, 1 for every other shape).
    pub roundness: [f64; 2],
}

impl XyzParticle {
    /// A sphere of `radius` at `position` (type `sphere`, identity orientation).
    pub fn sphere(position: Vector3<f64>, radius: f64) -> XyzParticle {
        XyzParticle {
            species: "sphere".into(),
            position,
            orientation: UnitQuaternion::identity(),
            aspherical_shape: [radius; 3],
            radius,
            cylinder_length: 0.0,
            roundness: [1.0, 1.0],
        }
    }
}

/// The `Properties=` value written by [`to_string`].
pub const PROPERTIES: &str =
    "type:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:radius:R:1:cylinder_length:R:1:\
     superquadric_roundness:R:2";

/// The `Properties=` value of files written before the columns were renamed (same columns in
/// the same order); [`parse`] reads both.
pub const LEGACY_PROPERTIES: &str =
    "species:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:radius:R:1:cylinder_length:R:1:\
     roundness:R:2";

/// The extended XYZ text of one frame. `extra` holds further `key=value` header pairs
/// (keys without whitespace; values are quoted when they contain spaces).
pub fn to_string(
    cell: &Cell,
    particles: &[XyzParticle],
    extra: &[(&str, String)],
) -> Result<String> {
    if let Some(l) = cell.lengths.iter().find(|l| !(l.is_finite() && **l > 0.0)) {
        return invalid(format!("cell length {l}: must be positive and finite"));
    }
    if let Some(o) = cell.origin.iter().find(|o| !o.is_finite()) {
        return invalid(format!("cell origin {o}: must be finite"));
    }
    let [lx, ly, lz] = cell.lengths;
    let [ox, oy, oz] = cell.origin;
    let tf = |b: bool| if b { "T" } else { "F" };
    let mut s = String::with_capacity(120 * (particles.len() + 2));
    let _ = writeln!(s, "{}", particles.len());
    let _ = write!(
        s,
        "Lattice=\"{lx} 0 0 0 {ly} 0 0 0 {lz}\" Origin=\"{ox} {oy} {oz}\" pbc=\"{} {} {}\" \
         Properties={PROPERTIES}",
        tf(cell.pbc[0]),
        tf(cell.pbc[1]),
        tf(cell.pbc[2])
    );
    for (k, v) in extra {
        if k.is_empty() || k.contains(char::is_whitespace) || k.contains('=') {
            return invalid(format!(
                "header key `{k}`: must be non-empty without whitespace or '='"
            ));
        }
        if v.contains('"') {
            return invalid(format!("header value of `{k}`: must not contain '\"'"));
        }
        if v.contains(char::is_whitespace) || v.is_empty() {
            let _ = write!(s, " {k}=\"{v}\"");
        } else {
            let _ = write!(s, " {k}={v}");
        }
    }
    s.push('\n');
    for (i, p) in particles.iter().enumerate() {
        if p.species.is_empty() || p.species.contains(char::is_whitespace) {
            return invalid(format!(
                "particle {i}: species `{}` must be non-empty without whitespace",
                p.species
            ));
        }
        let q = p.orientation.quaternion();
        let x = &p.position;
        let a = &p.aspherical_shape;
        let _ = writeln!(
            s,
            "{} {} {} {} {} {} {} {} {} {} {} {} {} {} {}",
            p.species,
            x.x,
            x.y,
            x.z,
            q.i,
            q.j,
            q.k,
            q.w,
            a[0],
            a[1],
            a[2],
            p.radius,
            p.cylinder_length,
            p.roundness[0],
            p.roundness[1]
        );
    }
    Ok(s)
}

/// Writes one frame atomically (temporary file + rename).
pub fn write(
    path: &Path,
    cell: &Cell,
    particles: &[XyzParticle],
    extra: &[(&str, String)],
) -> Result<()> {
    super::write_atomic(path, to_string(cell, particles, extra)?.as_bytes())
}

/// One frame of a configuration as read: the cell, the particles and, for each particle,
/// the line of the file it came from (1-based, for error messages).
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub cell: Cell,
    pub particles: Vec<XyzParticle>,
    pub lines: Vec<usize>,
}

/// Reads the first frame of an extended XYZ text: (cell, particles). Any `Properties=` whose
/// columns describe the particles is read ([`read_frame_at`]); `origin` names the source in
/// errors.
pub fn parse(text: &str, origin: &str) -> Result<(Cell, Vec<XyzParticle>)> {
    let lines: Vec<&str> = text.lines().collect();
    let f = read_frame_at(&lines, 0, origin)?;
    Ok((f.cell, f.particles))
}

/// The first line (0-based) of every frame of an extended XYZ text: frames follow each other,
/// each a count line, a header line and that many particle lines. Blank lines after the last
/// frame are allowed.
pub fn frame_starts(lines: &[&str], origin: &str) -> Result<Vec<usize>> {
    let mut starts = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if lines[i..].iter().all(|l| l.trim().is_empty()) {
            break;
        }
        let n = count_line(lines, i, origin)?;
        starts.push(i);
        i += 2 + n;
    }
    Ok(starts)
}

fn file_err(origin: &str, line: usize, msg: String) -> Error {
    Error::File {
        path: origin.to_string(),
        msg: format!("line {line}: {msg}"),
    }
}

/// The particle count on line `i` (0-based).
fn count_line(lines: &[&str], i: usize, origin: &str) -> Result<usize> {
    lines
        .get(i)
        .and_then(|l| l.trim().parse().ok())
        .ok_or_else(|| {
            file_err(
                origin,
                i + 1,
                format!(
                    "`{}`: the first line of an XYZ frame must be the particle count",
                    lines.get(i).map_or("", |l| l.trim())
                ),
            )
        })
}

/// The `key=value` pairs of an extended XYZ header line (libAtoms/ASE extxyz convention):
/// values bare, in double quotes (backslash escapes) or in braces; a key alone is `None`.
fn header_pairs(header: &str) -> std::result::Result<Vec<(String, Option<String>)>, String> {
    let mut out = Vec::new();
    let mut it = header.chars().peekable();
    loop {
        while it.next_if(|c| c.is_whitespace()).is_some() {}
        if it.peek().is_none() {
            return Ok(out);
        }
        let mut key = String::new();
        while let Some(c) = it.next_if(|c| !c.is_whitespace() && *c != '=') {
            key.push(c);
        }
        if it.next_if_eq(&'=').is_none() {
            out.push((key, None));
            continue;
        }
        let mut value = String::new();
        match it.peek() {
            Some('"') => {
                it.next();
                loop {
                    match it.next() {
                        Some('\\') => value.extend(it.next()),
                        Some('"') => break,
                        Some(c) => value.push(c),
                        None => {
                            return Err(format!("the value of `{key}` lacks its closing quote"))
                        }
                    }
                }
            }
            Some('{') => {
                it.next();
                loop {
                    match it.next() {
                        Some('}') => break,
                        Some(c) => value.push(c),
                        None => {
                            return Err(format!("the value of `{key}` lacks its closing brace"))
                        }
                    }
                }
            }
            _ => {
                while let Some(c) = it.next_if(|c| !c.is_whitespace()) {
                    value.push(c);
                }
            }
        }
        out.push((key, Some(value)));
    }
}

/// Where each particle attribute sits on a particle line: first column and width.
#[derive(Debug, Default)]
struct Columns {
    total: usize,
    label: Option<usize>,
    pos: Option<usize>,
    radius: Option<usize>,
    diameter: Option<usize>,
    orientation: Option<usize>,
    aspherical_shape: Option<usize>,
    cylinder_length: Option<usize>,
    roundness: Option<usize>,
}

/// The columns named in a `Properties=` value (name:type:count triplets, types S, R, I, L).
/// Names are matched without regard to case; columns of other names are skipped.
fn columns_of(properties: &str) -> std::result::Result<Columns, String> {
    let t: Vec<&str> = properties.split(':').collect();
    if !t.len().is_multiple_of(3) || t.iter().any(|x| x.is_empty()) {
        return Err(format!(
            "Properties={properties}: must be name:type:count triplets"
        ));
    }
    let mut c = Columns::default();
    for w in t.chunks(3) {
        let (name, kind) = (w[0].to_ascii_lowercase(), w[1]);
        let count: usize = w[2]
            .parse()
            .ok()
            .filter(|n| *n > 0)
            .ok_or_else(|| format!("Properties: column `{}` has count `{}`", w[0], w[2]))?;
        if !matches!(kind, "S" | "R" | "I" | "L") {
            return Err(format!(
                "Properties: column `{}` has type `{kind}`: must be S, R, I or L",
                w[0]
            ));
        }
        // (slot, expected count, numeric)
        let slot = match name.as_str() {
            "type" | "species" | "element" => {
                if c.label.is_some() && name != "type" {
                    None
                } else {
                    Some((&mut c.label, 1, false))
                }
            }
            "pos" => Some((&mut c.pos, 3, true)),
            "radius" | "radii" => Some((&mut c.radius, 1, true)),
            "diameter" => Some((&mut c.diameter, 1, true)),
            "orientation" => Some((&mut c.orientation, 4, true)),
            "aspherical_shape" => Some((&mut c.aspherical_shape, 3, true)),
            "cylinder_length" => Some((&mut c.cylinder_length, 1, true)),
            "superquadric_roundness" | "roundness" => Some((&mut c.roundness, 2, true)),
            _ => None,
        };
        if let Some((slot, want, numeric)) = slot {
            if count != want || (numeric && !matches!(kind, "R" | "I")) {
                return Err(format!(
                    "Properties: column `{}:{kind}:{count}` must be {}:{}:{want}",
                    w[0],
                    w[0],
                    if numeric { "R" } else { "S" }
                ));
            }
            *slot = Some(c.total);
        }
        c.total += count;
    }
    if c.pos.is_none() {
        return Err(format!(
            "Properties={properties} has no `pos:R:3` column (the particle centres)"
        ));
    }
    if c.radius.is_none() && c.diameter.is_none() && c.aspherical_shape.is_none() {
        return Err(format!(
            "Properties={properties} has no `radius:R:1` column (nor `diameter` or \
             `aspherical_shape`): the particle sizes are not in the file"
        ));
    }
    Ok(c)
}

/// The cell of a header's `Lattice`, `Origin` and `pbc` values (`pbc` defaults to T T T).
fn cell_of(pairs: &[(String, Option<String>)]) -> std::result::Result<Cell, String> {
    let get = |key: &str| {
        pairs
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .and_then(|(_, v)| v.as_deref())
    };
    let numbers = |key: &str, v: &str, n: usize| -> std::result::Result<Vec<f64>, String> {
        let m: Vec<f64> = v
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("{key}=\"{v}\" is not {n} numbers"))?;
        if m.len() != n || m.iter().any(|x| !x.is_finite()) {
            return Err(format!("{key}=\"{v}\" is not {n} finite numbers"));
        }
        Ok(m)
    };
    let lat = get("Lattice")
        .ok_or("no Lattice=\"Lx 0 0 0 Ly 0 0 0 Lz\" in the header: the box is not in the file")?;
    let m = numbers("Lattice", lat, 9)?;
    if m.iter().enumerate().any(|(k, v)| k % 4 != 0 && *v != 0.0) {
        return Err(format!(
            "Lattice \"{lat}\" is not an orthorhombic cell Lx 0 0 0 Ly 0 0 0 Lz"
        ));
    }
    if m.iter().step_by(4).any(|l| *l <= 0.0) {
        return Err(format!(
            "Lattice \"{lat}\": the edge lengths Lx, Ly, Lz must be positive"
        ));
    }
    let org = match get("Origin") {
        Some(v) => numbers("Origin", v, 3)?,
        None => vec![0.0; 3],
    };
    let pbc: Vec<bool> = match get("pbc") {
        Some(v) => v
            .split_whitespace()
            .map(|t| match t {
                "T" | "t" | "True" | "true" | "1" => Ok(true),
                "F" | "f" | "False" | "false" | "0" => Ok(false),
                _ => Err(format!("pbc=\"{v}\": each value must be T or F")),
            })
            .collect::<std::result::Result<_, _>>()?,
        None => vec![true; 3],
    };
    if pbc.len() != 3 {
        return Err(format!("pbc has {} values: must be 3", pbc.len()));
    }
    Ok(Cell {
        lengths: [m[0], m[4], m[8]],
        origin: [org[0], org[1], org[2]],
        pbc: [pbc[0], pbc[1], pbc[2]],
    })
}

/// Reads the frame whose count line is line `start` (0-based) of `lines`. The header must
/// hold an orthorhombic `Lattice` with positive edges and a `Properties` value with `pos` and
/// a size (`radius`, `diameter` or `aspherical_shape`), in any column order; `type`,
/// `species` or `element` give the particle's type name, and `orientation` (X, Y, Z, W),
/// `aspherical_shape`, `cylinder_length` and `superquadric_roundness` (or `roundness`) its
/// shape where present (else a sphere of `radius`). Other columns are skipped. Each particle
/// is checked by [`shaped`].
pub fn read_frame_at(lines: &[&str], start: usize, origin: &str) -> Result<Frame> {
    let err = |line: usize, msg: String| file_err(origin, line, msg);
    let n = count_line(lines, start, origin)?;
    let hl = start + 2; // 1-based line of the header
    let header = lines
        .get(start + 1)
        .ok_or_else(|| err(hl, "missing header line".into()))?;
    let pairs = header_pairs(header).map_err(|m| err(hl, m))?;
    let properties = pairs
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case("Properties"))
        .and_then(|(_, v)| v.as_deref())
        .ok_or_else(|| {
            err(
                hl,
                "no Properties= in the header: an extended XYZ with `pos` and `radius` \
                 columns is needed"
                    .into(),
            )
        })?;
    let c = columns_of(properties).map_err(|m| err(hl, m))?;
    let cell = cell_of(&pairs).map_err(|m| err(hl, m))?;
    let mut particles = Vec::with_capacity(n);
    let mut at = Vec::with_capacity(n);
    for k in 0..n {
        let line = hl + 1 + k;
        let text = lines.get(start + 2 + k).ok_or_else(|| {
            err(
                line,
                format!("the file ends after {k} particles; the count line says {n}"),
            )
        })?;
        let t: Vec<&str> = text.split_whitespace().collect();
        if t.len() != c.total {
            return Err(err(
                line,
                format!("{} columns; Properties names {}", t.len(), c.total),
            ));
        }
        let num = |col: usize, name: &str| -> Result<f64> {
            t[col]
                .parse::<f64>()
                .map_err(|_| err(line, format!("`{name}` value `{}` is not a number", t[col])))
        };
        let many = |col: Option<usize>, name: &str, n: usize| -> Result<Option<Vec<f64>>> {
            col.map(|c0| (0..n).map(|j| num(c0 + j, name)).collect())
                .transpose()
        };
        let pos = many(c.pos, "pos", 3)?.unwrap_or_default();
        let radius = match (
            many(c.radius, "radius", 1)?,
            many(c.diameter, "diameter", 1)?,
        ) {
            (Some(r), _) => Some(r[0]),
            (None, Some(d)) => Some(0.5 * d[0]),
            (None, None) => None,
        };
        let columns = ReadColumns {
            label: c.label.map(|j| t[j]),
            position: [pos[0], pos[1], pos[2]],
            radius,
            orientation: many(c.orientation, "orientation", 4)?.map(|q| [q[0], q[1], q[2], q[3]]),
            aspherical_shape: many(c.aspherical_shape, "aspherical_shape", 3)?
                .map(|a| [a[0], a[1], a[2]]),
            cylinder_length: many(c.cylinder_length, "cylinder_length", 1)?.map(|l| l[0]),
            roundness: many(c.roundness, "superquadric_roundness", 2)?.map(|r| [r[0], r[1]]),
        };
        particles.push(shaped(&columns).map_err(|m| err(line, m))?);
        at.push(line);
    }
    Ok(Frame {
        cell,
        particles,
        lines: at,
    })
}

/// The particle columns of one line as read (None: the file has no such column).
#[derive(Debug, Clone, Default)]
pub struct ReadColumns<'a> {
    pub label: Option<&'a str>,
    pub position: [f64; 3],
    pub radius: Option<f64>,
    /// X, Y, Z, W (OVITO's order).
    pub orientation: Option<[f64; 4]>,
    pub aspherical_shape: Option<[f64; 3]>,
    pub cylinder_length: Option<f64>,
    pub roundness: Option<[f64; 2]>,
}

/// The particle shapes OVITO displays (OVITO manual, "Non-spherical particle shapes"), as
/// type names: a type so named is that shape. porelab voxelises the first four.
const VOXELISED_SHAPES: [&str; 4] = ["sphere", "ellipsoid", "spherocylinder", "superquadric"];
const OTHER_SHAPES: [&str; 6] = ["box", "cube", "cylinder", "circle", "square", "mesh"];

/// The particle of one line's columns, or why not (the message names the column, the value
/// and the rule). Every number must be finite; the radius (or half the `diameter`) and the
/// cylinder length positive (length >= 0), the semi-axes positive, the quaternion non-zero
/// (normalised when its norm is not 1 within 1e-9). An `aspherical_shape` of zeros means a
/// sphere of `radius` (OVITO's convention); without `radius` the radius is the largest
/// semi-axis. A type name that names a shape (OVITO's list: sphere, ellipsoid,
/// spherocylinder, superquadric, box, cube, cylinder, circle, square, mesh; any case) must be
/// one porelab voxelises and agree with the columns; a `spherocylinder` without a
/// `cylinder_length` column takes OVITO's `aspherical_shape` (R, R, L): radius R, cylinder
/// length L. Any other type name (a chemical symbol, a LAMMPS type number) is a label: the
/// shape follows from the columns.
pub fn shaped(c: &ReadColumns) -> std::result::Result<XyzParticle, String> {
    let finite = |name: &str, v: &[f64]| -> std::result::Result<(), String> {
        match v.iter().find(|x| !x.is_finite()) {
            Some(x) => Err(format!("`{name}` is {x}: must be finite")),
            None => Ok(()),
        }
    };
    finite("pos", &c.position)?;
    let word = c.label.map(str::to_ascii_lowercase);
    let word = word.as_deref();
    if let Some(w) = word.filter(|w| OTHER_SHAPES.contains(w)) {
        return Err(format!(
            "type `{w}` is a particle shape porelab does not voxelise (it voxelises {})",
            VOXELISED_SHAPES.join(", ")
        ));
    }
    let mut aspherical = c.aspherical_shape;
    if let Some(a) = aspherical {
        finite("aspherical_shape", &a)?;
        if a == [0.0; 3] {
            aspherical = None;
        } else if a.iter().any(|x| *x <= 0.0) {
            return Err(format!(
                "`aspherical_shape` {a:?}: the semi-axes must be positive (or all 0: a sphere)"
            ));
        }
    }
    let mut cylinder_length = c.cylinder_length.unwrap_or(0.0);
    finite("cylinder_length", &[cylinder_length])?;
    if cylinder_length < 0.0 {
        return Err(format!("`cylinder_length` {cylinder_length}: must be >= 0"));
    }
    let mut radius = c.radius;
    if word == Some("spherocylinder") && c.cylinder_length.is_none() {
        // OVITO's Spherocylinder: Aspherical Shape X = radius, Z = cylinder length
        match aspherical {
            Some([r, r2, l]) if r == r2 => {
                radius = Some(r);
                cylinder_length = l;
            }
            _ => {
                return Err("type `spherocylinder` needs a `cylinder_length` column or \
                     `aspherical_shape` R R L (OVITO's radius and cylinder length)"
                    .into())
            }
        }
    }
    let radius = match (radius, aspherical) {
        (Some(r), _) => r,
        (None, Some(a)) => a.iter().cloned().fold(0.0, f64::max),
        (None, None) => {
            return Err("no radius: `aspherical_shape` is 0 0 0 and there is no `radius`".into())
        }
    };
    finite("radius", &[radius])?;
    if radius <= 0.0 {
        return Err(format!("`radius` {radius}: must be positive"));
    }
    let roundness = c.roundness.unwrap_or([1.0, 1.0]);
    finite("superquadric_roundness", &roundness)?;
    if roundness.iter().any(|x| *x <= 0.0) {
        return Err(format!(
            "`superquadric_roundness` {roundness:?}: must be positive"
        ));
    }
    let orientation = match c.orientation {
        None => UnitQuaternion::identity(),
        Some(q) => {
            finite("orientation", &q)?;
            let q = Quaternion::new(q[3], q[0], q[1], q[2]);
            let norm = q.norm();
            if norm == 0.0 {
                return Err("`orientation` is 0 0 0 0: must be a non-zero quaternion".into());
            }
            if (norm - 1.0).abs() <= 1e-9 {
                UnitQuaternion::new_unchecked(q)
            } else {
                UnitQuaternion::new_normalize(q)
            }
        }
    };
    let p = XyzParticle {
        species: c.label.unwrap_or("particle").to_string(),
        position: Vector3::from(c.position),
        orientation,
        aspherical_shape: aspherical.unwrap_or([radius; 3]),
        radius,
        cylinder_length,
        roundness,
    };
    if let Some(w) = word.filter(|w| VOXELISED_SHAPES.contains(w)) {
        let kind = contact_shape(&p)?.name();
        let agrees = match w {
            "sphere" => kind == "sphere",
            "ellipsoid" => matches!(kind, "sphere" | "ellipsoid"),
            "superquadric" => kind != "spherocylinder",
            _ => kind == "spherocylinder",
        };
        if !agrees {
            return Err(format!(
                "type `{}` but the shape columns describe a {kind}",
                c.label.unwrap_or_default()
            ));
        }
    }
    Ok(p)
}

/// The convex shape of a particle's columns, by the rules the voxeliser follows: a positive
/// `cylinder_length` is a spherocylinder (radius, length); a roundness (e, n) other than
/// (1, 1) a superquadric with semi-axes `aspherical_shape` and exponents (2/e, 2/e, 2/n)
/// (e, n in (0, 1]: convex); semi-axes equal to the radius (within 1e-12) a sphere; others
/// an ellipsoid.
pub fn contact_shape(p: &XyzParticle) -> std::result::Result<ContactShape, String> {
    let r = p.radius;
    let a = p.aspherical_shape;
    let shape = if p.cylinder_length > 0.0 {
        ContactShape::Spherocylinder {
            radius: r,
            length: p.cylinder_length,
        }
    } else if p.roundness != [1.0, 1.0] {
        let [e, n] = p.roundness;
        if !(e > 0.0 && e <= 1.0 && n > 0.0 && n <= 1.0) {
            return Err(format!(
                "superquadric_roundness {:?} must lie in (0, 1] (exponents 2/roundness >= 2: \
                 a convex superquadric)",
                p.roundness
            ));
        }
        ContactShape::Superquadric {
            semi_axes: a,
            exponents: [2.0 / e, 2.0 / e, 2.0 / n],
        }
    } else if a.iter().all(|x| (x - r).abs() <= 1e-12 * r) {
        ContactShape::Sphere { radius: r }
    } else {
        ContactShape::Ellipsoid { semi_axes: a }
    };
    shape.validate().map_err(|e| e.to_string())?;
    Ok(shape)
}

/// The radius of the largest sphere about the centre inside the shape: the radius of a
/// sphere or spherocylinder, the smallest semi-axis of an ellipsoid or (convex) superquadric.
pub fn inscribed_radius(s: &ContactShape) -> f64 {
    match *s {
        ContactShape::Sphere { radius } | ContactShape::Spherocylinder { radius, .. } => radius,
        ContactShape::Ellipsoid { semi_axes } | ContactShape::Superquadric { semi_axes, .. } => {
            semi_axes.iter().cloned().fold(f64::INFINITY, f64::min)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<XyzParticle> {
        let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.3);
        vec![
            XyzParticle {
                species: "SC".into(),
                position: Vector3::new(0.1, 1.0 / 3.0, 2.5),
                orientation: q,
                aspherical_shape: [0.5, 0.5, 1.5],
                radius: 0.5,
                cylinder_length: 1.5,
                roundness: [1.0, 1.0],
            },
            XyzParticle {
                species: "S".into(),
                position: Vector3::new(3.0, 0.0, 1e-17),
                orientation: UnitQuaternion::identity(),
                aspherical_shape: [0.5; 3],
                radius: 0.5,
                cylinder_length: 0.0,
                roundness: [0.5, 0.5],
            },
        ]
    }

    #[test]
    fn header_columns_and_exact_round_trip() {
        let p = sample();
        let text = to_string(
            &Cell::cubic(4.25),
            &p,
            &[("phi", "0.6".into()), ("title", "two rods".into())],
        )
        .unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "2");
        assert!(lines[1].starts_with("Lattice=\"4.25 0 0 0 4.25 0 0 0 4.25\""));
        assert!(lines[1].contains("pbc=\"T T T\""));
        assert!(lines[1].contains(" phi=0.6") && lines[1].contains(" title=\"two rods\""));
        // Quaternion (x, y, z, w) = (sin 0.15, 0, 0, cos 0.15): OVITO order.
        let cols: Vec<f64> = lines[2]
            .split_whitespace()
            .skip(4)
            .take(4)
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(cols, vec![0.15f64.sin(), 0.0, 0.0, 0.15f64.cos()]);
        let (c, back) = parse(&text, "test").unwrap();
        assert_eq!(c, Cell::cubic(4.25));
        assert_eq!(back, p);
        // A cylinder's bounding cell, periodic along z only.
        let cyl = Cell {
            lengths: [6.0, 6.0, 11.5],
            origin: [-3.0, -3.0, 0.0],
            pbc: [false, false, true],
        };
        let text = to_string(&cyl, &p, &[]).unwrap();
        assert!(text.contains("Origin=\"-3 -3 0\" pbc=\"F F T\""));
        assert_eq!(parse(&text, "test").unwrap().0, cyl);
    }

    /// A file of the first layout (columns `species`, `roundness`) reads to the same
    /// particles; a header with other columns is refused by name.
    #[test]
    fn legacy_column_names_are_read() {
        let p = sample();
        let text = to_string(&Cell::cubic(4.25), &p, &[]).unwrap();
        assert!(text.contains(&format!(" Properties={PROPERTIES}")));
        let legacy = text.replacen(PROPERTIES, LEGACY_PROPERTIES, 1);
        assert_ne!(legacy, text);
        assert_eq!(parse(&legacy, "old").unwrap().1, p);
        // a column of another name is skipped (the roundness then defaults to 1 1); a header
        // without centres is refused by name
        let other = text.replacen("superquadric_roundness:R:2", "charge:R:2", 1);
        let mut round = p.clone();
        round[1].roundness = [1.0, 1.0];
        assert_eq!(parse(&other, "t").unwrap().1, round);
        let e = parse(&text.replacen(":pos:R:3", ":centre:R:3", 1), "t")
            .unwrap_err()
            .to_string();
        assert!(e.contains("t: line 2") && e.contains("no `pos:R:3`"), "{e}");
        let sphere = XyzParticle::sphere(Vector3::new(1.0, 2.0, 3.0), 0.25);
        assert_eq!(
            (
                sphere.species.as_str(),
                sphere.aspherical_shape,
                sphere.roundness
            ),
            ("sphere", [0.25; 3], [1.0, 1.0])
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut p = sample();
        assert!(to_string(&Cell::cubic(-1.0), &p, &[])
            .unwrap_err()
            .to_string()
            .contains("cell length -1"));
        assert!(to_string(&Cell::cubic(1.0), &p, &[("a b", "1".into())]).is_err());
        p[0].species = "two words".into();
        assert!(to_string(&Cell::cubic(1.0), &p, &[])
            .unwrap_err()
            .to_string()
            .contains("species"));
        let text = to_string(&Cell::cubic(2.0), &sample(), &[]).unwrap();
        let truncated: String = text.lines().take(3).collect::<Vec<_>>().join("\n");
        assert!(parse(&truncated, "t")
            .unwrap_err()
            .to_string()
            .contains("the count line says 2"));
        let skew = text.replacen("Lattice=\"2 0 0", "Lattice=\"2 1 0", 1);
        assert!(parse(&skew, "t")
            .unwrap_err()
            .to_string()
            .contains("orthorhombic"));
    }

    fn one(header: &str, line: &str) -> std::result::Result<XyzParticle, String> {
        parse(&format!("1\n{header}\n{line}\n"), "f")
            .map(|(_, p)| p[0].clone())
            .map_err(|e| e.to_string())
    }

    /// Headers and columns as other tools write them: quoted, braced and bare values, keys
    /// in another case, columns in another order with integer and logical columns between,
    /// sizes as diameters, OVITO's spherocylinder convention, quaternions not of unit norm.
    #[test]
    fn foreign_headers_and_columns() {
        let pairs = header_pairs(r#"a="x \"y\" z" b={1 2} c=3 flag Lattice="1 0 0""#).unwrap();
        let want = |k: &str, v: Option<&str>| (k.to_string(), v.map(str::to_string));
        assert_eq!(
            pairs,
            vec![
                want("a", Some(r#"x "y" z"#)),
                want("b", Some("1 2")),
                want("c", Some("3")),
                want("flag", None),
                want("Lattice", Some("1 0 0")),
            ]
        );
        assert!(header_pairs("a=\"open")
            .unwrap_err()
            .contains("closing quote"));
        let h = r#"lattice="5 0 0 0 6 0 0 0 7" PBC="T T F" properties=id:I:1:fixed:L:1:diameter:R:1:Pos:R:3"#;
        let p = one(h, "7 T 0.8 1 2 3").unwrap();
        assert_eq!((p.radius, p.position), (0.4, Vector3::new(1.0, 2.0, 3.0)));
        assert_eq!(p.species, "particle");
        let (c, _) = parse(&format!("1\n{h}\n7 T 0.8 1 2 3\n"), "f").unwrap();
        assert_eq!((c.lengths, c.pbc), ([5.0, 6.0, 7.0], [true, true, false]));
        // OVITO's spherocylinder: aspherical_shape R R L without a cylinder_length column
        let h = r#"Lattice="5 0 0 0 5 0 0 0 5" Properties=species:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3"#;
        let rod = one(h, "Spherocylinder 1 1 1 0 0 0 2 0.3 0.3 1.5").unwrap();
        assert_eq!((rod.radius, rod.cylinder_length), (0.3, 1.5));
        assert_eq!(rod.orientation, UnitQuaternion::identity());
        assert_eq!(contact_shape(&rod).unwrap().name(), "spherocylinder");
        let e = one(h, "sphere 1 1 1 0 0 0 1 0.3 0.2 0.2").unwrap_err();
        assert!(
            e.contains("line 3: type `sphere`") && e.contains("ellipsoid"),
            "{e}"
        );
        let e = one(h, "spherocylinder 1 1 1 0 0 0 1 0.3 0.2 1.0").unwrap_err();
        assert!(e.contains("R R L"), "{e}");
        let e = one(h, "Box 1 1 1 0 0 0 1 0.3 0.2 1.0").unwrap_err();
        assert!(
            e.contains("type `box`") && e.contains("does not voxelise"),
            "{e}"
        );
        let e = one(h, "A 1 1 1 0 0 0 0 0.3 0.2 1.0").unwrap_err();
        assert!(e.contains("non-zero quaternion"), "{e}");
        let e = one(h, "A 1 1 inf 0 0 0 1 0.3 0.2 1.0").unwrap_err();
        assert!(e.contains("`pos` is inf"), "{e}");
        let e = one(h, "A 1 1 1 0 0 0 1 0.3 0 1.0").unwrap_err();
        assert!(e.contains("semi-axes must be positive"), "{e}");
        // no radius column: the radius is the largest semi-axis
        let a = one(h, "A 1 1 1 0 0 0 1 0.3 0.2 1.0").unwrap();
        assert_eq!(
            (a.radius, contact_shape(&a).unwrap().name()),
            (1.0, "ellipsoid")
        );
        let tilted = one(h, "A 1 1 1 0 0 3 4 0.3 0.2 1.0").unwrap();
        assert!((tilted.orientation.coords - Vector3::new(0.0, 0.0, 0.6).push(0.8)).norm() < 1e-15);
        // sizes and centres must be there, in the right shape
        let bad = |props: &str| {
            one(
                &format!("Lattice=\"5 0 0 0 5 0 0 0 5\" Properties={props}"),
                "1 1 1 1",
            )
            .unwrap_err()
        };
        assert!(bad("pos:R:3:charge:R:1").contains("no `radius:R:1`"));
        assert!(bad("pos:R:2:radius:R:2").contains("must be pos:R:3"));
        assert!(bad("pos:R:3:radius:X:1").contains("must be S, R, I or L"));
        let e = one("Properties=pos:R:3:radius:R:1", "1 1 1 1").unwrap_err();
        assert!(e.contains("no Lattice"), "{e}");
        let e = one("Lattice=\"1 0 0 0 1 0 0 0 1\"", "1 1 1 1").unwrap_err();
        assert!(e.contains("no Properties="), "{e}");
    }
}
