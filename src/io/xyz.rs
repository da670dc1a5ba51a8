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
//! [`parse`] also reads the first layout, whose columns were the same but named
//! `species` and `roundness` ([`LEGACY_PROPERTIES`]).

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

/// Reads a frame written by [`to_string`]: (cell, particles). Checks that the header's
/// `Lattice` is orthorhombic and that `Properties` is exactly [`PROPERTIES`] or
/// [`LEGACY_PROPERTIES`]; `origin` names the source in errors.
pub fn parse(text: &str, origin: &str) -> Result<(Cell, Vec<XyzParticle>)> {
    let err = |line: usize, msg: String| Error::File {
        path: origin.to_string(),
        msg: format!("line {line}: {msg}"),
    };
    let mut lines = text.lines();
    let n: usize = lines
        .next()
        .and_then(|l| l.trim().parse().ok())
        .ok_or_else(|| err(1, "first line must be the particle count".into()))?;
    let header = lines
        .next()
        .ok_or_else(|| err(2, "missing header line".into()))?;
    let properties = header
        .split_whitespace()
        .find_map(|t| t.strip_prefix("Properties="));
    if !matches!(properties, Some(p) if p == PROPERTIES || p == LEGACY_PROPERTIES) {
        return Err(err(
            2,
            format!(
                "Properties is {}: must be {PROPERTIES} (or the older {LEGACY_PROPERTIES})",
                properties.unwrap_or("missing")
            ),
        ));
    }
    let lat = header
        .split("Lattice=\"")
        .nth(1)
        .and_then(|r| r.split('"').next())
        .ok_or_else(|| err(2, "missing Lattice=\"...\"".into()))?;
    let m: Vec<f64> = lat
        .split_whitespace()
        .map(|t| t.parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| err(2, format!("Lattice \"{lat}\" is not 9 numbers")))?;
    if m.len() != 9 || m.iter().enumerate().any(|(k, v)| k % 4 != 0 && *v != 0.0) {
        return Err(err(
            2,
            format!("Lattice \"{lat}\" is not an orthorhombic cell Lx 0 0 0 Ly 0 0 0 Lz"),
        ));
    }
    let quoted = |key: &str| -> Option<Vec<&str>> {
        header
            .split(&format!("{key}=\""))
            .nth(1)
            .and_then(|r| r.split('"').next())
            .map(|v| v.split_whitespace().collect())
    };
    let org: Vec<f64> = quoted("Origin")
        .unwrap_or_else(|| vec!["0", "0", "0"])
        .iter()
        .map(|t| t.parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| err(2, "Origin is not 3 numbers".into()))?;
    let pbc: Vec<bool> = quoted("pbc")
        .unwrap_or_else(|| vec!["T", "T", "T"])
        .iter()
        .map(|t| *t == "T")
        .collect();
    if org.len() != 3 || pbc.len() != 3 {
        return Err(err(2, "Origin and pbc need 3 values each".into()));
    }
    let cell = Cell {
        lengths: [m[0], m[4], m[8]],
        origin: [org[0], org[1], org[2]],
        pbc: [pbc[0], pbc[1], pbc[2]],
    };
    let mut out = Vec::with_capacity(n);
    for (k, line) in lines.enumerate().take(n) {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.len() != 15 {
            return Err(err(k + 3, format!("{} columns, expected 15", t.len())));
        }
        let v: Vec<f64> = t[1..]
            .iter()
            .map(|x| x.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| err(k + 3, "a column is not a number".into()))?;
        out.push(XyzParticle {
            species: t[0].to_string(),
            position: Vector3::new(v[0], v[1], v[2]),
            orientation: UnitQuaternion::new_unchecked(Quaternion::new(v[6], v[3], v[4], v[5])),
            aspherical_shape: [v[7], v[8], v[9]],
            radius: v[10],
            cylinder_length: v[11],
            roundness: [v[12], v[13]],
        });
    }
    if out.len() != n {
        return Err(err(
            2 + out.len(),
            format!("{} particles, header says {n}", out.len()),
        ));
    }
    Ok((cell, out))
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
        let other = text.replacen("superquadric_roundness:R:2", "charge:R:2", 1);
        let e = parse(&other, "t").unwrap_err().to_string();
        assert!(e.contains("charge:R:2") && e.contains("must be"), "{e}");
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
            .contains("header says 2"));
        let skew = text.replacen("Lattice=\"2 0 0", "Lattice=\"2 1 0", 1);
        assert!(parse(&skew, "t")
            .unwrap_err()
            .to_string()
            .contains("orthorhombic"));
    }
}
