//! Key names shared by every engine's schema: one spelling per quantity (`density_kg_m3`,
//! `viscosity_pa_s`), with the spellings earlier scene files used still read, and named on
//! stderr so that a user can update the file.

use std::sync::Mutex;

/// Old spellings of keys, and the name each now has. Every engine's schema reads the new name;
/// [`rename_old_keys`] maps an old one to it before parsing.
pub const RENAMED: &[(&str, &str)] = &[
    ("viscosity_Pa_s", "viscosity_pa_s"),
    ("rho_kg_m3", "density_kg_m3"),
];

/// Renames, in every table of `table` (recursively), each key of [`RENAMED`]'s old spellings to
/// its new name, printing one note per renamed key on stderr naming `origin` and the key. A
/// table that holds both spellings is left alone, so the schema refuses the old one by name.
pub fn rename_old_keys(table: &mut toml::Table, origin: &str) {
    rename_in(table, origin, "");
}

fn rename_in(table: &mut toml::Table, origin: &str, path: &str) {
    for (old, new) in RENAMED {
        if table.contains_key(*old) && !table.contains_key(*new) {
            if let Some(v) = table.remove(*old) {
                table.insert((*new).to_string(), v);
                note(format!(
                    "{origin}: key `{path}{old}` is now spelt `{path}{new}` (read as such; \
                     please rename it)"
                ));
            }
        }
    }
    for (k, v) in table.iter_mut() {
        match v {
            toml::Value::Table(t) => rename_in(t, origin, &format!("{path}{k}.")),
            toml::Value::Array(a) => {
                for (i, item) in a.iter_mut().enumerate() {
                    if let toml::Value::Table(t) = item {
                        rename_in(t, origin, &format!("{path}{k}.{i}."));
                    }
                }
            }
            _ => {}
        }
    }
}

/// `text` (a scene file read from `origin`) deserialised as `T` after [`rename_old_keys`]:
/// from the text itself when no key was renamed, so that errors show the line.
pub fn parse_renamed<T: serde::de::DeserializeOwned>(
    text: &str,
    origin: &str,
) -> Result<T, toml::de::Error> {
    let table: toml::Table = toml::from_str(text)?;
    let mut renamed = table.clone();
    rename_old_keys(&mut renamed, origin);
    if renamed == table {
        toml::from_str(text).map_err(|e| name_the_key(text, e))
    } else {
        toml::Value::Table(renamed).try_into()
    }
}

/// A value of the wrong type inside a table that is read as a whole (flattened or tagged
/// tables) is reported by the TOML reader at the table's header, without the key: this finds
/// the key in that table whose value is the one the error quotes, and names it with its line.
/// Any other error is returned as it was.
pub(crate) fn name_the_key(text: &str, e: toml::de::Error) -> toml::de::Error {
    let found = (|| {
        let span = e.span()?;
        let rest = e.message().strip_prefix("invalid type: ")?;
        let (what, expected) = rest.split_once(", expected ")?;
        // as written in the file: "text" for a string, 5 for an integer `5`
        let literal = match what.strip_prefix("string ") {
            Some(quoted) => quoted.to_string(),
            None => what.split('`').nth(1)?.to_string(),
        };
        let header = text.get(span.clone())?.trim();
        let table = header.trim_start_matches('[').trim_end_matches(']');
        if !header.starts_with('[') {
            return None;
        }
        let first_line = text[..span.start].lines().count();
        let lines = text.lines().enumerate().skip(first_line + 1);
        for (k, line) in lines {
            let code = line.split('#').next().unwrap_or("").trim();
            if code.starts_with('[') {
                break;
            }
            if let Some((key, value)) = code.split_once('=') {
                if value.trim() == literal {
                    return Some(format!(
                        "line {}: key `{table}.{}` = {literal}: must be {expected}",
                        k + 1,
                        key.trim()
                    ));
                }
            }
        }
        None
    })();
    match found {
        Some(msg) => <toml::de::Error as serde::de::Error>::custom(msg),
        None => e,
    }
}

/// Notes already printed in this process: a sweep that checks a thousand jobs of one scene
/// prints each note once.
/// A lattice named in a scene ("D3Q15", "D3Q19"), for `deserialize_with`.
pub fn lattice_kind<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<crate::lbm::LatticeKind, D::Error> {
    use serde::de::{Deserialize, Error};
    crate::lbm::LatticeKind::parse(&String::deserialize(d)?, "lattice").map_err(D::Error::custom)
}

/// A collision named in a scene ("bgk", "trt", ...), for `deserialize_with`.
pub fn collision_kind<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<crate::lbm::CollisionKind, D::Error> {
    use serde::de::{Deserialize, Error};
    crate::lbm::CollisionKind::parse(&String::deserialize(d)?, "collision")
        .map_err(D::Error::custom)
}

static PRINTED: Mutex<Vec<String>> = Mutex::new(Vec::new());

fn note(msg: String) {
    if let Ok(mut seen) = PRINTED.lock() {
        if seen.contains(&msg) {
            return;
        }
        seen.push(msg.clone());
    }
    eprintln!("note: {msg}");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn old_spellings_are_read_under_their_new_names() {
        let mut t: toml::Table = toml::from_str(
            "rho_kg_m3 = 1000.0\n[fluid]\nviscosity_Pa_s = 1e-3\n[[species]]\nrho_kg_m3 = 2.0\n",
        )
        .unwrap();
        rename_old_keys(&mut t, "s.toml");
        assert_eq!(t["density_kg_m3"].as_float(), Some(1000.0));
        assert_eq!(t["fluid"]["viscosity_pa_s"].as_float(), Some(1e-3));
        assert_eq!(t["species"][0]["density_kg_m3"].as_float(), Some(2.0));
        assert!(!t.contains_key("rho_kg_m3"));
        // both spellings: left for the schema to refuse by name
        let mut t: toml::Table = toml::from_str("rho_kg_m3 = 1.0\ndensity_kg_m3 = 2.0\n").unwrap();
        rename_old_keys(&mut t, "s.toml");
        assert!(t.contains_key("rho_kg_m3"));
    }

    /// Without an old spelling the text itself is read (errors show the line); with one, the
    /// renamed table.
    #[test]
    fn parse_renamed_reads_old_spellings_and_keeps_lines_in_errors() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        struct F {
            viscosity_pa_s: f64,
        }
        let f: F = parse_renamed("viscosity_Pa_s = 2.0\n", "s.toml").unwrap();
        assert_eq!(f.viscosity_pa_s, 2.0);
        let e = parse_renamed::<F>("\nviscosity = 2.0\n", "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("viscosity"), "{e}");
    }
}
