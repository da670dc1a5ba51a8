//! Scene files: `porelab run SCENE.toml` and the built-in scenes.
//!
//! A scene is a TOML file whose top-level `kind` key names the engine (one of [`KINDS`]:
//! `"brownian"`, `"packing"`, `"deposition"`, `"dem"`, `"lbm"`, `"coupled"`, `"filter"`); the rest of the
//! file is that engine's schema (README, "Scene files"). Every
//! table is parsed with `deny_unknown_fields`, so a misspelt key is rejected by name. A scene
//! builds only the terms it needs and prints them before the run.
//!
//! Built-in scenes are TOML files compiled into the binary (`src/scene/builtin/*.toml`), so
//! `porelab run --builtin NAME` works on a fresh clone and `porelab run --list` shows them; the
//! same files are the examples of the schema.

pub mod brownian;
pub mod coupled;
pub mod dem;
pub mod deposition;
pub mod filter;
pub mod keys;
pub mod lbm;
pub mod packing;
pub mod run_store;

use crate::error::{invalid, Error, Result};
use std::path::{Path, PathBuf};

/// A built-in scene: its name, one line of description, and its TOML text.
pub struct Builtin {
    pub name: &'static str,
    pub about: &'static str,
    pub toml: &'static str,
}

/// One kind of scene: what a scene file's `kind = "..."` selects. Each engine's scene module
/// implements it once (its `Kind`), and [`KINDS`] is the one list of kinds.
pub trait Scene: Sync {
    /// The value of the scene file's `kind` key.
    fn kind(&self) -> &'static str;
    /// The built-in scenes of this kind.
    fn builtins(&self) -> Vec<Builtin>;
    /// The key path of the scene's random seed (`porelab sweep` derives one per run there);
    /// None for an engine that draws no random numbers.
    fn seed_key(&self) -> Option<&'static str>;
    /// Parses and checks a scene text as [`Scene::run`] does before it runs, without running.
    fn check(&self, text: &str, origin: &str) -> Result<()>;
    /// Runs the scene in `text` (read from `origin`, a path or `builtin:NAME`), writing its
    /// outputs under `out`.
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()>;
}

/// Every kind of scene, in the order error messages list them.
pub const KINDS: &[&dyn Scene] = &[
    &brownian::Kind,
    &packing::Kind,
    &deposition::Kind,
    &dem::Kind,
    &lbm::Kind,
    &coupled::Kind,
    &filter::Kind,
];

/// The kind of scene that `kind = "{name}"` selects.
pub fn kind_named(name: &str) -> Option<&'static dyn Scene> {
    KINDS.iter().copied().find(|k| k.kind() == name)
}

/// All built-in scenes, in the order `porelab run --list` prints them.
pub fn builtins() -> Vec<Builtin> {
    let mut v: Vec<Builtin> = KINDS.iter().flat_map(|k| k.builtins()).collect();
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

impl RunOptions {
    /// Refuses a negative or non-finite checkpoint interval.
    pub fn check_checkpoint_interval(&self) -> Result<()> {
        match self.checkpoint_every_seconds {
            Some(t) if !(t.is_finite() && t >= 0.0) => invalid(format!(
                "checkpoint interval {t} s: must be finite and not negative"
            )),
            _ => Ok(()),
        }
    }
}

/// The values of a scene's `kind`, as error messages list them.
fn known_kinds() -> String {
    let names: Vec<String> = KINDS.iter().map(|k| format!("\"{}\"", k.kind())).collect();
    names.join(", ")
}

/// The kind of scene the text's top-level `kind` key names.
fn scene_kind(text: &str, origin: &str) -> Result<&'static dyn Scene> {
    let value: toml::Table = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("not valid TOML: {e}"),
    })?;
    refuse_non_finite(&value, text, origin)?;
    match value.get("kind") {
        Some(toml::Value::String(s)) => kind_named(s).map_or_else(
            || {
                invalid(format!(
                    "{origin}: kind = \"{s}\": unknown engine (known: {})",
                    known_kinds()
                ))
            },
            Ok,
        ),
        Some(other) => invalid(format!(
            "{origin}: key `kind` = {other}: must be a string, one of {}",
            known_kinds()
        )),
        None => invalid(format!(
            "{origin}: missing top-level key `kind` (one of {})",
            known_kinds()
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
    let kind = scene_kind(text, origin)?;
    check_out_writable(&out)?;
    kind.run(text, origin, &out, opts)
        .map_err(|e| naming_origin(e, origin))
}

/// Refuses, before any work, an output folder that cannot be written: a file in its place or
/// in its path, or a nearest existing folder where no file can be made (a probe file is made
/// there and removed; the folder itself is made by the run).
pub fn check_out_writable(out: &Path) -> Result<()> {
    let refuse = |msg: String| Error::File {
        path: out.display().to_string(),
        msg: format!("--out: {msg}"),
    };
    let mut dir = out;
    let existing = loop {
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => break dir,
            Ok(_) => {
                return Err(refuse(format!(
                    "{} is a file: the outputs need a folder",
                    dir.display()
                )))
            }
            Err(_) => match dir.parent() {
                Some(p) if !p.as_os_str().is_empty() => dir = p,
                _ => break Path::new("."),
            },
        }
    };
    let probe = existing.join(format!(".porelab-write-probe-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .map_err(|e| refuse(format!("cannot write in {}: {e}", existing.display())))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// `e` with the scene's file in front when its message does not name it yet (engine checks
/// name the key or quantity, the scene adds where it was read).
fn naming_origin(e: Error, origin: &str) -> Error {
    match e {
        Error::InvalidInput(msg) if !msg.contains(origin) => {
            Error::InvalidInput(format!("{origin}: {msg}"))
        }
        e => e,
    }
}

/// Refuses a NaN or infinite number anywhere in a scene file, naming its key path and line: no
/// engine reads a non-finite number as a setting (a bound is left out for its default, or
/// written as a large finite value), and one that slipped through would poison a run silently.
fn refuse_non_finite(table: &toml::Table, text: &str, origin: &str) -> Result<()> {
    fn walk(v: &toml::Value, path: &str, found: &mut Option<(String, f64)>) {
        if found.is_some() {
            return;
        }
        match v {
            toml::Value::Float(x) if !x.is_finite() => *found = Some((path.to_string(), *x)),
            toml::Value::Table(t) => {
                for (k, v) in t {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    walk(v, &p, found);
                }
            }
            toml::Value::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    walk(v, &format!("{path}[{i}]"), found);
                }
            }
            _ => {}
        }
    }
    let mut found = None;
    walk(&toml::Value::Table(table.clone()), "", &mut found);
    let Some((path, x)) = found else {
        return Ok(());
    };
    // the line: the first that assigns a non-finite literal to the key's last name
    let leaf = path
        .rsplit('.')
        .next()
        .unwrap_or(&path)
        .split('[')
        .next()
        .unwrap_or(&path);
    let line = text.lines().position(|l| {
        l.split('#').next().is_some_and(|code| {
            code.find(leaf).is_some_and(|at| {
                let rest = code[at + leaf.len()..].trim_start();
                rest.starts_with('=') && (rest.contains("nan") || rest.contains("inf"))
            })
        })
    });
    let at = line.map_or(String::new(), |k| format!(" (line {})", k + 1));
    invalid(format!(
        "{origin}{at}: key `{path}` = {x}: a scene's numbers must be finite (leave the key out \
         for its default, or write a finite value)"
    ))
}

/// (where, text) of the configuration a scene names in its key `key` (value `xyz`): a path
/// relative to the scene file's folder (`origin`'s), or absolute; `builtin:NAME` is one of
/// `builtins` (name, text), wherever the scene is (a built-in scene, its sweep jobs, or a file
/// started from `--show`). `hint` ends the message of a file that cannot be read.
pub(crate) fn read_configuration(
    xyz: &str,
    key: &str,
    origin: &str,
    builtins: &[(&str, &str)],
    hint: &str,
) -> Result<(String, String)> {
    if let Some(wanted) = xyz.strip_prefix("builtin:") {
        return builtins
            .iter()
            .find(|(name, _)| *name == wanted)
            .map(|(_, text)| (xyz.to_string(), text.to_string()))
            .ok_or_else(|| {
                let known: Vec<_> = builtins.iter().map(|(n, _)| *n).collect();
                Error::InvalidInput(format!(
                    "{key} = \"{xyz}\": no built-in configuration of that name (known: {})",
                    known.join(", ")
                ))
            });
    }
    let path = Path::new(xyz);
    let full = match Path::new(origin).parent() {
        Some(dir) if path.is_relative() => dir.join(path),
        _ => path.to_path_buf(),
    };
    let text = std::fs::read_to_string(&full).map_err(|e| Error::File {
        path: full.display().to_string(),
        msg: format!("{key} = \"{xyz}\" (relative to the scene file's folder): {e}{hint}"),
    })?;
    Ok((full.display().to_string(), text))
}

/// Parses and checks the scene in `text` as [`run_text`] does before it runs, without running
/// it (each engine's own parse and validation; `porelab sweep plan` checks every job so).
pub fn check_text(text: &str, origin: &str) -> Result<()> {
    scene_kind(text, origin)?
        .check(text, origin)
        .map_err(|e| naming_origin(e, origin))
}

/// `porelab run --check`: [`check_text`], then one line on stdout saying the scene would start.
fn check_and_say(text: &str, origin: &str) -> Result<()> {
    let kind = scene_kind(text, origin)?;
    check_text(text, origin)?;
    println!("{origin}: a valid {} scene (checked, not run)", kind.kind());
    Ok(())
}

/// `porelab run --show NAME`: prints the built-in scene's TOML to stdout, to start a scene
/// file from (`porelab run --show packing-spheres > my.toml`).
pub fn cli_show(name: &str) -> Result<()> {
    let all = builtins();
    match all.iter().find(|b| b.name == name) {
        Some(b) => {
            print!("{}", b.toml);
            Ok(())
        }
        None => {
            let names: Vec<_> = all.iter().map(|b| b.name).collect();
            invalid(format!(
                "--show {name}: no built-in scene of that name (known: {})",
                names.join(", ")
            ))
        }
    }
}

/// Most worker threads `--threads` accepts per core: more only add start-up and switching
/// cost (results do not depend on the count), and thousands of threads stall the machine.
pub const MAX_THREADS_PER_CORE: usize = 8;

/// Parses a checkpoint file's JSON, reading its `format` first, so that a file written in
/// another format is named as such (and not reported as malformed). `kind` names the run.
pub(crate) fn parse_checkpoint<T: serde::de::DeserializeOwned>(
    bytes: &[u8],
    format: u32,
    kind: &str,
) -> std::result::Result<T, String> {
    #[derive(serde::Deserialize)]
    struct Format {
        format: u32,
    }
    let malformed = |e: serde_json::Error| format!("not a {kind} checkpoint: {e}");
    let found = serde_json::from_slice::<Format>(bytes)
        .map_err(malformed)?
        .format;
    if found != format {
        return Err(format!(
            "checkpoint format {found}: this porelab reads format {format}; delete the \
             checkpoint to start the run afresh"
        ));
    }
    serde_json::from_slice(bytes).map_err(malformed)
}

/// The checkpoint at `path`, if there is one, read with [`parse_checkpoint`]; refused, naming
/// the file, when `scene_of` it is not `scene` (the hash of the scene text that runs now).
pub(crate) fn read_checkpoint_file<T: serde::de::DeserializeOwned>(
    path: &Path,
    format: u32,
    kind: &str,
    scene: &str,
    scene_of: impl Fn(&T) -> &str,
) -> Result<Option<T>> {
    read_checkpoint_of(
        path,
        format,
        kind,
        (scene, scene_of),
        "a different scene (its text differs)",
    )
}

/// [`read_checkpoint_file`] of any run: refused, naming the file, when `key_of` it is not
/// `key` (the hash of what the run that starts now depends on), as written by `other` (what
/// differs).
pub(crate) fn read_checkpoint_of<T: serde::de::DeserializeOwned>(
    path: &Path,
    format: u32,
    kind: &str,
    (key, key_of): (&str, impl Fn(&T) -> &str),
    other: &str,
) -> Result<Option<T>> {
    let file_err = |msg: String| Error::File {
        path: path.display().to_string(),
        msg,
    };
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(file_err(format!("cannot read the checkpoint: {e}"))),
    };
    let c: T = parse_checkpoint(&bytes, format, kind).map_err(file_err)?;
    if key_of(&c) != key {
        return Err(file_err(format!(
            "written by {other}: delete it to start afresh, or choose another output folder \
             with --out"
        )));
    }
    Ok(Some(c))
}

/// Removes the checkpoint at `path` of a run whose outputs are complete (none there: nothing
/// to do).
pub(crate) fn remove_checkpoint(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::File {
            path: path.display().to_string(),
            msg: format!("cannot remove the finished run's checkpoint: {e}"),
        }),
        _ => Ok(()),
    }
}

/// Refuses a `--threads` of 0 or above [`MAX_THREADS_PER_CORE`] per available core.
pub fn check_threads(threads: Option<usize>) -> Result<()> {
    let Some(t) = threads else { return Ok(()) };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = MAX_THREADS_PER_CORE * cores;
    if t == 0 || t > max {
        return invalid(format!(
            "--threads {t}: must be between 1 and {max} ({MAX_THREADS_PER_CORE} per core, \
             {cores} cores here); results do not depend on it"
        ));
    }
    Ok(())
}

/// Runs `f` on a pool of `threads` worker threads (None: the global pool, one per core), once
/// [`check_threads`] accepts the count; results do not depend on it.
pub(crate) fn on_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> Result<T> + Send,
) -> Result<T> {
    check_threads(threads)?;
    match threads {
        None => f(),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| crate::Error::InvalidInput(format!("--threads {t}: {e}")))?
            .install(f),
    }
}

/// Memory this machine can give a run, in bytes: `MemAvailable` of /proc/meminfo (None where
/// that cannot be read, e.g. off Linux).
pub fn available_memory_bytes() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// Refuses, before anything is allocated, a run whose estimated memory (`bytes`, from `what`,
/// which names the keys and the estimate) exceeds what the machine has available.
pub fn check_memory(origin: &str, what: &str, bytes: f64) -> Result<()> {
    let Some(avail) = available_memory_bytes() else {
        return Ok(());
    };
    if bytes > avail {
        return invalid(format!(
            "{origin}: {what} needs about {:.3e} bytes ({:.1} GB), more than the {:.1} GB of \
             memory available here: make the run smaller",
            bytes,
            bytes / 1e9,
            avail / 1e9
        ));
    }
    Ok(())
}

/// `porelab run`: a scene file, or a built-in scene by name, or the list of built-ins.
pub fn cli_run(
    file: Option<&Path>,
    builtin: Option<&str>,
    list: bool,
    check_only: bool,
    opts: &RunOptions,
) -> Result<()> {
    check_threads(opts.threads)?;
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
            let origin = path.display().to_string();
            if check_only {
                return check_and_say(&text, &origin);
            }
            run_text(&text, &origin, &stem, opts)
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
            let origin = format!("builtin:{name}");
            if check_only {
                return check_and_say(b.toml, &origin);
            }
            run_text(b.toml, &origin, name, opts)
        }
        (Some(_), Some(_)) => invalid("give either a scene file or --builtin NAME, not both"),
        (None, None) => invalid("give a scene file, --builtin NAME, or --list"),
    }
}

/// Test helper: the run `run` of `text` with its seed changed, into a folder that holds a
/// checkpoint of `text`, is refused, naming the checkpoint.
#[cfg(test)]
pub(crate) fn assert_other_scene_refused(run: impl FnOnce(&str) -> Result<()>, text: &str) {
    let other = text.replace("seed = 1", "seed = 2");
    assert_ne!(other, text, "the scene has no `seed = 1` to change");
    let e = run(&other).unwrap_err().to_string();
    assert!(
        e.contains("checkpoint.json") && e.contains("different scene"),
        "{e}"
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::checkpoint::DemState;

    #[test]
    fn a_checkpoint_of_another_format_is_named_as_such() {
        let old = br#"{"format": 1, "state": {}}"#;
        let e = parse_checkpoint::<DemState>(old, 2, "DEM").unwrap_err();
        assert!(
            e.starts_with("checkpoint format 1: this porelab reads format 2"),
            "{e}"
        );
        let e = parse_checkpoint::<DemState>(br#"{"state": {}}"#, 2, "DEM").unwrap_err();
        assert!(e.starts_with("not a DEM checkpoint"), "{e}");
    }
}
