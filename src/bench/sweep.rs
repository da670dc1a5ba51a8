//! `porelab bench sweep`: what a sweep costs beyond its scenes. Plans, runs and collects a
//! sweep of the tiny packing scene [`TINY_PACKING`] (default 10 sizes x 10 runs = 100 jobs)
//! with 1 and 2 local workers, and prints per-job overheads against the scene's own run time
//! (`done.json` seconds, measured inside the job around `scene::run_text`).
//!
//! Launch overhead per job = (wall time of `sweep run --jobs 1` - sum of the jobs' own
//! seconds) / jobs: process start, manifest read, hash check, rename and records.

use crate::error::{invalid, Error, Result};
use crate::sweep::{job_dir, Plan};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A packing scene of 20 spheres that runs in a fraction of a second: the test and benchmark
/// scene of the sweep module (tests/common/sweep_scene.rs uses it too).
pub const TINY_PACKING: &str = r#"kind = "packing"
title = "tiny packing"
[particles]
shape = "sphere"
n = 20
[mcm]
delta_v_per_particle = 0.05
halvings = 2
tries_per_particle = 50.0
[analysis]
gr_bins = 20
s4_trials = 50
"#;

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Points (particle counts 20, 21, ...).
    #[arg(long, default_value_t = 10)]
    pub points: usize,
    /// Runs per point.
    #[arg(long, default_value_t = 10)]
    pub runs: usize,
    /// Working folder (removed and rewritten).
    #[arg(long, default_value = "target/porelab/bench-sweep")]
    pub out: PathBuf,
}

/// The jobs' own run times (done.json `seconds`), summed.
fn job_seconds(dir: &Path, plan: &Plan) -> Result<f64> {
    let mut total = 0.0;
    for j in &plan.jobs {
        let t = std::fs::read_to_string(job_dir(dir, j.job).join("done.json"))?;
        let v: serde_json::Value =
            serde_json::from_str(&t).map_err(|e| Error::Validation(e.to_string()))?;
        total += v["seconds"]
            .as_f64()
            .ok_or_else(|| Error::Validation(format!("job {}: no seconds", j.job)))?;
    }
    Ok(total)
}

pub fn run(a: &BenchArgs) -> Result<()> {
    if a.points == 0 || a.runs == 0 {
        return invalid("--points and --runs: at least 1 each");
    }
    let _ = std::fs::remove_dir_all(&a.out);
    crate::io::create_dir(&a.out)?;
    std::fs::write(a.out.join("base.toml"), TINY_PACKING)?;
    let sizes: Vec<String> = (0..a.points).map(|k| (20 + k).to_string()).collect();
    let sweep = a.out.join("sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "scene = \"base.toml\"\nruns_per_point = {}\n[vary]\n\"particles.n\" = [{}]\n",
            a.runs,
            sizes.join(", ")
        ),
    )?;
    let exe = std::env::current_exe()?;
    let mut rows = Vec::new();
    let mut tables = Vec::new();
    for workers in [1usize, 2] {
        let dir = a.out.join(format!("workers-{workers}"));
        let t = Instant::now();
        crate::sweep::plan::cli_plan(&sweep, &dir)?;
        let plan_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let status = std::process::Command::new(&exe)
            .args(["sweep", "run"])
            .arg(&dir)
            .args(["--jobs", &workers.to_string(), "--threads", "1"])
            .stderr(std::process::Stdio::null())
            .status()?;
        let run_s = t.elapsed().as_secs_f64();
        if !status.success() {
            return Err(Error::Validation(format!(
                "sweep run {}: {status}",
                dir.display()
            )));
        }
        let t = Instant::now();
        crate::sweep::cli_collect(&dir, false)?;
        let collect_s = t.elapsed().as_secs_f64();
        let plan = Plan::read(&dir)?;
        let n = plan.jobs.len() as f64;
        let own = job_seconds(&dir, &plan)?;
        rows.push((workers, n, plan_s, run_s, own, collect_s));
        tables.push(std::fs::read(dir.join("collected.csv"))?);
    }
    let same = tables[0] == tables[1];
    let mut csv = String::from(
        "workers,jobs,plan_ms_per_job,run_wall_s,jobs_own_s,launch_ms_per_job,collect_ms_per_job,\
         mean_job_ms,identical_collected\n",
    );
    println!(
        "{:>7} {:>5} {:>10} {:>10} {:>10} {:>12} {:>12} {:>10}",
        "workers",
        "jobs",
        "plan ms/j",
        "run wall s",
        "jobs own s",
        "launch ms/j",
        "collect ms/j",
        "job ms"
    );
    for &(w, n, plan_s, run_s, own, collect_s) in &rows {
        // Launch overhead is defined on the serial run; with two workers the wall time is shared.
        let launch = (run_s * w as f64 - own) / n * 1e3;
        println!(
            "{w:>7} {n:>5} {:>10.3} {run_s:>10.2} {own:>10.2} {launch:>12.1} {:>12.3} {:>10.1}",
            plan_s / n * 1e3,
            collect_s / n * 1e3,
            own / n * 1e3
        );
        csv += &format!(
            "{w},{n},{},{run_s},{own},{launch},{},{},{same}\n",
            plan_s / n * 1e3,
            collect_s / n * 1e3,
            own / n * 1e3
        );
    }
    println!(
        "speed-up of 2 workers: {:.2}; collected.csv identical: {same}",
        rows[0].3 / rows[1].3
    );
    crate::io::write_atomic(&a.out.join("bench-sweep.csv"), csv.as_bytes())?;
    if !same {
        return Err(Error::Validation(
            "collected.csv differs between 1 and 2 workers".into(),
        ));
    }
    Ok(())
}
