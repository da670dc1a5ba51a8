//! Kill and resume through the binary, one test per engine without a test of its own here
//! (deposition, LBM and the magnetic filter; DEM, packing and coupled runs are killed and resumed in their scene
//! tests and tests/sweep.rs): a shortened built-in run to its end; the same run into a fresh
//! folder, killed with SIGKILL at a random moment after its first checkpoint, then started
//! again with the same `--out`; every output file byte-identical to the uninterrupted run's
//! (wall times excepted). A checkpoint written by another scene, or in another checkpoint
//! format, is refused with a message naming the file.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn porelab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_porelab"))
}

/// An empty folder under cargo's test temp dir.
fn fresh_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("resume-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes the built-in `name` with `edits` (each `(from, to)` must occur) to `dir/scene.toml`.
fn shortened(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let out = porelab().args(["run", "--show", name]).output().unwrap();
    assert!(out.status.success());
    let mut text = String::from_utf8(out.stdout).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name} has no `{from}`");
        text = text.replace(from, to);
    }
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `porelab run SCENE --out OUT --quiet --checkpoint-every S`.
fn run(scene: &Path, out: &Path, every_s: &str) -> Command {
    let mut c = porelab();
    c.arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args(["--quiet", "--checkpoint-every", every_s]);
    c
}

/// Runs `cmd`, asserting success.
fn ok(cmd: &mut Command) {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A pseudo-random number in [0, n) from the clock (printed, so a failure can be replayed).
fn random_below(n: u64) -> u64 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .subsec_nanos() as u64;
    nanos.wrapping_mul(0x9E37_79B9_7F4A_7C15) % n.max(1)
}

/// Starts the run, waits for its first checkpoint, kills it with SIGKILL at a random moment
/// within `window` of that, and asserts that it had not finished.
fn kill_after_first_checkpoint(mut cmd: Command, out: &Path, window: Duration) {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !out.join("checkpoint.json").is_file() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its first checkpoint"
        );
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no checkpoint in 300 s"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    let delay = random_below(window.as_millis() as u64);
    eprintln!("SIGKILL {delay} ms after the first checkpoint");
    std::thread::sleep(Duration::from_millis(delay));
    child.kill().unwrap();
    let _ = child.wait();
    assert!(
        !out.join("summary.json").exists(),
        "the kill came too late to test anything (the run had finished)"
    );
    assert!(out.join("checkpoint.json").is_file());
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                v.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    v.sort();
    v
}

/// The text of `file` without wall times: JSON keys `seconds` and `start_seconds` and array
/// entries of quantity `seconds`, the `seconds` column of a CSV table and its `seconds` row
/// (deposition's runs.csv and ensemble.csv).
fn without_wall_times(file: &Path, bytes: Vec<u8>) -> Vec<u8> {
    let name = file.file_name().unwrap().to_string_lossy();
    if name.ends_with(".json") {
        let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        fn strip(v: &mut serde_json::Value) {
            match v {
                serde_json::Value::Object(m) => {
                    m.remove("seconds");
                    m.remove("start_seconds");
                    m.values_mut().for_each(strip);
                }
                serde_json::Value::Array(a) => {
                    a.retain(|e| e.get("quantity").is_none_or(|q| q != "seconds"));
                    a.iter_mut().for_each(strip)
                }
                _ => {}
            }
        }
        strip(&mut v);
        return serde_json::to_vec_pretty(&v).unwrap();
    }
    if name.ends_with(".csv") {
        let text = String::from_utf8(bytes).unwrap();
        let col = text
            .lines()
            .next()
            .and_then(|h| h.split(',').position(|c| c == "seconds"));
        let kept: Vec<String> = text
            .lines()
            .filter(|l| !l.starts_with("seconds,"))
            .map(|l| {
                let mut cells: Vec<&str> = l.split(',').collect();
                if let Some(c) = col {
                    cells.remove(c);
                }
                cells.join(",")
            })
            .collect();
        return kept.join("\n").into_bytes();
    }
    bytes
}

/// The two folders hold the same files with the same bytes (wall times excepted; the
/// deposition's plot, drawn from the same profiles, compared as bytes too).
fn assert_same_outputs(whole: &Path, resumed: &Path) {
    let (a, b) = (files(whole), files(resumed));
    assert_eq!(a, b, "the resumed run wrote other files");
    for f in &a {
        let read = |d: &Path| without_wall_times(f, std::fs::read(d.join(f)).unwrap());
        assert!(read(whole) == read(resumed), "{} differs", f.display());
    }
}

/// Another scene's run into `out` (the scene with a changed title) and a checkpoint of
/// another format are refused, naming the checkpoint file.
fn assert_foreign_checkpoints_refused(scene: &Path, out: &Path, every_s: &str) {
    let other = scene.with_file_name("other.toml");
    let text = std::fs::read_to_string(scene).unwrap();
    std::fs::write(&other, text.replacen("title = \"", "title = \"other ", 1)).unwrap();
    let refused = |scene: &Path, what: &str| {
        let r = run(scene, out, every_s).output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{what}: accepted");
        assert!(
            err.contains(&out.join("checkpoint.json").display().to_string()) && err.contains(what),
            "{err}"
        );
    };
    refused(&other, "different scene");
    let cp = out.join("checkpoint.json");
    let saved = std::fs::read_to_string(&cp).unwrap();
    std::fs::write(&cp, saved.replacen("\"format\":1", "\"format\":99", 1)).unwrap();
    refused(scene, "checkpoint format 99");
    std::fs::write(&cp, saved).unwrap();
}

/// Runs `scene` to its end, then killed and resumed; the outputs agree.
fn kill_and_resume(name: &str, scene: &Path, root: &Path, every_s: &str, window: Duration) {
    let (whole, killed) = (root.join("whole"), root.join("killed"));
    ok(&mut run(scene, &whole, every_s));
    assert!(!whole.join("checkpoint.json").exists());
    kill_after_first_checkpoint(run(scene, &killed, every_s), &killed, window);
    assert_foreign_checkpoints_refused(scene, &killed, every_s);
    ok(&mut run(scene, &killed, every_s));
    assert!(
        !killed.join("checkpoint.json").exists(),
        "{name}: the finished run left its checkpoint"
    );
    assert_same_outputs(&whole, &killed);
}

/// The built-in platelets (Perram-Wertheim pairs, rotations), 200 per run in 4 runs on
/// parallel threads, each saving every 20 ms.
#[test]
fn a_killed_deposition_resumes_to_the_same_outputs() {
    let root = fresh_dir("deposition");
    let scene = shortened(
        &root,
        "deposition-platelets",
        &[("particles = 600", "particles = 200")],
    );
    kill_and_resume(
        "deposition",
        &scene,
        &root,
        "0.02",
        Duration::from_millis(400),
    );
}

/// The built-in pressure-driven channel (inlet and outlet planes), on a finer lattice with a
/// tighter tolerance so that it runs for seconds, checkpointing at every check.
#[test]
fn a_killed_lbm_run_resumes_to_the_same_outputs() {
    let root = fresh_dir("lbm");
    let scene = shortened(&root, "lbm-pressure-channel", &[]);
    kill_and_resume("lbm", &scene, &root, "0", Duration::from_millis(400));
}

/// The built-in magnetic filter on a coarser flow lattice (the flow is computed again on
/// resume), checkpointing after every step of the particles.
#[test]
fn a_killed_filter_run_resumes_to_the_same_outputs() {
    let root = fresh_dir("filter");
    let scene = shortened(
        &root,
        "filter-quick",
        &[("resolution = 24", "resolution = 12")],
    );
    kill_and_resume("filter", &scene, &root, "0", Duration::from_millis(400));
}
