//! `porelab shape ...`: volume, principal moments of inertia (unit density, about the centre,
//! body frame) and bounding radius of one particle, printed as one JSON object
//! `{"volume": v, "principal_inertia": [Ixx, Iyy, Izz], "bounding_radius": r}`.
//! Bad arguments: one line naming the problem, exit status 2 (see `main.rs`).

use crate::error::{invalid, Result};
use crate::shape::{ConvexShape, Ellipsoid, Sphere, Spherocylinder, Superquadric};
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct ShapeArgs {
    #[command(subcommand)]
    pub kind: ShapeKind,
}

#[derive(Debug, clap::Subcommand)]
pub enum ShapeKind {
    /// Sphere of radius R.
    Sphere {
        /// Radius R.
        #[arg(long, allow_hyphen_values = true)]
        radius: f64,
    },
    /// Spherocylinder: cylinder of length L (between the hemisphere centres) capped by two
    /// hemispheres of radius R, axis z.
    Spherocylinder {
        /// Radius R.
        #[arg(long, allow_hyphen_values = true)]
        radius: f64,
        /// Cylinder length L (>= 0).
        #[arg(long, allow_hyphen_values = true)]
        length: f64,
    },
    /// Triaxial ellipsoid with semi-axes A,B,C along x, y, z.
    Ellipsoid {
        /// Semi-axes A,B,C.
        #[arg(long = "semi-axes", allow_hyphen_values = true)]
        semi_axes: String,
    },
    /// Superquadric |x/a1|^g1 + |y/a2|^g2 + |z/a3|^g3 <= 1 (thesis eq. 4.3), g_i >= 2.
    Superquadric {
        /// Semi-axes A1,A2,A3.
        #[arg(long = "semi-axes", allow_hyphen_values = true)]
        semi_axes: String,
        /// Exponents G1,G2,G3 (each >= 2).
        #[arg(long, allow_hyphen_values = true)]
        exponents: String,
    },
}

pub use crate::io::parse_three;

/// A finite f64 as a JSON number (shortest representation that round-trips).
pub fn json_number(x: f64) -> String {
    serde_json::Value::from(x).to_string()
}

/// The JSON summary of one shape, keys in the documented order (an error if a value
/// overflows f64).
pub fn shape_json(shape: &dyn ConvexShape) -> Result<String> {
    let v = shape.volume();
    let i = shape.principal_inertia_unit_density();
    let r = shape.bounding_radius();
    if !(v.is_finite() && i.iter().all(|x| x.is_finite()) && r.is_finite()) {
        return invalid(format!(
            "the volume ({v:e}), inertia ({:e}, {:e}, {:e}) or bounding radius ({r:e}) is not finite in f64: choose other length units",
            i.x, i.y, i.z
        ));
    }
    Ok(format!(
        "{{\"volume\": {}, \"principal_inertia\": [{}, {}, {}], \"bounding_radius\": {}}}",
        json_number(v),
        json_number(i.x),
        json_number(i.y),
        json_number(i.z),
        json_number(r)
    ))
}

/// Builds the shape named on the command line.
pub fn build(kind: &ShapeKind) -> Result<Box<dyn ConvexShape>> {
    Ok(match kind {
        ShapeKind::Sphere { radius } => Box::new(Sphere::new(*radius)?),
        ShapeKind::Spherocylinder { radius, length } => {
            Box::new(Spherocylinder::new(*radius, *length)?)
        }
        ShapeKind::Ellipsoid { semi_axes } => {
            Box::new(Ellipsoid::new(parse_three(semi_axes, "semi-axes")?)?)
        }
        ShapeKind::Superquadric {
            semi_axes,
            exponents,
        } => Box::new(Superquadric::new(
            parse_three(semi_axes, "semi-axes")?,
            parse_three(exponents, "exponents")?,
        )?),
    })
}

/// `porelab shape ...`.
pub fn run_shape(args: &ShapeArgs) -> Result<ExitCode> {
    let shape = build(&args.kind)?;
    println!("{}", shape_json(shape.as_ref())?);
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_json() {
        assert_eq!(parse_three("1, 2,3e-1", "x").unwrap(), [1.0, 2.0, 0.3]);
        let e = parse_three("1,2", "semi-axes").unwrap_err().to_string();
        assert!(e.contains("--semi-axes '1,2'"), "{e}");
        let e = parse_three("1,b,2", "exponents").unwrap_err().to_string();
        assert!(e.contains("'b' is not a number"), "{e}");
        let s = build(&ShapeKind::Sphere { radius: 1.0 }).unwrap();
        let j: serde_json::Value = serde_json::from_str(&shape_json(s.as_ref()).unwrap()).unwrap();
        assert_eq!(j["bounding_radius"], 1.0);
        assert_eq!(j["principal_inertia"].as_array().unwrap().len(), 3);
        let e = build(&ShapeKind::Superquadric {
            semi_axes: "1,1,1".into(),
            exponents: "2,1,2".into(),
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("g2 = 1"), "{e}");
    }
}
