//! Generators of the independent reference tables in `reference/`. Nothing here calls the
//! code under test (`magnetics`, ...): each oracle is written from a different formulation.
//!
//! Adding a generator is two lines: a `pub mod NAME;` below and one [`Generator`] entry in
//! [`GENERATORS`]. A generator is a `fn(&Path) -> Result<()>` that writes its file(s) into the
//! given `reference/` folder, atomically, e.g. with [`write_file`]. Literature tables are
//! checked in by hand and have no generator (they are read-only).

// Generator modules (one `pub mod` line each), e.g. `pub mod cylinder_field;`.
pub mod cylinder_field;
pub mod porous_couette;
pub mod shape_quadrature;

use crate::{Error, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// One generated reference table (or group of tables).
#[derive(Debug, Clone, Copy)]
pub struct Generator {
    /// Name used on the command line (`porelab reference regen NAME`).
    pub name: &'static str,
    /// One line: what the oracle is and how it is computed.
    pub description: &'static str,
    /// Writes the table(s) into the given `reference/` folder.
    pub generate: fn(&Path) -> Result<()>,
}

/// The registry of generators, in the order `regen` runs them.
pub static GENERATORS: &[Generator] = &[
    // Generator { name: "cylinder_field", description: "...", generate: cylinder_field::generate },
    Generator {
        name: "cylinder-field",
        description: "H and grad H of a uniformly magnetized cylinder (adaptive Gauss-Kronrod of elementary kernels + multipole far field); also three_cylinders.csv",
        generate: cylinder_field::regen_cylinder_field,
    },
    Generator {
        name: "shape-quadrature",
        description: "volume and inertia of superquadrics and spherocylinders by nested adaptive Gauss-Kronrod over z-slices (no Gamma functions)",
        generate: shape_quadrature::regen_shape_quadrature,
    },
    Generator {
        name: "porous-couette",
        description: "porous plane Couette flow (Brinkman-Forchheimer, seed 002 Fig. 6a) by second-order finite differences, Newton, Richardson over three grids",
        generate: porous_couette::regen_porous_couette,
    },
];

/// The generator called `name`, or an error listing the known names.
pub fn find(name: &str) -> Result<&'static Generator> {
    GENERATORS.iter().find(|g| g.name == name).ok_or_else(|| {
        let known: Vec<&str> = GENERATORS.iter().map(|g| g.name).collect();
        Error::InvalidInput(format!(
            "unknown reference table '{name}' (known: {})",
            if known.is_empty() {
                "none".to_string()
            } else {
                known.join(", ")
            }
        ))
    })
}

/// `<root>/reference`, with the root from `$PORELAB_ROOT` or the crate folder.
pub fn reference_dir() -> PathBuf {
    crate::io::repo_root().join("reference")
}

/// Writes `reference/<file_name>` atomically (temp file + rename); returns its path.
pub fn write_file(dir: &Path, file_name: &str, contents: impl AsRef<[u8]>) -> Result<PathBuf> {
    let path = dir.join(file_name);
    crate::io::write_atomic(&path, contents.as_ref())?;
    Ok(path)
}

type Listing = BTreeMap<PathBuf, (SystemTime, u64)>;

fn hash_bytes(b: &[u8]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    b.hash(&mut h);
    h.finish()
}

/// Modification time and content hash of every file under `dir`.
fn listing(dir: &Path) -> Listing {
    let mut out = Listing::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if let (Ok(meta), Ok(bytes)) = (e.metadata(), std::fs::read(&p)) {
                let t = meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
                out.insert(p, (t, hash_bytes(&bytes)));
            }
        }
    }
    out
}

/// Runs `generators` into `dir` and returns, for each file written, its path and whether its
/// contents changed ("new", "changed", "unchanged").
pub fn regen_into(dir: &Path, generators: &[&Generator]) -> Result<Vec<(PathBuf, &'static str)>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::File {
        path: dir.display().to_string(),
        msg: e.to_string(),
    })?;
    let mut written = Vec::new();
    for g in generators {
        let before = listing(dir);
        let start = SystemTime::now();
        eprintln!("regenerating {} ...", g.name);
        (g.generate)(dir).map_err(|e| Error::Validation(format!("reference {}: {e}", g.name)))?;
        for (p, (t, h)) in listing(dir) {
            let status = match before.get(&p) {
                None => "new",
                Some((_, h0)) if *h0 != h => "changed",
                Some((t0, _)) if t > *t0 || t >= start => "unchanged",
                _ => continue,
            };
            written.push((p, status));
        }
    }
    Ok(written)
}

/// `porelab reference regen [NAME]`: regenerates all generated tables, or the one named.
pub fn cli_regen(name: Option<&str>) -> Result<()> {
    let gens: Vec<&Generator> = match name {
        Some(n) => vec![find(n)?],
        None => GENERATORS.iter().collect(),
    };
    if gens.is_empty() {
        println!("no generated reference tables are registered (src/reference/mod.rs)");
        return Ok(());
    }
    let root = crate::io::repo_root();
    let dir = root.join("reference");
    let written = regen_into(&dir, &gens)?;
    for (p, status) in &written {
        let shown = p.strip_prefix(&root).unwrap_or(p);
        println!("wrote {} ({status})", shown.display());
    }
    if written.is_empty() {
        println!("no files were written");
    }
    println!("review the changes with `git diff reference/` before committing");
    Ok(())
}

/// `porelab reference list`.
pub fn cli_list() -> Result<()> {
    if GENERATORS.is_empty() {
        println!("no generated reference tables are registered");
    }
    let w = GENERATORS.iter().map(|g| g.name.len()).max().unwrap_or(0);
    for g in GENERATORS {
        println!("{:w$}  {}", g.name, g.description);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gen_ab(dir: &Path) -> Result<()> {
        write_file(dir, "a.csv", "x,y\n1,2\n")?;
        write_file(dir, "b.csv", "x,y\n3,4\n")?;
        Ok(())
    }

    static TEST_GEN: Generator = Generator {
        name: "ab",
        description: "two tables",
        generate: gen_ab,
    };

    #[test]
    fn unknown_name_lists_known() {
        let e = find("no-such-table").unwrap_err().to_string();
        assert!(e.contains("no-such-table") && e.contains("known"), "{e}");
    }

    #[test]
    fn regen_reports_written_files() {
        let dir = std::env::temp_dir().join(format!("porelab-regen-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("README.md"), "provenance").unwrap();
        let w = regen_into(&dir, &[&TEST_GEN]).unwrap();
        let mut names: Vec<(String, &str)> = w
            .iter()
            .map(|(p, s)| (p.file_name().unwrap().to_string_lossy().into_owned(), *s))
            .collect();
        names.sort();
        assert_eq!(
            names,
            [("a.csv".to_string(), "new"), ("b.csv".to_string(), "new")]
        );
        let w = regen_into(&dir, &[&TEST_GEN]).unwrap();
        assert!(w.iter().all(|(_, s)| *s == "unchanged"), "{w:?}");
        assert_eq!(w.len(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
