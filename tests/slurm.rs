//! A real Slurm job array: submits the 2 points x 3 runs sweep of tests/common/sweep_scene.rs
//! through `porelab sweep slurm --submit`, waits for the array with squeue (at most 5 minutes),
//! checks every task's state and output file, collects, and compares collected.csv byte for
//! byte with a local run of the same sweep. It runs only where a cluster answers (`sinfo`;
//! .ci/slurm-test.sh starts a one-node one here) and otherwise prints why it skipped.

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

#[test]
fn a_slurm_job_array_collects_the_same_table_as_a_local_run() {
    if let Some(why) = no_cluster() {
        // Straight to the stderr handle: the test harness captures print! and eprint!.
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "SKIPPED tests/slurm.rs: {why}");
        return;
    }
    let root = fresh_dir("slurm");
    let sweep = write_sweep(&root);
    let (on_slurm, local) = (root.join("on-slurm"), root.join("local"));
    for d in [&on_slurm, &local] {
        plan(&sweep, d);
    }
    let id = ok_out(porelab().args(["sweep", "slurm"]).arg(&on_slurm).args([
        "--max-running",
        "2",
        "--time",
        "00:05:00",
        "--submit",
    ]));
    let id = id.trim().to_string();
    assert!(
        !id.is_empty() && id.bytes().all(|b| b.is_ascii_digit()),
        "job id {id:?}"
    );
    println!("submitted array job {id}");
    // Meanwhile the same sweep locally.
    ok_out(porelab().args(["sweep", "run"]).arg(&local));
    let started = Instant::now();
    loop {
        let q = ok_out(Command::new("squeue").args(["-h", "-j", &id, "-o", "%i %T"]));
        if q.trim().is_empty() {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "array {id} still queued after 5 minutes: {q}"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    println!(
        "array {id} left the queue after {:.1} s",
        started.elapsed().as_secs_f64()
    );
    // Every task ran under Slurm and ended COMPLETED with exit code 0 (scontrol keeps finished
    // jobs for MinJobAge; the test cluster sets 600 s).
    let show = ok_out(Command::new("scontrol").args(["show", "job", &id]));
    let tasks: Vec<&str> = show
        .split("\n\n")
        .filter(|rec| rec.contains("ArrayTaskId="))
        .collect();
    assert_eq!(tasks.len(), 6, "{show}");
    for t in &tasks {
        assert!(
            t.contains("JobState=COMPLETED") && t.contains(" ExitCode=0:0"),
            "{t}"
        );
    }
    for k in 0..6 {
        let out = on_slurm.join("slurm").join(format!("{id}_{k}.out"));
        let text = std::fs::read_to_string(&out).unwrap_or_else(|e| panic!("{out:?}: {e}"));
        assert!(
            text.contains(&format!("porelab sweep job {k:05}: done")),
            "{text}"
        );
    }
    let status = ok_out(porelab().args(["sweep", "status"]).arg(&on_slurm));
    assert!(status.contains("6 done, 0 failed"), "{status}");
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
