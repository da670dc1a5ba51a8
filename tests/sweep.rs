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

/// What `porelab sweep status DIR` prints, and its exit code.
fn status(dir: &Path) -> (String, Option<i32>) {
    let out = porelab()
        .args(["sweep", "status"])
        .arg(dir)
        .output()
        .unwrap();
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        out.status.code(),
    )
}

fn collected(dir: &Path) -> String {
    ok(porelab().args(["sweep", "collect"]).arg(dir));
    std::fs::read_to_string(dir.join("collected.csv")).unwrap()
}

/// `collect --partial`: the table of the finished jobs while others are missing; a plain
/// `collect` must refuse the same set.
fn collected_partial(dir: &Path) -> String {
    let plain = porelab()
        .args(["sweep", "collect"])
        .arg(dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&plain.stderr);
    assert_eq!(plain.status.code(), Some(2), "{err}");
    assert!(
        err.contains("refused") && err.contains("--partial"),
        "{err}"
    );
    ok(porelab().args(["sweep", "collect", "--partial"]).arg(dir));
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
    // Job 2 killed mid-way by an older porelab: a stale tmp folder with partial output, no
    // out/, no record.
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
    let (st, code) = status(&dir);
    assert!(
        st.contains("4 done, 0 running, 0 failed, 0 timed out, 0 cancelled, 1 killed, 1 pending")
            && code == Some(0),
        "{st}"
    );
    // Collect meanwhile refuses the partial set; with --partial it lists both and averages
    // over the rest only.
    let partial = table(&collected_partial(&dir));
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
    let (st, code) = status(&dir);
    assert!(
        st.contains("5 done, 0 running, 1 failed") && st.contains("job 00001 failed: "),
        "{st}"
    );
    assert_eq!(code, Some(1), "status exits 1 when a job failed");
    // Nothing left to submit, but not "every job is finished": exit 1, the failure named.
    let slurm = porelab()
        .args(["sweep", "slurm"])
        .arg(&dir)
        .args(["--max-array-size", "1001"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&slurm.stderr);
    assert_eq!(slurm.status.code(), Some(1), "{err}");
    assert!(
        err.contains("nothing to submit")
            && err.contains("1 failed")
            && err.contains("--retry-failed"),
        "{err}"
    );
    let rows = table(&collected_partial(&dir));
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
    std::fs::remove_dir_all(job(&dir, 3).join("out")).unwrap();
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
    let (cmds, _) = ok(porelab().args(["sweep", "slurm"]).arg(&dir).args([
        "--max-running",
        "2",
        "--partition",
        "short",
        "--time",
        "00:10:00",
        "--signal-before",
        "90",
        "--mem",
        "4G",
        "--account",
        "proj-1",
        "--qos",
        "normal",
        "--gres",
        "gpu:1",
        "--requeue",
        "--max-array-size",
        "1001",
    ]));
    let s = std::fs::read_to_string(dir.join("sweep.sbatch")).unwrap();
    let abs = std::fs::canonicalize(&dir).unwrap();
    for line in [
        format!("#SBATCH --output={}/slurm/%A_%a.out", abs.display()),
        "#SBATCH --partition=short".into(),
        "#SBATCH --time=00:10:00".into(),
        "#SBATCH --signal=B:USR1@90".into(),
        "#SBATCH --mem=4G".into(),
        "#SBATCH --account=proj-1".into(),
        "#SBATCH --qos=normal".into(),
        "#SBATCH --gres=gpu:1".into(),
        "#SBATCH --requeue".into(),
        format!(
            "sweep job '{}' \"$((${{PORELAB_JOB_BASE:-0}} + SLURM_ARRAY_TASK_ID))\" --threads 1 \
             --requeue",
            abs.display()
        ),
    ] {
        assert!(s.contains(&line), "missing {line} in\n{s}");
    }
    let script = abs.join("sweep.sbatch");
    assert_eq!(
        cmds.trim(),
        format!(
            "sbatch --array=0-1,3%2 --export=ALL,PORELAB_JOB_BASE=2 {}",
            script.display()
        )
    );
    // A cluster whose MaxArraySize is 2 (task ids 0 and 1): one array per block of ids.
    let (cmds, _) = ok(porelab()
        .args(["sweep", "slurm"])
        .arg(&dir)
        .args(["--max-array-size", "2"]));
    let arrays: Vec<&str> = cmds.lines().collect();
    assert_eq!(
        arrays,
        [
            format!(
                "sbatch --array=0-1 --export=ALL,PORELAB_JOB_BASE=2 {}",
                script.display()
            ),
            format!(
                "sbatch --array=0 --export=ALL,PORELAB_JOB_BASE=5 {}",
                script.display()
            ),
        ]
    );
    assert!(!std::fs::read_to_string(&script)
        .unwrap()
        .contains("--requeue"));
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
    let rows = table(&collected_partial(&dir));
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
    // This test process becomes the subreaper of the killed runner's job processes and never
    // waits for them, as a container init that does not reap: they stay zombies with their
    // /proc entries, which must not pass for live claims.
    assert_eq!(
        unsafe { libc::prctl(libc::PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) },
        0
    );
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
    let rerun = run(&dir, 2);
    assert!(
        rerun.status.success(),
        "the rerun failed: {}",
        String::from_utf8_lossy(&rerun.stderr)
    );
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

/// The claim a process holds on a job folder, as `porelab sweep job` writes it.
fn claim_of(pid: u32) -> String {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let after = &stat[stat.rfind(')').unwrap() + 1..];
    let start: u64 = after.split_whitespace().nth(19).unwrap().parse().unwrap();
    let read = |p: &str| std::fs::read_to_string(p).unwrap().trim().to_string();
    serde_json::json!({
        "host": read("/proc/sys/kernel/hostname"),
        "pid": pid,
        "start_ticks": start,
        "boot_id": read("/proc/sys/kernel/random/boot_id"),
        "slurm_job": null,
    })
    .to_string()
}

#[test]
fn a_job_claimed_by_a_live_process_is_never_run_twice() {
    let (_, dir) = planned("claims");
    // Job 0 held by a live process (a sleeping child stands in for a running job).
    let mut holder = std::process::Command::new("sleep")
        .arg("60")
        .spawn()
        .unwrap();
    std::fs::write(job(&dir, 0).join("claim.json"), claim_of(holder.id())).unwrap();
    let (o, e) = ok(porelab().args(["sweep", "job"]).arg(&dir).arg("0"));
    assert!(
        e.contains("running in pid") && e.contains("left to it"),
        "{o}{e}"
    );
    assert!(!job(&dir, 0).join("done.json").exists());
    let (st, _) = status(&dir);
    assert!(
        st.contains("1 running") && st.contains("job 00000 running: pid"),
        "{st}"
    );
    // `sweep run` leaves it too, and says the sweep is not complete.
    let out = run(&dir, 2);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("5 of 6 jobs to run"));
    assert!(!job(&dir, 0).join("done.json").exists());
    // The holder dies: its claim is dead and taken over (the same pid with another start
    // time, a reused pid, would be dead as well).
    holder.kill().unwrap();
    holder.wait().unwrap();
    let (st, _) = status(&dir);
    assert!(st.contains("1 killed"), "{st}");
    assert!(run(&dir, 1).status.success());
    assert!(
        !job(&dir, 0).join("claim.json").exists(),
        "released at the end"
    );

    // Two runners started together on a fresh sweep: every job runs exactly once, no folder
    // ends with both records.
    let (_, reference) = planned("claims-reference");
    assert!(run(&reference, 1).status.success());
    let (_, fresh) = planned("claims-race");
    let spawn = || {
        porelab()
            .args(["sweep", "run"])
            .arg(&fresh)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (r1, r2) = (spawn(), spawn());
    for r in [r1, r2] {
        let out = r.wait_with_output().unwrap();
        // One runner may find a job still held by the other at its end: exit 1 is allowed.
        assert!(matches!(out.status.code(), Some(0 | 1)), "{out:?}");
    }
    for i in 0..6 {
        let d = job(&fresh, i);
        assert!(d.join("done.json").is_file(), "job {i}");
        assert!(!d.join("failed.json").exists(), "job {i}");
        let log = std::fs::read_to_string(d.join("log.txt")).unwrap();
        assert_eq!(
            log.matches(": done (").count(),
            1,
            "job {i} ran twice:\n{log}"
        );
    }
    assert_eq!(collected(&fresh), collected(&reference));
}

/// A packing sweep of one job that takes seconds (600 spheres, 10 halvings of Delta V: about
/// 20 s on a busy 2-core machine), with a checkpoint after its first halving.
fn slow_sweep(name: &str) -> PathBuf {
    let root = fresh_dir(name);
    std::fs::write(root.join("base.toml"), sweep_scene::BASE_SCENE).unwrap();
    let sweep = root.join("sweep.toml");
    std::fs::write(
        &sweep,
        "scene = \"base.toml\"\ncombine = \"zip\"\n[vary]\n\"particles.n\" = [600]\n\
         \"mcm.halvings\" = [10]\n",
    )
    .unwrap();
    let dir = root.join("sweep");
    plan(&sweep, &dir);
    dir
}

#[test]
fn a_stopped_run_ends_its_jobs_which_resume_from_their_checkpoint() {
    let dir = slow_sweep("sigterm");
    let reference = slow_sweep("sigterm-reference");
    assert!(run(&reference, 1).status.success());
    let runner = porelab()
        .args(["sweep", "run"])
        .arg(&dir)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // SIGTERM to the runner alone once its first job wrote a checkpoint.
    let ckpt = job(&dir, 0).join("work").join("checkpoint.json");
    let started = std::time::Instant::now();
    while !ckpt.is_file() {
        assert!(
            started.elapsed().as_secs() < 120,
            "no checkpoint within 120 s"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let claim: serde_json::Value = json(&job(&dir, 0).join("claim.json"));
    let job_pid = claim["pid"].as_u64().unwrap();
    ok(std::process::Command::new("kill").args(["-TERM", &runner.id().to_string()]));
    let out = runner.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(128 + 15), "{err}");
    assert!(err.contains("stopped by SIGTERM"), "{err}");
    // Its job process is gone, recorded as cancelled, checkpoint kept.
    assert!(
        !Path::new(&format!("/proc/{job_pid}")).exists(),
        "job process {job_pid} still runs"
    );
    let rec = json(&job(&dir, 0).join("interrupted.json"));
    assert_eq!(rec["reason"], "cancelled (SIGTERM)", "{rec}");
    assert!(ckpt.is_file());
    assert!(!job(&dir, 0).join("done.json").exists());
    let (st, _) = status(&dir);
    assert!(st.contains("1 cancelled"), "{st}");
    // The next run resumes job 0 from its checkpoint and ends with the uninterrupted table.
    assert!(run(&dir, 1).status.success());
    let log = std::fs::read_to_string(job(&dir, 0).join("log.txt")).unwrap();
    assert!(log.contains("resum"), "job 0 did not resume:\n{log}");
    assert_eq!(collected(&dir), collected(&reference));
}

#[test]
fn collect_refuses_mixed_versions_and_unconverged_runs() {
    let (_, dir) = planned("mixed");
    assert!(run(&dir, 1).status.success());
    let whole = collected(&dir);
    // Job 1 recorded by another porelab version.
    let done = job(&dir, 1).join("done.json");
    let original = std::fs::read_to_string(&done).unwrap();
    let mut v = json(&done);
    v["porelab_version"] = "0.0.1".into();
    std::fs::write(&done, v.to_string()).unwrap();
    let out = porelab()
        .args(["sweep", "collect"])
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("several porelab versions") && err.contains("0.0.1 (1 jobs)"),
        "{err}"
    );
    ok(porelab().args(["sweep", "collect", "--partial"]).arg(&dir));
    std::fs::write(&done, original).unwrap();
    // Job 4 did not converge (its packing did not jam): left out and named.
    let summary = job(&dir, 4).join("out/summary.json");
    let mut s = json(&summary);
    s["jammed"] = false.into();
    std::fs::write(&summary, s.to_string()).unwrap();
    let rows = table(&collected_partial(&dir));
    assert_eq!(rows[1]["runs_done"], "2");
    let missing = std::fs::read_to_string(dir.join("collect-missing.txt")).unwrap();
    assert!(
        missing.contains("job 00004") && missing.contains("unconverged"),
        "{missing}"
    );
    s["jammed"] = true.into();
    std::fs::write(&summary, s.to_string()).unwrap();
    assert_eq!(collected(&dir), whole);
}
