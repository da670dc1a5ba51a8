//! `porelab contact PAIRS.jsonl`: one pair per input line, one JSON result per output line.
//!
//! Input line: `{"a": SHAPE, "b": SHAPE}` with SHAPE =
//! `{"shape": "sphere"|"spherocylinder"|"ellipsoid"|"superquadric", "radius": r, "length": l,
//! "semi_axes": [..], "exponents": [..], "position": [x, y, z], "orientation": [qx, qy, qz, qw]}`
//! carrying only the keys its shape needs (`position` required, `orientation` optional,
//! default identity; the quaternion must have unit norm to 1e-6 and is then normalised).
//! Output line: `{"overlap": bool, "gap": g, "normal": [..], "point_a": [..], "point_b": [..],
//! "method": "..."}` (+ `"pw_scale"` for ellipsoid pairs). Blank lines are skipped.
//! A bad line, or a pair the solver cannot certify, stops the run with one line on stderr
//! naming the problem and the line number (exit status 2, see `main.rs`).

use crate::contact::{contact, ContactShape, Pose};
use crate::error::{Error, Result};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde_json::{Map, Value};
use std::io::Write;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct ContactArgs {
    /// JSON-lines file, one pair {"a": SHAPE, "b": SHAPE} per line.
    pub pairs: std::path::PathBuf,
}

fn num(v: &Value, what: &str) -> std::result::Result<f64, String> {
    match v.as_f64() {
        Some(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{what} = {v}: must be a finite number")),
    }
}

fn arr<const N: usize>(v: &Value, what: &str) -> std::result::Result<[f64; N], String> {
    let a = v
        .as_array()
        .ok_or_else(|| format!("{what} = {v}: must be an array of {N} numbers"))?;
    if a.len() != N {
        return Err(format!("{what} = {v}: must be an array of {N} numbers"));
    }
    let mut out = [0.0; N];
    for (k, x) in a.iter().enumerate() {
        out[k] = num(x, &format!("{what}[{k}]"))?;
    }
    Ok(out)
}

/// Parses one SHAPE object (`side` is "a" or "b", for messages).
pub fn parse_shape(v: &Value, side: &str) -> std::result::Result<(ContactShape, Pose), String> {
    let obj: &Map<String, Value> = v
        .as_object()
        .ok_or_else(|| format!("\"{side}\" must be an object"))?;
    let kind = obj
        .get("shape")
        .and_then(Value::as_str)
        .ok_or_else(|| format!("{side}.shape missing or not a string"))?;
    let needs: &[&str] = match kind {
        "sphere" => &["radius"],
        "spherocylinder" => &["radius", "length"],
        "ellipsoid" => &["semi_axes"],
        "superquadric" => &["semi_axes", "exponents"],
        other => {
            return Err(format!(
            "{side}.shape = \"{other}\": must be sphere, spherocylinder, ellipsoid or superquadric"
        ))
        }
    };
    for key in obj.keys() {
        if !(key == "shape"
            || key == "position"
            || key == "orientation"
            || needs.contains(&key.as_str()))
        {
            return Err(format!("{side}: unknown key \"{key}\" for a {kind} (keys: shape, position, orientation, {})", needs.join(", ")));
        }
    }
    let get = |k: &str| {
        obj.get(k)
            .ok_or_else(|| format!("{side}.{k} missing (a {kind} needs it)"))
    };
    let shape = match kind {
        "sphere" => ContactShape::Sphere {
            radius: num(get("radius")?, &format!("{side}.radius"))?,
        },
        "spherocylinder" => ContactShape::Spherocylinder {
            radius: num(get("radius")?, &format!("{side}.radius"))?,
            length: num(get("length")?, &format!("{side}.length"))?,
        },
        "ellipsoid" => ContactShape::Ellipsoid {
            semi_axes: arr::<3>(get("semi_axes")?, &format!("{side}.semi_axes"))?,
        },
        _ => ContactShape::Superquadric {
            semi_axes: arr::<3>(get("semi_axes")?, &format!("{side}.semi_axes"))?,
            exponents: arr::<3>(get("exponents")?, &format!("{side}.exponents"))?,
        },
    };
    shape.validate().map_err(|e| format!("{side}.{e}"))?;
    let p = arr::<3>(get("position")?, &format!("{side}.position"))?;
    let q = match obj.get("orientation") {
        None => UnitQuaternion::identity(),
        Some(v) => {
            let q = arr::<4>(v, &format!("{side}.orientation"))?;
            let quat = Quaternion::new(q[3], q[0], q[1], q[2]);
            let n = quat.norm();
            if (n - 1.0).abs() > 1e-6 {
                return Err(format!("{side}.orientation = {v}: quaternion [qx,qy,qz,qw] must have unit norm (norm {n})"));
            }
            UnitQuaternion::from_quaternion(quat)
        }
    };
    Ok((shape, Pose::new(Vector3::from(p), q)))
}

/// Computes the result line of one input line (None for a blank line).
pub fn process_line(line: &str) -> std::result::Result<Option<String>, String> {
    if line.trim().is_empty() {
        return Ok(None);
    }
    let v: Value = serde_json::from_str(line).map_err(|e| format!("not valid JSON: {e}"))?;
    let obj = v
        .as_object()
        .ok_or("a line must be an object {\"a\": SHAPE, \"b\": SHAPE}")?;
    for key in obj.keys() {
        if key != "a" && key != "b" {
            return Err(format!("unknown key \"{key}\" (a line has keys a and b)"));
        }
    }
    let (sa, pa) = parse_shape(obj.get("a").ok_or("key \"a\" missing")?, "a")?;
    let (sb, pb) = parse_shape(obj.get("b").ok_or("key \"b\" missing")?, "b")?;
    let c = contact(&sa, &pa, &sb, &pb).map_err(|e| e.to_string())?;
    let v3 = |x: &Vector3<f64>| Value::from(vec![x.x, x.y, x.z]);
    let mut out = Map::new();
    out.insert("overlap".into(), Value::from(c.overlap()));
    out.insert("gap".into(), Value::from(c.gap));
    out.insert("normal".into(), v3(&c.normal));
    out.insert("point_a".into(), v3(&c.point_a));
    out.insert("point_b".into(), v3(&c.point_b));
    out.insert("method".into(), Value::from(c.method));
    if let Some(s) = c.pw_scale {
        out.insert("pw_scale".into(), Value::from(s));
    }
    Ok(Some(Value::Object(out).to_string()))
}

/// Runs `porelab contact`.
pub fn run_contact(args: &ContactArgs) -> Result<ExitCode> {
    let path = args.pairs.display().to_string();
    let text = std::fs::read_to_string(&args.pairs).map_err(|e| Error::File {
        path: path.clone(),
        msg: e.to_string(),
    })?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    for (i, line) in text.lines().enumerate() {
        match process_line(line) {
            Ok(Some(s)) => writeln!(out, "{s}")?,
            Ok(None) => {}
            Err(msg) => {
                out.flush()?;
                return Err(Error::File {
                    path,
                    msg: format!("line {}: {msg}", i + 1),
                });
            }
        }
    }
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spheres_and_errors() {
        let l = r#"{"a": {"shape": "sphere", "radius": 1, "position": [0,0,0]}, "b": {"shape": "sphere", "radius": 1, "position": [3,0,0]}}"#;
        let s = process_line(l).unwrap().unwrap();
        let v: Value = serde_json::from_str(&s).unwrap();
        assert_eq!(v["gap"].as_f64().unwrap(), 1.0);
        assert_eq!(v["overlap"], Value::from(false));
        let bad = r#"{"a": {"shape": "sphere", "radius": 1, "length": 2, "position": [0,0,0]}, "b": {"shape": "sphere", "radius": 1, "position": [3,0,0]}}"#;
        let e = process_line(bad).unwrap_err();
        assert!(e.contains("\"length\""), "{e}");
        let bad = r#"{"a": {"shape": "sphere", "radius": -1, "position": [0,0,0]}, "b": {"shape": "sphere", "radius": 1, "position": [3,0,0]}}"#;
        assert!(process_line(bad).unwrap_err().contains("radius = -1"));
    }
}
