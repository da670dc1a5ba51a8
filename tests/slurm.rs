//! Real Slurm job arrays. The first test submits the 2 points x 3 runs sweep of
//! tests/common/sweep_scene.rs through `porelab sweep slurm --submit`, waits for the arrays
//! with squeue (at most 5 minutes), checks every task's state and output file, collects, and
//! compares collected.csv byte for byte with a local run of the same sweep. The second runs a
//! sweep of more jobs than the cluster's MaxArraySize through faults: the submitting process
//! killed mid-way, one task cancelled, one told its time limit is near, a resubmission while
//! the arrays still run; it must end with the local table. They run only where a cluster
//! answers (`sinfo`; .ci/slurm-test.sh starts a one-node one here, MaxArraySize 5) and
//! otherwise print why they skipped.

#[path = "common/sweep_scene.rs"]
mod sweep_scene;

use std::process::Command;
use std::time::{Duration, Instant};
use sweep_scene::{fresh_dir, ok, plan, porelab, write_sweep};

/// Why no cluster can be used, or None when `sinfo` answers with a node up.
fn no_cluster() -> Option<String> {
    match Command::new("sinfo").args(["-h", "-o", "%T"]).output() {
        Err(e) => Some(format!(
            "sinfo cannot be run ({e}); .ci/slurm-test.sh starts a cluster"
        )),
        Ok(o) if !o.status.success() => Some(format!(
            "sinfo failed ({}): {}",
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Ok(o) => {
            let states = String::from_utf8_lossy(&o.stdout).into_owned();
            let usable = states.lines().any(|s| {
                ["idle", "mixed", "allocated"]
                    .iter()
                    .any(|u| s.starts_with(u))
            });
            (!usable).then(|| format!("sinfo shows no usable node (states: {:?})", states.trim()))
        }
    }
}

/// The stdout of a command that must succeed.
fn ok_out(cmd: &mut Command) -> String {
    ok(cmd).0
}

/// Prints a skip reason straight to the stderr handle (the harness captures eprint!).
fn skip(why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED tests/slurm.rs: {why}");
}

/// The cluster's MaxArraySize.
fn max_array_size() -> usize {
    let conf = ok_out(Command::new("scontrol").args(["show", "config"]));
    conf.lines()
        .find_map(|l| {
            let (k, v) = l.split_once('=')?;
            (k.trim() == "MaxArraySize").then(|| v.trim().parse().unwrap())
        })
        .expect("scontrol show config names MaxArraySize")
}

/// `porelab sweep slurm DIR ARGS --submit`: the (array id, first job) of each array, read
/// from its stdout (one id per array, then the collect job's with --collect) and
/// DIR/slurm/arrays.csv.
fn submit(dir: &std::path::Path, args: &[&str]) -> Vec<(String, usize)> {
    let out = ok_out(
        porelab()
            .args(["sweep", "slurm"])
            .arg(dir)
            .args(args)
            .arg("--submit"),
    );
    let mut ids: Vec<String> = out.lines().map(|l| l.trim().to_string()).collect();
    for id in &ids {
        assert!(
            !id.is_empty() && id.bytes().all(|b| b.is_ascii_digit()),
            "job id {id:?}"
        );
    }
    if args.contains(&"--collect") {
        ids.pop().expect("the collect job's id");
    }
    let table = std::fs::read_to_string(dir.join("slurm/arrays.csv")).unwrap();
    ids.iter()
        .map(|id| {
            let base = table
                .lines()
                .find_map(|l| l.strip_prefix(&format!("{id},")))
                .unwrap_or_else(|| panic!("{id} not in arrays.csv:\n{table}"));
            (id.clone(), base.parse().unwrap())
        })
        .collect()
}

/// Waits (at most 5 minutes) until no task of `arrays` is queued or running.
fn wait_for(arrays: &[(String, usize)]) {
    let started = Instant::now();
    for (id, _) in arrays {
        loop {
            let q = ok_out(Command::new("squeue").args(["-h", "-j", id, "-o", "%i %T"]));
            if q.trim().is_empty() {
                break;
            }
            assert!(
                started.elapsed() < Duration::from_secs(300),
                "array {id} still queued after 5 minutes: {q}"
            );
            std::thread::sleep(Duration::from_millis(300));
        }
    }
    println!(
        "arrays left the queue after {:.1} s",
        started.elapsed().as_secs_f64()
    );
}

/// Waits (at most 3 minutes) until `cond` holds.
fn until(what: &str, mut cond: impl FnMut() -> bool) {
    let started = Instant::now();
    while !cond() {
        assert!(
            started.elapsed() < Duration::from_secs(180),
            "not within 3 minutes: {what}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_slurm_job_array_collects_the_same_table_as_a_local_run() {
    if let Some(why) = no_cluster() {
        skip(&why);
        return;
    }
    let root = fresh_dir("slurm");
    let sweep = write_sweep(&root);
    let (on_slurm, local) = (root.join("on-slurm"), root.join("local"));
    for d in [&on_slurm, &local] {
        plan(&sweep, d);
    }
    let arrays = submit(&on_slurm, &["--max-running", "2", "--time", "00:05:00"]);
    // Meanwhile the same sweep locally.
    ok_out(porelab().args(["sweep", "run"]).arg(&local));
    wait_for(&arrays);
    // Every task ran under Slurm and ended COMPLETED with exit code 0 (scontrol keeps finished
    // jobs for MinJobAge; the test cluster sets 600 s).
    let mut ran = 0;
    for (id, base) in &arrays {
        let show = ok_out(Command::new("scontrol").args(["show", "job", id]));
        let tasks: Vec<&str> = show
            .split("\n\n")
            .filter(|rec| rec.contains("ArrayTaskId="))
            .collect();
        for t in &tasks {
            assert!(
                t.contains("JobState=COMPLETED") && t.contains(" ExitCode=0:0"),
                "{t}"
            );
        }
        for k in 0..tasks.len() {
            let out = on_slurm.join("slurm").join(format!("{id}_{k}.out"));
            let text = std::fs::read_to_string(&out).unwrap_or_else(|e| panic!("{out:?}: {e}"));
            assert!(
                text.contains(&format!("porelab sweep job {:05}: done", base + k)),
                "{text}"
            );
        }
        ran += tasks.len();
    }
    assert_eq!(ran, 6);
    let status = ok_out(porelab().args(["sweep", "status"]).arg(&on_slurm));
    assert!(status.contains("6 done, 0 running, 0 failed"), "{status}");
    for d in [&on_slurm, &local] {
        ok_out(porelab().args(["sweep", "collect"]).arg(d));
    }
    let a = std::fs::read(on_slurm.join("collected.csv")).unwrap();
    let b = std::fs::read(local.join("collected.csv")).unwrap();
    assert!(a == b, "Slurm and local collected.csv differ");
    // Nothing left to submit.
    ok_out(porelab().args(["sweep", "slurm"]).arg(&on_slurm));
    assert!(!on_slurm.join("sweep.sbatch").exists());
}

/// The job folder of job `i`.
fn job(dir: &std::path::Path, i: usize) -> std::path::PathBuf {
    dir.join("jobs").join(format!("{i:05}"))
}

/// The claim of job `i` when a Slurm task holds it.
fn slurm_claim(dir: &std::path::Path, i: usize) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(job(dir, i).join("claim.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["slurm_job"].is_string().then_some(v)
}

/// The sweep `sweep_toml` of the base scene planned twice under a fresh `name` folder, for
/// Slurm and for the local run it must agree with, which starts now in the background:
/// (Slurm folder, local folder, the local run).
fn slurm_and_local(
    name: &str,
    sweep_toml: &str,
) -> (std::path::PathBuf, std::path::PathBuf, std::process::Child) {
    let root = fresh_dir(name);
    std::fs::write(root.join("base.toml"), sweep_scene::BASE_SCENE).unwrap();
    let sweep = root.join("sweep.toml");
    std::fs::write(&sweep, sweep_toml).unwrap();
    let (on_slurm, local) = (root.join("on-slurm"), root.join("local"));
    for d in [&on_slurm, &local] {
        plan(&sweep, d);
    }
    let reference = porelab()
        .args(["sweep", "run"])
        .arg(&local)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    (on_slurm, local, reference)
}

/// Collects both folders (the local run ended well) and compares their tables byte for byte.
fn assert_same_table(
    on_slurm: &std::path::Path,
    local: &std::path::Path,
    mut reference: std::process::Child,
) {
    assert!(reference.wait().unwrap().success());
    for d in [on_slurm, local] {
        ok_out(porelab().args(["sweep", "collect"]).arg(d));
    }
    let a = std::fs::read(on_slurm.join("collected.csv")).unwrap();
    let b = std::fs::read(local.join("collected.csv")).unwrap();
    assert!(a == b, "Slurm and local collected.csv differ");
}

#[test]
fn a_sweep_larger_than_max_array_size_survives_faults_to_the_local_table() {
    if let Some(why) = no_cluster() {
        skip(&why);
        return;
    }
    // 3 points x 2 runs; the first point's jobs (600 spheres, 10 halvings of Delta V) take
    // about 20 s, so that they can be stopped mid-way, the others (20 and 30 spheres) well
    // under a second.
    let jobs = 6;
    let max = max_array_size();
    if max >= jobs {
        skip(&format!(
            "the cluster's MaxArraySize {max} holds all {jobs} jobs in one array \
             (.ci/slurm-test.sh sets 5)"
        ));
        return;
    }
    let (on_slurm, local, reference) = slurm_and_local(
        "slurm-faults",
        "scene = \"base.toml\"\ncombine = \"zip\"\nruns_per_point = 2\nbase_seed = 3\n\
         [vary]\n\"particles.n\" = [600, 20, 30]\n\"mcm.halvings\" = [10, 2, 2]\n",
    );

    // 1. A local submitter killed with SIGKILL mid-way through job 0: its job process gets
    //    SIGTERM (PR_SET_PDEATHSIG), writes its checkpoint and records the cancel.
    let mut submitter = porelab()
        .args(["sweep", "run"])
        .arg(&on_slurm)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    until("job 0 checkpointed by the local submitter", || {
        job(&on_slurm, 0).join("work/checkpoint.json").is_file()
    });
    submitter.kill().unwrap();
    submitter.wait().unwrap();
    until("job 0 recorded as cancelled", || {
        job(&on_slurm, 0).join("interrupted.json").is_file()
    });

    // 2. Six jobs in arrays of at most MaxArraySize task ids, one task at a time per array.
    let arrays = submit(&on_slurm, &["--max-running", "1", "--time", "00:30:00"]);
    assert_eq!(arrays.len(), jobs.div_ceil(max), "{arrays:?}");
    assert_eq!(arrays[0].1, 0);
    // A resubmission while they run submits nothing: every job is queued or running.
    let again = porelab()
        .args(["sweep", "slurm"])
        .arg(&on_slurm)
        .arg("--submit")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(again.status.success(), "{err}");
    assert_eq!(String::from_utf8_lossy(&again.stdout).trim(), "", "{err}");
    assert!(
        err.contains("nothing to submit") && err.contains("still queued"),
        "{err}"
    );

    // 3. Job 0's task, resumed from the checkpoint, cancelled (scancel: SIGTERM).
    let (first, _) = &arrays[0];
    until("job 0 running under Slurm", || {
        slurm_claim(&on_slurm, 0).is_some()
    });
    until("job 0 checkpointed under Slurm", || {
        job(&on_slurm, 0).join("work/checkpoint.json").is_file()
    });
    ok(Command::new("scancel").arg(format!("{first}_0")));
    // 4. Job 1's task told that its time limit is near: the SIGUSR1 that the script's
    //    `--signal=B:USR1@S` makes Slurm send S seconds before the limit, sent now.
    until("job 1 running under Slurm", || {
        slurm_claim(&on_slurm, 1).is_some()
    });
    // (scancel 22.05 may exit 1 with no message after delivering a signal to an array
    // task's batch step; the job's record below says whether it arrived.)
    let _ = Command::new("scancel")
        .args(["--signal=USR1", "--batch"])
        .arg(format!("{first}_1"))
        .status();
    wait_for(&arrays);
    let out = porelab()
        .args(["sweep", "status"])
        .arg(&on_slurm)
        .output()
        .unwrap();
    let st = String::from_utf8_lossy(&out.stdout);
    assert!(
        st.contains("4 done, 0 running, 0 failed, 1 timed out, 1 cancelled, 0 killed, 0 pending"),
        "{st}"
    );
    assert_eq!(out.status.code(), Some(0), "{st}");
    let rec = |i: usize| -> serde_json::Value {
        serde_json::from_str(
            &std::fs::read_to_string(job(&on_slurm, i).join("interrupted.json")).unwrap(),
        )
        .unwrap()
    };
    assert_eq!(rec(0)["reason"], "cancelled (SIGTERM)");
    assert_eq!(rec(1)["reason"], "timed out");
    for i in [0, 1] {
        assert!(
            job(&on_slurm, i).join("work/checkpoint.json").is_file(),
            "job {i}"
        );
    }
    // The partial set is refused.
    let partial = porelab()
        .args(["sweep", "collect"])
        .arg(&on_slurm)
        .output()
        .unwrap();
    assert_eq!(partial.status.code(), Some(2));

    // 5. Resubmitted: only jobs 0 and 1, both resumed from their checkpoints.
    let retry = submit(&on_slurm, &["--time", "00:30:00", "--collect"]);
    assert_eq!(retry.len(), 1, "{retry:?}");
    assert_eq!(retry[0].1, 0);
    wait_for(&retry);
    for (k, i) in [(0, 0), (1, 1)] {
        let text = std::fs::read_to_string(
            on_slurm
                .join("slurm")
                .join(format!("{}_{k}.out", retry[0].0)),
        )
        .unwrap();
        assert!(
            text.contains(&format!("porelab sweep job {i:05}: resuming from"))
                && text.contains(&format!("porelab sweep job {i:05}: done")),
            "{text}"
        );
    }
    let st = ok_out(porelab().args(["sweep", "status"]).arg(&on_slurm));
    assert!(st.contains("6 done, 0 running, 0 failed"), "{st}");
    for i in 0..jobs {
        let d = job(&on_slurm, i);
        assert!(
            !d.join("failed.json").exists() && !d.join("interrupted.json").exists(),
            "job {i}"
        );
        assert!(d.join("out/summary.json").is_file(), "job {i}");
    }
    // The collect job submitted with --collect ran after the array (afterany).
    until("the collect job's table", || {
        on_slurm.join("collected.csv").is_file()
    });
    assert_same_table(&on_slurm, &local, reference);
}

/// Slurm's own time limit: one task of about a minute of work under `--time 00:01:00`
/// with `--signal-before 55` and `--requeue`. Slurm itself sends SIGUSR1 when less than 55 s
/// are left (its time-limit check comes every few seconds to half a minute); the job writes its
/// checkpoint, records "timed out" and requeues itself; the requeued task resumes from the
/// checkpoint (as often as it takes) and the sweep ends with the local table.
#[test]
fn slurm_times_a_task_out_and_it_requeues_itself_to_the_local_table() {
    if let Some(why) = no_cluster() {
        skip(&why);
        return;
    }
    // 600 spheres and 13 halvings of Delta V: about 65 s of one core's work, longer than the
    // 5 to 35 s after which the warning comes
    let (on_slurm, local, reference) = slurm_and_local(
        "slurm-timeout",
        "scene = \"base.toml\"\nruns_per_point = 1\nbase_seed = 7\n\
         [vary]\n\"particles.n\" = [600]\n\"mcm.halvings\" = [13]\n",
    );
    let arrays = submit(
        &on_slurm,
        &["--time", "00:01:00", "--signal-before", "55", "--requeue"],
    );
    let task = format!("{}_0", arrays[0].0);
    let started = Instant::now();
    loop {
        let show = ok_out(Command::new("scontrol").args(["show", "job", &task]));
        if ["COMPLETED", "FAILED", "CANCELLED", "TIMEOUT"]
            .iter()
            .any(|s| show.contains(&format!("JobState={s} ")))
        {
            break;
        }
        // Slurm holds a requeued task for its requeue delay (BeginTime, about two minutes)
        // before it may start again: the test lets it start at once
        if show.contains("JobState=PENDING") && show.contains("Reason=BeginTime") {
            let _ = Command::new("scontrol")
                .args(["update", &format!("JobId={task}"), "StartTime=now"])
                .status();
        }
        assert!(
            started.elapsed() < Duration::from_secs(900),
            "task {task} not finished within 15 minutes: {show}"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let show = ok_out(Command::new("scontrol").args(["show", "job", &task]));
    assert!(
        show.contains("JobState=COMPLETED") && show.contains(" ExitCode=0:0"),
        "{show}"
    );
    let restarts: u32 = show
        .split_whitespace()
        .find_map(|w| w.strip_prefix("Restarts="))
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("no Restarts in {show}"));
    assert!(restarts >= 1, "the task never requeued itself: {show}");
    println!(
        "{task}: {restarts} requeue(s), done after {:.0} s",
        started.elapsed().as_secs_f64()
    );
    // the log of every run of the task, appended: Slurm's warning taken, and resumed
    let log = std::fs::read_to_string(on_slurm.join("slurm").join(format!("{task}.out"))).unwrap();
    for said in [
        "porelab sweep job 00000: timed out",
        "porelab sweep job 00000: resuming from",
        "porelab sweep job 00000: done",
    ] {
        assert!(log.contains(said), "{said}: {log}");
    }
    let st = ok_out(porelab().args(["sweep", "status"]).arg(&on_slurm));
    assert!(st.contains("1 done, 0 running, 0 failed"), "{st}");
    assert_same_table(&on_slurm, &local, reference);
}
