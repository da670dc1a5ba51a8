//! The layering of `src/` (DESIGN.md, "Layout"): kernels flow down into engines, engines into
//! the floors that drive them, and never back. This test reads the sources and fails on an
//! import that runs back up, on an engine reaching into an engine it does not compose, and on
//! two files of one folder that import each other (a circle).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Kernels and shared plumbing: import no engine and no floor.
const KERNELS: &[&str] = &[
    "special",
    "shape",
    "contact",
    "magnetics",
    "hydro",
    "analysis",
    "io",
    "consts",
    "error",
    "driver",
];
/// Engines: import kernels, and only the engines they compose (below).
const ENGINES: &[&str] = &[
    "brownian",
    "packing",
    "deposition",
    "dem",
    "lbm",
    "coupled",
    "filter",
];
/// Floors above the engines: scenes, sweeps, benchmarks, one-shot commands, validation and
/// the reference oracles.
const FLOORS: &[&str] = &["scene", "sweep", "bench", "cli", "validation", "reference"];
/// The engines an engine composes (DESIGN.md: the coupled engine uses dem and lbm through
/// their public step and field APIs; the filter joins a flow, a field and particle motion).
const COMPOSES: &[(&str, &[&str])] = &[
    ("coupled", &["dem", "lbm"]),
    ("filter", &["lbm", "brownian"]),
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The code of a file without its comments (line comments and doc comments).
fn code_of(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level modules a file names through `crate::NAME`, including `use crate::{a::x, b}`.
fn crate_modules(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // a group: the first path segment of each item (nested groups are rare here)
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name: String = item
                    .trim()
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    out.insert(name);
                }
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            out.insert(name);
        }
    }
    out
}

fn top_module(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel
        .components()
        .next()
        .unwrap()
        .as_os_str()
        .to_string_lossy();
    first.trim_end_matches(".rs").to_string()
}

#[test]
fn imports_run_down_and_engines_compose_only_what_they_name() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut wrong = Vec::new();
    for f in &files {
        let from = top_module(&src, f);
        let code = code_of(&std::fs::read_to_string(f).unwrap());
        for to in crate_modules(&code) {
            if to == from {
                continue;
            }
            let up = (KERNELS.contains(&from.as_str())
                && (ENGINES.contains(&to.as_str()) || FLOORS.contains(&to.as_str())))
                || (ENGINES.contains(&from.as_str()) && FLOORS.contains(&to.as_str()));
            let across = ENGINES.contains(&from.as_str())
                && ENGINES.contains(&to.as_str())
                && !COMPOSES
                    .iter()
                    .any(|(e, uses)| *e == from && uses.contains(&to.as_str()));
            if up || across {
                wrong.push(format!(
                    "{} uses crate::{to} ({})",
                    f.strip_prefix(&src).unwrap().display(),
                    if up {
                        "runs back up"
                    } else {
                        "an engine it does not compose"
                    }
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the layering:\n{}",
        wrong.join("\n")
    );
}

/// The sibling files (same folder) a file imports, through `super::NAME` or
/// `crate::<its module path>::NAME`.
fn siblings_used(code: &str, module_path: &str, siblings: &BTreeSet<String>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let prefixes = ["super::".to_string(), format!("crate::{module_path}::")];
    for prefix in &prefixes {
        let mut rest = code;
        while let Some(i) = rest.find(prefix.as_str()) {
            rest = &rest[i + prefix.len()..];
            let names: Vec<String> = if let Some(group) = rest.strip_prefix('{') {
                let end = group.find('}').unwrap_or(group.len());
                group[..end]
                    .split(',')
                    .map(|s| {
                        s.trim()
                            .chars()
                            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                            .collect()
                    })
                    .collect()
            } else {
                vec![rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect()]
            };
            for n in names {
                if siblings.contains(&n) {
                    out.insert(n);
                }
            }
        }
    }
    out
}

#[test]
fn no_two_files_of_a_folder_import_each_other() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    // folder -> (file stem -> sibling stems it uses); mod.rs is the folder itself, not a sibling
    let mut by_folder: BTreeMap<PathBuf, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for f in &files {
        let dir = f.parent().unwrap().to_path_buf();
        if dir == src {
            continue;
        }
        let stem = f.file_stem().unwrap().to_string_lossy().into_owned();
        if stem == "mod" {
            continue;
        }
        let siblings: BTreeSet<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| {
                let p = e.ok()?.path();
                let s = p.file_stem()?.to_string_lossy().into_owned();
                (s != "mod" && s != stem && (p.is_dir() || p.extension()? == "rs")).then_some(s)
            })
            .collect();
        let module_path = dir
            .strip_prefix(&src)
            .unwrap()
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join("::");
        let code = code_of(&std::fs::read_to_string(f).unwrap());
        // a test module's `super::` is its own file, not the folder: drop test code
        let code = match code.find("#[cfg(test)]") {
            Some(i) => code[..i].to_string(),
            None => code,
        };
        let used = siblings_used(&code, &module_path, &siblings);
        by_folder.entry(dir).or_default().insert(stem, used);
    }
    let mut circles = Vec::new();
    for (dir, uses) in &by_folder {
        for (a, used) in uses {
            for b in used {
                if a < b && uses.get(b).is_some_and(|u| u.contains(a)) {
                    circles.push(format!(
                        "{}: {a}.rs <-> {b}.rs",
                        dir.strip_prefix(&src).unwrap().display()
                    ));
                }
            }
        }
    }
    assert!(
        circles.is_empty(),
        "import circles:\n{}",
        circles.join("\n")
    );
}
