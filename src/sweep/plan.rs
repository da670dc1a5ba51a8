//! `porelab sweep plan`: a sweep file -> one complete scene per job, a manifest, a copy of the
//! sweep file. Every job's scene is checked by its engine before anything is written.
//!
//! Job numbering: point `p` (grid order: the first `[vary]` key varies slowest, the last
//! fastest, as nested loops in file order; zip: the lists side by side), run `r` of
//! `runs_per_point`, job `j = p * runs_per_point + r`.

use super::{fnv1a64, job_dir, Plan, PlannedJob, MANIFEST, SWEEP_COPY};
use crate::error::{invalid, Error, Result};
use crate::io::{create_dir, write_atomic};
use serde::Deserialize;
use std::path::Path;

/// The sweep file (TOML). Unknown keys are rejected by name.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepFile {
    /// Free text, copied into every job's header.
    #[serde(default)]
    title: String,
    /// Base scene file, relative to the sweep file.
    scene: Option<String>,
    /// Or a built-in scene by name (`porelab run --list`).
    builtin: Option<String>,
    /// Or the base scene itself, inline as a `[base]` table.
    base: Option<toml::Table>,
    /// "grid" (every combination) or "zip" (the lists side by side, equal lengths).
    #[serde(default = "grid")]
    combine: String,
    #[serde(default = "one")]
    runs_per_point: usize,
    #[serde(default = "one_u64")]
    base_seed: u64,
    /// Dotted key paths into the scene -> lists of values.
    #[serde(default)]
    vary: toml::Table,
}
fn grid() -> String {
    "grid".into()
}
fn one() -> usize {
    1
}
fn one_u64() -> u64 {
    1
}

/// Most jobs one plan holds (five-digit job folders).
pub const MAX_JOBS: usize = 100_000;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014, "Fast splittable pseudorandom number
/// generators", OOPSLA; the constants of Vigna's `splitmix64.c`).
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of run `run` of point `point`:
/// `splitmix64(splitmix64(splitmix64(base_seed) ^ point) ^ run) >> 1`, chained so that
/// neighbouring (point, run) pairs get unrelated seeds; the shift keeps it within TOML's
/// signed 64-bit integers.
pub fn job_seed(base_seed: u64, point: usize, run: usize) -> u64 {
    splitmix64(splitmix64(splitmix64(base_seed) ^ point as u64) ^ run as u64) >> 1
}

/// The varied keys in file order, each with its list of values. Nested tables (`[vary.mcm]`
/// or unquoted dotted keys) and quoted dotted keys (`"mcm.phi0"`) both name a path.
fn flatten_vary(
    prefix: &str,
    t: &toml::Table,
    out: &mut Vec<(String, Vec<toml::Value>)>,
) -> Result<()> {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(sub) => flatten_vary(&key, sub, out)?,
            toml::Value::Array(values) if values.is_empty() => {
                return invalid(format!("vary.{key} = []: needs at least one value"))
            }
            toml::Value::Array(values) => out.push((key, values.clone())),
            other => {
                return invalid(format!(
                    "vary.{key} = {other}: must be a list of values (e.g. [{other}])"
                ))
            }
        }
    }
    Ok(())
}

/// The value index of every key at each point.
fn combine(how: &str, lens: &[usize]) -> Result<Vec<Vec<usize>>> {
    match how {
        "grid" => {
            let mut points = vec![vec![]];
            for &n in lens {
                points = points
                    .into_iter()
                    .flat_map(|p| {
                        (0..n).map(move |i| {
                            let mut q = p.clone();
                            q.push(i);
                            q
                        })
                    })
                    .collect();
            }
            Ok(points)
        }
        "zip" => {
            let n = lens.first().copied().unwrap_or(1);
            if lens.iter().any(|&m| m != n) {
                return invalid(format!(
                    "combine = \"zip\": the [vary] lists have lengths {lens:?}; zip needs equal \
                     lengths (use combine = \"grid\" for every combination)"
                ));
            }
            Ok((0..n).map(|i| vec![i; lens.len()]).collect())
        }
        other => invalid(format!(
            "combine = \"{other}\": must be \"grid\" or \"zip\""
        )),
    }
}

/// Sets `value` at the dotted `path` of `table`; a numeric segment indexes an array of tables
/// (`species.0.fraction`). Missing tables are created (the engine's schema then accepts or
/// rejects the key by name); a path through a value that is not a table is refused.
pub fn set_path(table: &mut toml::Table, path: &str, value: toml::Value) -> Result<()> {
    let parts: Vec<&str> = path.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return invalid(format!("vary.{path}: empty segment in the key path"));
    }
    let mut cur = table;
    for (depth, part) in parts[..parts.len() - 1].iter().enumerate() {
        let here = parts[..=depth].join(".");
        let next = cur
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = match next {
            toml::Value::Table(t) => t,
            toml::Value::Array(items) => {
                let seg = parts[depth + 1];
                return set_in_array(items, &here, seg, &parts[depth + 2..], path, value);
            }
            other => {
                return invalid(format!(
                    "vary.{path}: `{here}` is {other} in the base scene, not a table"
                ))
            }
        };
    }
    cur.insert(parts[parts.len() - 1].to_string(), value);
    Ok(())
}

fn set_in_array(
    items: &mut [toml::Value],
    here: &str,
    seg: &str,
    rest: &[&str],
    path: &str,
    value: toml::Value,
) -> Result<()> {
    let Ok(i) = seg.parse::<usize>() else {
        return invalid(format!(
            "vary.{path}: `{here}` is an array in the base scene: the next segment must be an \
             index (0..{}), not `{seg}`",
            items.len()
        ));
    };
    let n = items.len();
    let Some(item) = items.get_mut(i) else {
        return invalid(format!(
            "vary.{path}: `{here}` has {n} entries in the base scene, no index {i}"
        ));
    };
    match (item, rest.is_empty()) {
        (slot, true) => {
            *slot = value;
            Ok(())
        }
        (toml::Value::Table(t), false) => set_path(t, &rest.join("."), value),
        (other, false) => invalid(format!(
            "vary.{path}: `{here}.{i}` is {other} in the base scene, not a table"
        )),
    }
}

/// A value as the manifest and the headers print it (strings without quotes).
pub fn show_value(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Reads, expands and checks a sweep file; nothing is written.
pub fn plan_sweep(sweep_path: &Path) -> Result<(String, Plan)> {
    let origin = sweep_path.display().to_string();
    let text = std::fs::read_to_string(sweep_path).map_err(|e| Error::File {
        path: origin.clone(),
        msg: e.to_string(),
    })?;
    let plan = plan_text(
        &text,
        sweep_path.parent().unwrap_or(Path::new(".")),
        &origin,
    )?;
    Ok((text, plan))
}

/// Expands the sweep in `text` (`base` is the folder relative paths start from).
pub fn plan_text(text: &str, base: &Path, origin: &str) -> Result<Plan> {
    let f: SweepFile = toml::from_str(text).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: format!("sweep file: {e}"),
    })?;
    let named = |e: Error| match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{origin}: {m}")),
        other => other,
    };
    let (scene_text, scene_origin) = match (&f.scene, &f.builtin, &f.base) {
        (None, None, Some(table)) => {
            let t = toml::to_string(table).map_err(|e| {
                Error::InvalidInput(format!("{origin}: [base]: cannot write the scene: {e}"))
            })?;
            (t, format!("{origin} [base]"))
        }
        (Some(p), None, None) => {
            let path = base.join(p);
            let t = std::fs::read_to_string(&path).map_err(|e| Error::File {
                path: path.display().to_string(),
                msg: format!("the sweep's base scene (scene = \"{p}\"): {e}"),
            })?;
            (t, p.clone())
        }
        (None, Some(name), None) => {
            let all = crate::scene::builtins();
            let Some(b) = all.iter().find(|b| b.name == name) else {
                let names: Vec<_> = all.iter().map(|b| b.name).collect();
                return invalid(format!(
                    "{origin}: builtin = \"{name}\": no built-in scene of that name (known: {})",
                    names.join(", ")
                ));
            };
            (b.toml.to_string(), format!("builtin:{name}"))
        }
        _ => {
            return invalid(format!(
                "{origin}: give exactly one of `scene = \"file.toml\"`, `builtin = \"name\"` or \
                 a `[base]` table"
            ))
        }
    };
    let base_table: toml::Table = toml::from_str(&scene_text).map_err(|e| Error::File {
        path: scene_origin.clone(),
        msg: format!("not valid TOML: {e}"),
    })?;
    let kind = match base_table.get("kind") {
        Some(toml::Value::String(k)) => k.clone(),
        _ => {
            return invalid(format!(
                "{scene_origin}: the base scene needs a top-level string key `kind`"
            ))
        }
    };
    if f.runs_per_point == 0 {
        return invalid(format!("{origin}: runs_per_point = 0: must be at least 1"));
    }
    let seed_path = crate::scene::kind_named(&kind).and_then(|k| k.seed_key());
    if seed_path.is_none() && f.runs_per_point > 1 {
        return invalid(format!(
            "{origin}: runs_per_point = {}: a \"{kind}\" scene has no seed (it draws no random \
             numbers), so its runs would be identical; use runs_per_point = 1",
            f.runs_per_point
        ));
    }
    let mut vary = Vec::new();
    flatten_vary("", &f.vary, &mut vary).map_err(named)?;
    if let Some(sk) = seed_path {
        if vary.iter().any(|(k, _)| k == sk) {
            return invalid(format!(
                "{origin}: vary.{sk}: the seed of a \"{kind}\" scene is set by the sweep from \
                 base_seed, the point and the run; vary base_seed or runs_per_point instead"
            ));
        }
    }
    let lens: Vec<usize> = vary.iter().map(|(_, v)| v.len()).collect();
    let points = combine(&f.combine, &lens).map_err(named)?;
    let n_jobs = points.len() * f.runs_per_point;
    if n_jobs > MAX_JOBS {
        return invalid(format!(
            "{origin}: {} points x {} runs = {n_jobs} jobs: at most {MAX_JOBS} per plan",
            points.len(),
            f.runs_per_point
        ));
    }
    let keys: Vec<String> = vary.iter().map(|(k, _)| k.clone()).collect();
    let mut jobs = Vec::with_capacity(n_jobs);
    for (p, idx) in points.iter().enumerate() {
        let values: Vec<toml::Value> = idx
            .iter()
            .zip(&vary)
            .map(|(&i, (_, vals))| vals[i].clone())
            .collect();
        let described: Vec<String> = keys
            .iter()
            .zip(&values)
            .map(|(k, v)| format!("{k} = {v}"))
            .collect();
        let at = format!("point {p} ({})", described.join(", "));
        let mut point_table = base_table.clone();
        for (k, v) in keys.iter().zip(&values) {
            set_path(&mut point_table, k, v.clone())
                .map_err(|e| Error::InvalidInput(format!("{origin}: {at}: {e}")))?;
        }
        for r in 0..f.runs_per_point {
            let j = p * f.runs_per_point + r;
            let mut table = point_table.clone();
            let seed = seed_path.map(|sk| {
                let s = job_seed(f.base_seed, p, r);
                // A key path of at most two plain segments into the scene's own tables.
                set_path(&mut table, sk, toml::Value::Integer(s as i64)).map(|_| s)
            });
            let seed = seed.transpose()?;
            let body = toml::to_string(&table).map_err(|e| {
                Error::InvalidInput(format!("{origin}: {at}: cannot write the scene: {e}"))
            })?;
            let mut header = format!(
                "# porelab sweep job {j:05}: point {p} of {}, run {r} of {}\n",
                points.len(),
                f.runs_per_point
            );
            if !f.title.is_empty() {
                header += &format!("# sweep: {}\n", f.title);
            }
            header += &format!("# base scene: {scene_origin}\n");
            for d in &described {
                header += &format!("# {d}\n");
            }
            if let (Some(sk), Some(s)) = (seed_path, seed) {
                header += &format!(
                    "# {sk} = {s} (SplitMix64 chain of base_seed {}, point {p}, run {r})\n",
                    f.base_seed
                );
            }
            let scene = format!("{header}\n{body}");
            crate::scene::check_text(&scene, &format!("job {j:05}"))
                .map_err(|e| Error::InvalidInput(format!("{origin}: {at}, run {r}: {e}")))?;
            jobs.push(PlannedJob {
                job: j,
                point: p,
                run: r,
                seed,
                values: values.iter().map(show_value).collect(),
                hash: fnv1a64(scene.as_bytes()),
                scene,
            });
        }
    }
    Ok(Plan { keys, jobs })
}

/// `porelab sweep plan SWEEP --out DIR`: checks every job, then writes them. A DIR that holds
/// the same plan is left as it is (its finished jobs stay); a different plan is refused.
pub fn cli_plan(sweep_path: &Path, dir: &Path) -> Result<()> {
    let (text, plan) = plan_sweep(sweep_path)?;
    write_plan(&text, &plan, dir)
}

/// Writes `plan` (from the sweep file `text`) to `dir`, as `porelab sweep plan` does.
pub fn write_plan(text: &str, plan: &Plan, dir: &Path) -> Result<()> {
    let manifest = plan.manifest_csv();
    let existing = dir.join(MANIFEST);
    if existing.is_file() {
        let old = std::fs::read_to_string(&existing)?;
        if old == manifest {
            eprintln!(
                "porelab sweep plan: {} already holds this plan ({} jobs); nothing written",
                dir.display(),
                plan.jobs.len()
            );
            return Ok(());
        }
        return invalid(format!(
            "--out {}: the folder holds a different plan (its {MANIFEST} differs); choose \
             another folder or remove it",
            dir.display()
        ));
    }
    if dir.is_dir() {
        // Without a manifest no job can have run: only an interrupted plan may be rewritten.
        for e in std::fs::read_dir(dir)? {
            let name = e?.file_name().to_string_lossy().into_owned();
            if name != "jobs" && name != SWEEP_COPY {
                return invalid(format!(
                    "--out {}: the folder is not empty and holds no sweep plan (found `{name}`); \
                     choose an empty or new folder",
                    dir.display()
                ));
            }
        }
    }
    create_dir(dir)?;
    write_atomic(&dir.join(SWEEP_COPY), text.as_bytes())?;
    for j in &plan.jobs {
        write_atomic(&job_dir(dir, j.job).join("scene.toml"), j.scene.as_bytes())?;
    }
    // Last: a folder with a manifest holds a complete plan.
    write_atomic(&existing, manifest.as_bytes())?;
    let points = plan.jobs.last().map_or(0, |j| j.point + 1);
    eprintln!(
        "porelab sweep plan: {} jobs ({points} points x {} runs) checked and written to {}",
        plan.jobs.len(),
        plan.jobs.len() / points.max(1),
        dir.display()
    );
    Ok(())
}
