//! `porelab sweep collect DIR`: per point, the mean, standard error and count over its runs of
//! every numeric scalar of the jobs' `out/summary.json` (nested objects flattened with dotted
//! names, booleans as 0/1, arrays, strings and nulls left out). Timing-like keys (wall seconds,
//! thread counts, the version, the seed) are left out, so the table depends only on the
//! results: the same sweep run on a laptop or on Slurm gives the same bytes. Jobs that are not
//! done are listed on stderr and in `DIR/collect-missing.txt` and never averaged over, and so
//! are runs that did not converge (a DEM bed stopped by its time limit before settling,
//! `stop` = "time limit ..."; `converged` or `jammed` false): averaging them with converged
//! runs would mix two different states. A set with any such job is refused unless `--partial`
//! ([`Collected::refusal`]), and so is one whose jobs ran different porelab versions or scene
//! kinds.
//!
//! Standard error of the mean: s / sqrt(n) with the sample standard deviation
//! s^2 = sum (x - mean)^2 / (n - 1); empty for n = 1.

use super::{job_dir, job_state, JobState, Plan};
use crate::error::Result;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Last segments of the summary keys that describe how a job ran, not what it found: wall
/// time (`seconds`, `*_seconds`), `threads`, `porelab_version`, the per-job `seed`, and the DEM's
/// `neighbour_share` (a share of wall time).
fn timing_like(key: &str) -> bool {
    let last = key.rsplit('.').next().unwrap_or(key);
    matches!(
        last,
        "seconds" | "threads" | "porelab_version" | "version" | "seed" | "neighbour_share"
    ) || last.ends_with("_seconds")
        || last.starts_with("elapsed")
}

/// The numeric scalars of a JSON value, flattened with dotted names.
pub fn flatten(prefix: &str, v: &serde_json::Value, out: &mut BTreeMap<String, f64>) {
    let name = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                flatten(&name(k), x, out);
            }
        }
        serde_json::Value::Number(n) if !timing_like(prefix) => {
            if let Some(x) = n.as_f64().filter(|x| x.is_finite()) {
                out.insert(prefix.to_string(), x);
            }
        }
        serde_json::Value::Bool(b) if !timing_like(prefix) => {
            out.insert(prefix.to_string(), if *b { 1.0 } else { 0.0 });
        }
        _ => {}
    }
}

/// Mean, standard error (None for one value) and count.
pub fn mean_sem(xs: &[f64]) -> (f64, Option<f64>, usize) {
    let n = xs.len();
    let mean = xs.iter().sum::<f64>() / n as f64;
    let sem = (n > 1).then(|| {
        let ss: f64 = xs.iter().map(|x| (x - mean) * (x - mean)).sum();
        (ss / (n - 1) as f64 / n as f64).sqrt()
    });
    (mean, sem, n)
}

/// One row of the collected table.
#[derive(Debug, Clone)]
pub struct PointRow {
    pub point: usize,
    /// The varied keys' values.
    pub values: Vec<String>,
    pub runs_planned: usize,
    pub runs_done: usize,
    /// Quantity -> (mean, standard error, count).
    pub stats: BTreeMap<String, (f64, Option<f64>, usize)>,
}

/// The collected table and the jobs left out of it.
#[derive(Debug, Clone)]
pub struct Collected {
    pub keys: Vec<String>,
    pub quantities: Vec<String>,
    pub rows: Vec<PointRow>,
    /// One line per job that is not in the table, with the reason.
    pub missing: Vec<String>,
    /// The porelab versions and scene kinds of the jobs in the table, with their counts.
    pub versions: BTreeMap<String, usize>,
    pub kinds: BTreeMap<String, usize>,
}

/// Why a finished run did not converge, from its summary: a DEM `stop` other than
/// "settled ...", `converged` (deposition) or `jammed` (packing) false.
pub fn unconverged(summary: &serde_json::Value) -> Option<String> {
    if let Some(stop) = summary["stop"].as_str() {
        if !stop.starts_with("settled") {
            return Some(format!("did not settle (stop: {stop})"));
        }
    }
    for key in ["converged", "jammed"] {
        if summary[key] == serde_json::Value::Bool(false) {
            return Some(format!("did not converge ({key} = false)"));
        }
    }
    None
}

/// What a finished job tells about how it ran, beside its numbers.
struct JobFacts {
    values: BTreeMap<String, f64>,
    /// porelab version that ran it ("unknown" for records of versions that did not say).
    version: String,
    /// The scene's `kind`.
    kind: String,
}

/// The summary of a finished job, or why it is not available.
fn job_summary(dir: &Path, plan: &Plan, j: usize) -> std::result::Result<JobFacts, String> {
    match job_state(dir, j) {
        JobState::Done => {}
        JobState::Failed(m) => return Err(format!("failed: {m}")),
        other => return Err(other.name().to_string()),
    }
    let d = job_dir(dir, j);
    let done: serde_json::Value = std::fs::read_to_string(d.join("done.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .ok_or("done.json unreadable")?;
    let want = format!("{:016x}", plan.jobs[j].hash);
    if done["scene_fnv1a64"].as_str() != Some(want.as_str()) {
        return Err(format!(
            "done.json names scene hash {}, the manifest {want}: the job ran another scene",
            done["scene_fnv1a64"]
        ));
    }
    let path = d.join("out").join("summary.json");
    let v: serde_json::Value = std::fs::read_to_string(&path)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .ok_or_else(|| format!("done, but {} is missing or not JSON", path.display()))?;
    if let Some(why) = unconverged(&v) {
        return Err(format!("unconverged: {why}"));
    }
    let version = done["porelab_version"]
        .as_str()
        .or(v["porelab_version"].as_str())
        .or(v["version"].as_str())
        .unwrap_or("unknown")
        .to_string();
    let kind = std::fs::read_to_string(d.join("scene.toml"))
        .ok()
        .and_then(|t| t.parse::<toml::Table>().ok())
        .and_then(|t| t.get("kind").and_then(|k| k.as_str()).map(String::from))
        .unwrap_or_else(|| "unknown".into());
    let mut values = BTreeMap::new();
    flatten("", &v, &mut values);
    Ok(JobFacts {
        values,
        version,
        kind,
    })
}

/// Reads every job of the sweep in `dir` and averages per point.
pub fn collect(dir: &Path) -> Result<Collected> {
    let plan = Plan::read(dir)?;
    let mut per_point: Vec<Vec<BTreeMap<String, f64>>> = vec![vec![]; plan.points()];
    let mut planned = vec![0usize; plan.points()];
    let mut missing = Vec::new();
    let (mut versions, mut kinds) = (BTreeMap::new(), BTreeMap::new());
    for j in &plan.jobs {
        planned[j.point] += 1;
        match job_summary(dir, &plan, j.job) {
            Ok(f) => {
                *versions.entry(f.version).or_insert(0) += 1;
                *kinds.entry(f.kind).or_insert(0) += 1;
                per_point[j.point].push(f.values)
            }
            Err(why) => missing.push(format!(
                "job {:05} (point {}, run {}): {why}",
                j.job, j.point, j.run
            )),
        }
    }
    let quantities: BTreeSet<String> = per_point
        .iter()
        .flatten()
        .flat_map(|m| m.keys().cloned())
        .collect();
    let rows = per_point
        .iter()
        .enumerate()
        .map(|(p, runs)| {
            let first = plan
                .jobs
                .iter()
                .find(|j| j.point == p)
                .expect("every point has jobs");
            let stats = quantities
                .iter()
                .filter_map(|q| {
                    let xs: Vec<f64> = runs.iter().filter_map(|m| m.get(q).copied()).collect();
                    (!xs.is_empty()).then(|| (q.clone(), mean_sem(&xs)))
                })
                .collect();
            PointRow {
                point: p,
                values: first.values.clone(),
                runs_planned: planned[p],
                runs_done: runs.len(),
                stats,
            }
        })
        .collect();
    Ok(Collected {
        keys: plan.keys.clone(),
        quantities: quantities.into_iter().collect(),
        rows,
        missing,
        versions,
        kinds,
    })
}

impl Collected {
    /// Why this set must not be published as complete: jobs missing or unconverged, several
    /// porelab versions, several scene kinds; None when it is whole.
    pub fn refusal(&self) -> Option<String> {
        let mut why = Vec::new();
        if !self.missing.is_empty() {
            why.push(format!(
                "{} job(s) not in the table (first: {})",
                self.missing.len(),
                self.missing[0]
            ));
        }
        let list = |m: &BTreeMap<String, usize>| {
            m.iter()
                .map(|(k, n)| format!("{k} ({n} jobs)"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if self.versions.len() > 1 {
            why.push(format!(
                "jobs of several porelab versions: {}",
                list(&self.versions)
            ));
        }
        if self.kinds.len() > 1 {
            why.push(format!(
                "jobs of several scene kinds: {}",
                list(&self.kinds)
            ));
        }
        (!why.is_empty()).then(|| why.join("; "))
    }

    /// The table as CSV: point, the varied keys, runs planned and done, then for every
    /// quantity its mean, standard error and count (`Q.mean`, `Q.sem`, `Q.n`).
    pub fn csv(&self) -> String {
        let mut w = csv::Writer::from_writer(vec![]);
        let mut head = vec!["point".to_string()];
        head.extend(self.keys.iter().cloned());
        head.push("runs_planned".into());
        head.push("runs_done".into());
        for q in &self.quantities {
            head.extend([format!("{q}.mean"), format!("{q}.sem"), format!("{q}.n")]);
        }
        w.write_record(&head).expect("in-memory CSV");
        for r in &self.rows {
            let mut row = vec![r.point.to_string()];
            row.extend(r.values.iter().cloned());
            row.push(r.runs_planned.to_string());
            row.push(r.runs_done.to_string());
            for q in &self.quantities {
                match r.stats.get(q) {
                    Some((m, s, n)) => row.extend([
                        m.to_string(),
                        s.map(|s| s.to_string()).unwrap_or_default(),
                        n.to_string(),
                    ]),
                    None => row.extend([String::new(), String::new(), "0".into()]),
                }
            }
            w.write_record(&row).expect("in-memory CSV");
        }
        String::from_utf8(w.into_inner().expect("in-memory CSV")).expect("UTF-8 fields")
    }
}
