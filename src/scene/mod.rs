//! Scene files: `porelab run SCENE.toml` and the built-in scenes.
//!
//! A scene is a TOML file whose top-level `kind` key names the engine (`"brownian"` or
//! `"packing"`); the rest of the file is that engine's schema (README, "Scene files"). Every
//! table is parsed with `deny_unknown_fields`, so a misspelt key is rejected by name. A scene
//! builds only the terms it needs and prints them before the run.
//!
//! Built-in scenes are TOML files compiled into the binary (`src/scene/builtin/*.toml`), so
//! `porelab run --builtin NAME` works on a fresh clone and `porelab run --list` shows them; the
//! same files are the examples of the schema.

pub mod brownian;
pub mod dem;
pub mod packing;

use crate::error::{invalid, Error, Result};
use std::path::{Path, PathBuf};

/// A built-in scene: its name, one line of description, and its TOML text.
pub struct Builtin {
    pub name: &'static str,
    pub about: &'static str,
    pub toml: &'static str,
}

/// All built-in scenes, in the order `porelab run --list` prints them.
pub fn builtins() -> Vec<Builtin> {
    let mut v = brownian::builtins();
    v.extend(packing::builtins());
    v.extend(dem::builtins());
    v.sort_by_key(|b| b.name);
    v
}

/// Where a scene's outputs go unless `--out` says otherwise: `target/porelab/run/<stem>/`.
pub fn default_out_dir(stem: &str) -> PathBuf {
    Path::new("target/porelab/run").join(stem)
}

/// Options of `porelab run` that override the scene file.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output folder.
    pub out: Option<PathBuf>,
    /// Worker threads for independent runs (None: all cores). Results do not depend on it.
    pub threads: Option<usize>,
    /// No progress bar.
    pub quiet: bool,
    /// Packing runs: write the checkpoint when at least this many seconds have passed since
    /// the last one, and always after a halving, at the end, and when a test stops the run
    /// after a set number of steps (a killed run resumes from the last one). `None` or
    /// `Some(0.0)` writes it after every compression step; negative or non-finite values are
    /// refused. The checkpoint holds the whole history, so writing it after each of the ~1e5
    /// steps of a thesis-schedule run (Delta V absolute) made the I/O quadratic in the steps.
    pub checkpoint_every_seconds: Option<f64>,
}

/// The engine a scene names, read from its top-level `kind` key.
fn scene_kind(text: &str, origin: &str) -> Result<String> {
    let value: toml::Table = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("not valid TOML: {e}"),
    })?;
    match value.get("kind") {
        Some(toml::Value::String(s)) => Ok(s.clone()),
        Some(other) => invalid(format!(
            "{origin}: key `kind` = {other}: must be a string, \"brownian\" or \"packing\""
        )),
        None => invalid(format!(
            "{origin}: missing top-level key `kind` (\"brownian\" or \"packing\")"
        )),
    }
}

/// Runs the scene in `text` (read from `origin`, a path or `builtin:NAME`), writing outputs
/// under `out_stem`'s folder.
pub fn run_text(text: &str, origin: &str, out_stem: &str, opts: &RunOptions) -> Result<()> {
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| default_out_dir(out_stem));
    match scene_kind(text, origin)?.as_str() {
        "brownian" => brownian::run_scene(text, origin, &out, opts),
        "packing" => packing::run_scene(text, origin, &out, opts),
        "dem" => dem::run_scene(text, origin, &out, opts),
        other => invalid(format!(
            "{origin}: kind = \"{other}\": unknown engine (known: \"brownian\", \"packing\", \"dem\")"
        )),
    }
}

/// `porelab run`: a scene file, or a built-in scene by name, or the list of built-ins.
pub fn cli_run(
    file: Option<&Path>,
    builtin: Option<&str>,
    list: bool,
    opts: &RunOptions,
) -> Result<()> {
    if list {
        for b in builtins() {
            println!("{:<28} {}", b.name, b.about);
        }
        return Ok(());
    }
    match (file, builtin) {
        (Some(path), None) => {
            let text = std::fs::read_to_string(path).map_err(|e| Error::File {
                path: path.display().to_string(),
                msg: e.to_string(),
            })?;
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".into());
            run_text(&text, &path.display().to_string(), &stem, opts)
        }
        (None, Some(name)) => {
            let all = builtins();
            let Some(b) = all.iter().find(|b| b.name == name) else {
                let names: Vec<_> = all.iter().map(|b| b.name).collect();
                return invalid(format!(
                    "no built-in scene `{name}` (known: {})",
                    names.join(", ")
                ));
            };
            run_text(b.toml, &format!("builtin:{name}"), name, opts)
        }
        (Some(_), Some(_)) => invalid("give either a scene file or --builtin NAME, not both"),
        (None, None) => invalid("give a scene file, --builtin NAME, or --list"),
    }
}
