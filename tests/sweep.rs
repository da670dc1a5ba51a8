//! `porelab sweep` through the binary on a tiny packing scene (each job well under a second):
//! plan -> run -> collect, idempotent reruns, resume after a kill, failure isolation, and the
//! same collected bytes with one or two workers.

#[path = "common/sweep_scene.rs"]
mod sweep_scene;

use std::path::{Path, PathBuf};
use sweep_scene::{fresh_dir, ok, plan, porelab, write_sweep};

fn planned(name: &str) -> (PathBuf, PathBuf) {
    let root = fresh_dir(name);
    let sweep = write_sweep(&root);
    let dir = root.join("sweep");
    plan(&sweep, &dir);
    (sweep, dir)
}

fn run(dir: &Path, jobs: usize) -> std::process::Output {
    porelab()
        .args(["sweep", "run"])
        .arg(dir)
        .args(["--jobs", &jobs.to_string()])
        .output()
        .unwrap()
}

/// What `porelab sweep status DIR` prints.
fn status(dir: &Path) -> String {
    ok(porelab().args(["sweep", "status"]).arg(dir)).0
}

fn collected(dir: &Path) -> String {
    ok(porelab().args(["sweep", "collect"]).arg(dir));
    std::fs::read_to_string(dir.join("collected.csv")).unwrap()
}

fn job(dir: &Path, i: usize) -> PathBuf {
    dir.join("jobs").join(format!("{i:05}"))
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The collected table as rows of (header -> cell).
fn table(csv_text: &str) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_reader(csv_text.as_bytes());
    let head: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            head.iter()
                .cloned()
                .zip(rec.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

#[test]
fn plan_run_collect_averages_each_points_runs() {
    let (_, dir) = planned("basic");
    assert!(run(&dir, 1).status.success());
    let text = collected(&dir);
    let rows = table(&text);
    assert_eq!(rows.len(), 2);
    let manifest = std::fs::read_to_string(dir.join("manifest.csv")).unwrap();
    let seeds: Vec<u64> = manifest
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    for (p, row) in rows.iter().enumerate() {
        assert_eq!(row["particles.n"], ["20", "30"][p]);
        assert_eq!(row["runs_done"], "3");
        // Recompute the point's mean and standard error from the jobs' own summaries.
        let xs: Vec<f64> = (0..3)
            .map(|r| {
                let s = json(&job(&dir, 3 * p + r).join("out/summary.json"));
                // Each job ran the scene it was planned with: its seed and size.
                assert_eq!(s["seed"].as_u64(), Some(seeds[3 * p + r]));
                assert_eq!(s["n"].as_u64(), Some([20, 30][p]));
                s["packing_fraction"].as_f64().unwrap()
            })
            .collect();
        let mean = xs.iter().sum::<f64>() / 3.0;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 2.0;
        let m: f64 = row["packing_fraction.mean"].parse().unwrap();
        let se: f64 = row["packing_fraction.sem"].parse().unwrap();
        assert!((m - mean).abs() <= 1e-15 * mean, "point {p}: {m} vs {mean}");
        assert!(
            (se - (var / 3.0).sqrt()).abs() <= 1e-12 * se,
            "point {p}: {se}"
        );
        assert_eq!(row["packing_fraction.n"], "3");
    }
    // Timings, threads and seeds stay out of the table.
    let head = text.lines().next().unwrap();
    for bad in ["seconds", "threads", "seed", "version"] {
        assert!(!head.contains(bad), "{bad} in {head}");
    }
    assert!(dir.join("plots/packing_fraction.svg").is_file());
    assert_eq!(
        std::fs::read_to_string(dir.join("collect-missing.txt")).unwrap(),
        ""
    );
}

#[test]
fn a_second_run_does_nothing_and_a_second_plan_keeps_the_results() {
    let (sweep, dir) = planned("idempotent");
    assert!(run(&dir, 1).status.success());
    let before = collected(&dir);
    let stamp = std::fs::metadata(job(&dir, 0).join("done.json"))
        .unwrap()
        .modified()
        .unwrap();
    let again = run(&dir, 2);
    assert!(again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("0 of 6 jobs to run"));
    plan(&sweep, &dir);
    let after = std::fs::metadata(job(&dir, 0).join("done.json"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(stamp, after);
    assert_eq!(before, collected(&dir));
    // Another plan into the same folder is refused.
    let other = sweep.with_file_name("other.toml");
    std::fs::write(
        &other,
        std::fs::read_to_string(&sweep)
            .unwrap()
            .replace("base_seed = 5", "base_seed = 6"),
    )
    .unwrap();
    let out = porelab()
        .args(["sweep", "plan"])
        .arg(&other)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("holds a different plan"));
}

#[test]
fn a_killed_sweep_resumes_to_the_same_table() {
    let (_, dir) = planned("resume");
    assert!(run(&dir, 1).status.success());
    let whole = collected(&dir);
    // Job 2 killed mid-way: a stale tmp folder with partial output, no out/, no record.
    std::fs::remove_file(job(&dir, 2).join("done.json")).unwrap();
    std::fs::remove_dir_all(job(&dir, 2).join("out")).unwrap();
    std::fs::create_dir_all(job(&dir, 2).join("tmp-999999")).unwrap();
    std::fs::write(
        job(&dir, 2).join("tmp-999999/summary.json"),
        "{\"packing_fr",
    )
    .unwrap();
    // Job 4 killed between the rename and the record: out/ but no done.json.
    std::fs::remove_file(job(&dir, 4).join("done.json")).unwrap();
    let st = status(&dir);
    assert!(
        st.contains("4 done, 0 failed, 1 started") && st.contains("1 pending"),
        "{st}"
    );
    // Collect meanwhile lists both and averages over the rest only.
    let partial = table(&collected(&dir));
    assert_eq!(
        (
            partial[0]["runs_done"].as_str(),
            partial[1]["runs_done"].as_str()
        ),
        ("2", "2")
    );
    let missing = std::fs::read_to_string(dir.join("collect-missing.txt")).unwrap();
    assert!(
        missing.contains("job 00002") && missing.contains("job 00004"),
        "{missing}"
    );
    let again = run(&dir, 2);
    assert!(again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("2 of 6 jobs to run"));
    assert!(!job(&dir, 2).join("tmp-999999").exists());
    assert_eq!(whole, collected(&dir));
}

#[test]
fn a_failing_job_is_recorded_and_the_others_finish() {
    let (_, dir) = planned("failure");
    // Corrupted after planning: the job refuses it (hash) and the sweep goes on.
    let scene = job(&dir, 1).join("scene.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, text.replace("n = 20", "n = 2O")).unwrap();
    let out = run(&dir, 2);
    assert_eq!(out.status.code(), Some(1));
    let failed = json(&job(&dir, 1).join("failed.json"));
    assert!(
        failed["error"]
            .as_str()
            .unwrap()
            .contains("changed after planning"),
        "{failed}"
    );
    for i in [0, 2, 3, 4, 5] {
        assert!(job(&dir, i).join("done.json").is_file(), "job {i}");
    }
    let st = status(&dir);
    assert!(
        st.contains("5 done, 1 failed") && st.contains("job 00001 failed: "),
        "{st}"
    );
    let rows = table(&collected(&dir));
    assert_eq!(rows[0]["runs_done"], "2");
    assert_eq!(rows[0]["packing_fraction.n"], "2");
    let missing = std::fs::read_to_string(dir.join("collect-missing.txt")).unwrap();
    assert!(
        missing.starts_with("job 00001 (point 0, run 1): failed: "),
        "{missing}"
    );
    // Failed jobs stay failed on a plain rerun (exit 1 again) and run with --retry-failed.
    assert_eq!(run(&dir, 1).status.code(), Some(1));
    std::fs::write(&scene, &text).unwrap();
    ok(porelab()
        .args(["sweep", "run"])
        .arg(&dir)
        .arg("--retry-failed"));
    assert!(job(&dir, 1).join("done.json").is_file() && !job(&dir, 1).join("failed.json").exists());
    // One job alone, as a Slurm task runs it: exit code 1 on failure.
    std::fs::remove_file(job(&dir, 3).join("done.json")).unwrap();
    std::fs::write(job(&dir, 3).join("scene.toml"), "kind = \"packing\"\n").unwrap();
    let one = porelab()
        .args(["sweep", "job"])
        .arg(&dir)
        .arg("3")
        .output()
        .unwrap();
    assert_eq!(one.status.code(), Some(1));
}

#[test]
fn one_and_two_workers_collect_the_same_bytes() {
    let (_, one) = planned("workers-1");
    let (_, two) = planned("workers-2");
    assert!(run(&one, 1).status.success());
    assert!(run(&two, 2).status.success());
    assert_eq!(collected(&one), collected(&two));
}

#[test]
fn the_slurm_script_lists_only_unfinished_tasks() {
    let (_, dir) = planned("sbatch");
    // Jobs 0, 1 and 4 done; 2, 3 and 5 not.
    for i in [0, 1, 4] {
        ok(porelab()
            .args(["sweep", "job"])
            .arg(&dir)
            .arg(i.to_string()));
    }
    ok(porelab().args(["sweep", "slurm"]).arg(&dir).args([
        "--max-running",
        "2",
        "--partition",
        "short",
        "--time",
        "00:10:00",
    ]));
    let s = std::fs::read_to_string(dir.join("sweep.sbatch")).unwrap();
    let abs = std::fs::canonicalize(&dir).unwrap();
    for line in [
        "#SBATCH --array=2-3,5%2".to_string(),
        format!("#SBATCH --output={}/slurm/%A_%a.out", abs.display()),
        "#SBATCH --partition=short".into(),
        "#SBATCH --time=00:10:00".into(),
        format!("sweep job '{}' \"$SLURM_ARRAY_TASK_ID\"", abs.display()),
    ] {
        assert!(s.contains(&line), "missing {line} in\n{s}");
    }
    let exe = std::fs::canonicalize(env!("CARGO_BIN_EXE_porelab")).unwrap();
    assert!(s.contains(&format!("exec '{}'", exe.display())), "{s}");
    let bad = porelab()
        .args(["sweep", "slurm"])
        .arg(&dir)
        .args(["--time", "10 min"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--time 10 min"));
}

#[test]
fn a_point_that_passes_the_plan_but_fails_at_run_time_is_isolated() {
    // 3e9 particles pass the packing schema; the run refuses them against the memory of the
    // machine it runs on (about 2 kB per particle: 6 TB), which the plan cannot know.
    let root = fresh_dir("runtime-failure");
    std::fs::write(root.join("base.toml"), sweep_scene::BASE_SCENE).unwrap();
    let sweep = root.join("sweep.toml");
    std::fs::write(
        &sweep,
        "scene = \"base.toml\"\n[vary]\n\"particles.n\" = [3000000000, 20]\n",
    )
    .unwrap();
    let dir = root.join("sweep");
    plan(&sweep, &dir);
    let out = run(&dir, 2);
    assert_eq!(out.status.code(), Some(1));
    let failed = json(&job(&dir, 0).join("failed.json"));
    let msg = failed["error"].as_str().unwrap();
    assert!(
        msg.contains("n = 3000000000") && msg.contains("memory"),
        "{msg}"
    );
    assert!(job(&dir, 1).join("done.json").is_file());
    assert!(!job(&dir, 0).join("out").exists());
    let rows = table(&collected(&dir));
    assert_eq!(
        (rows[0]["runs_done"].as_str(), rows[1]["runs_done"].as_str()),
        ("0", "1")
    );
    assert_eq!(rows[0]["packing_fraction.n"], "0");
    assert_eq!(rows[0]["packing_fraction.mean"], "");
}

#[test]
fn a_run_killed_for_real_finishes_on_restart() {
    use std::os::unix::process::CommandExt;
    let (_, dir) = planned("sigkill");
    let (_, reference) = planned("sigkill-reference");
    assert!(run(&reference, 1).status.success());
    // The runner and its job process in one process group, killed together with SIGKILL as
    // soon as two jobs are done (the third is then starting, running or being recorded).
    let mut child = porelab()
        .args(["sweep", "run"])
        .arg(&dir)
        .process_group(0)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while (0..6)
        .filter(|&i| job(&dir, i).join("done.json").is_file())
        .count()
        < 2
    {
        assert!(started.elapsed().as_secs() < 60, "no two jobs done in 60 s");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let group = format!("-{}", child.id());
    ok(std::process::Command::new("kill").args(["-KILL", "--", &group]));
    let _ = child.wait();
    let done = (0..6)
        .filter(|&i| job(&dir, i).join("done.json").is_file())
        .count();
    assert!(
        done < 6,
        "the kill came too late to test anything ({done} done)"
    );
    assert!(run(&dir, 2).status.success());
    for i in 0..6 {
        let names: Vec<String> = std::fs::read_dir(job(&dir, i))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(
            !names.iter().any(|n| n.starts_with("tmp-")),
            "job {i}: {names:?}"
        );
    }
    assert_eq!(collected(&dir), collected(&reference));
}
