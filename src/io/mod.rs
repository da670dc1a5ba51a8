//! Readers and writers: CSV tables with units in the headers; atomic file writes; extended
//! XYZ particle configurations ([`xyz`]).

pub mod vtk;
pub mod xyz;

use crate::error::{invalid, Error};
use crate::Result;
use std::path::Path;

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
/// reader never sees a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)?;
    Ok(())
}

/// Parses "x,y,z" into three finite numbers; `option` names the option in the error.
pub fn parse_three(text: &str, option: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return invalid(format!(
            "--{option} '{text}': expected three comma-separated numbers"
        ));
    }
    let mut v = [0.0; 3];
    for (k, p) in parts.iter().enumerate() {
        v[k] = p.parse::<f64>().map_err(|_| {
            Error::InvalidInput(format!("--{option} '{text}': '{p}' is not a number"))
        })?;
        if !v[k].is_finite() {
            return invalid(format!("--{option} '{text}': '{p}' is not finite"));
        }
    }
    Ok(v)
}
