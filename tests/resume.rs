//! Kill and resume through the binary, one test per engine (deposition, LBM, the magnetic
//! filter, Brownian capture, the permeability ladder, DEM, coupled and packing runs): a
//! shortened built-in run to its end; the same run into a fresh
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
/// within `window` of that, and asserts that it had not finished (written `last_output`).
fn kill_after_first_checkpoint(cmd: Command, out: &Path, window: Duration, last_output: &str) {
    let checkpoint = out.join("checkpoint.json");
    kill_after(cmd, || checkpoint.is_file(), window, &out.join(last_output));
    assert!(checkpoint.is_file());
}

/// Starts the run, waits until `saved` (it has saved some of its work), kills it with SIGKILL
/// at a random moment within `window` of that, and asserts that it had not written `last`.
fn kill_after(mut cmd: Command, saved: impl Fn() -> bool, window: Duration, last: &Path) {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !saved() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it saved anything"
        );
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "nothing saved in 300 s"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    let delay = random_below(window.as_millis() as u64);
    eprintln!("SIGKILL {delay} ms after the first save");
    std::thread::sleep(Duration::from_millis(delay));
    child.kill().unwrap();
    let _ = child.wait();
    assert!(
        !last.exists(),
        "the kill came too late to test anything (the run had finished)"
    );
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

/// The text of `file` without wall times: JSON keys `seconds` and `start_seconds`, the shares
/// of wall time (`timing`, `coupling_share` of a coupled run, `neighbour_share` of a DEM run)
/// and array entries of quantity `seconds`, the `seconds` (or `seconds_s`) column of a CSV table and its
/// `seconds` row (deposition's runs.csv and ensemble.csv).
fn without_wall_times(file: &Path, bytes: Vec<u8>) -> Vec<u8> {
    let name = file.file_name().unwrap().to_string_lossy();
    if name.ends_with(".json") {
        let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        fn strip(v: &mut serde_json::Value) {
            match v {
                serde_json::Value::Object(m) => {
                    for k in [
                        "seconds",
                        "start_seconds",
                        "timing",
                        "coupling_share",
                        "neighbour_share",
                    ] {
                        m.remove(k);
                    }
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
        let col = text.lines().next().and_then(|h| {
            h.split(',')
                .position(|c| c == "seconds" || c == "seconds_s")
        });
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

/// `cmd` fails, naming the checkpoint `cp` and saying `what`.
fn refused(cmd: &mut Command, cp: &Path, what: &str) {
    let r = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success(), "{what}: accepted");
    assert!(
        err.contains(&cp.display().to_string()) && err.contains(what),
        "{what}: {err}"
    );
}

/// Another scene's run into `out` (the scene with a changed title) and a checkpoint of
/// another format are refused, naming the checkpoint file.
fn assert_foreign_checkpoints_refused(scene: &Path, out: &Path, every_s: &str) {
    let other = scene.with_file_name("other.toml");
    let text = std::fs::read_to_string(scene).unwrap();
    std::fs::write(&other, text.replacen("title = \"", "title = \"other ", 1)).unwrap();
    let cp = out.join("checkpoint.json");
    let refused = |scene: &Path, what: &str| refused(&mut run(scene, out, every_s), &cp, what);
    refused(&other, "different scene");
    let saved = std::fs::read_to_string(&cp).unwrap();
    std::fs::write(&cp, with_format_99(&saved)).unwrap();
    refused(scene, "checkpoint format 99");
    std::fs::write(&cp, saved).unwrap();
}

/// The checkpoint text `saved` with its format number (whatever the engine's) made 99.
fn with_format_99(saved: &str) -> String {
    let at = saved
        .find("\"format\":")
        .expect("a checkpoint names its format")
        + 9;
    let digits = saved[at..].chars().take_while(char::is_ascii_digit).count();
    assert!(digits > 0, "the format is a number");
    format!("{}99{}", &saved[..at], &saved[at + digits..])
}

/// Runs `scene` to its end, then killed and resumed; the outputs agree.
fn kill_and_resume(name: &str, scene: &Path, root: &Path, every_s: &str, window: Duration) {
    let (whole, killed) = (root.join("whole"), root.join("killed"));
    ok(&mut run(scene, &whole, every_s));
    assert!(!whole.join("checkpoint.json").exists());
    kill_and_resume_after(name, scene, root, every_s, window);
    assert!(
        !killed.join("checkpoint.json").exists(),
        "{name}: the finished run left its checkpoint"
    );
    assert_same_outputs(&whole, &killed);
}

/// The kill and the resume of [`kill_and_resume`] into `root/killed`, with the refusals of
/// foreign checkpoints in between.
fn kill_and_resume_after(name: &str, scene: &Path, root: &Path, every_s: &str, window: Duration) {
    let killed = root.join("killed");
    kill_after_first_checkpoint(
        run(scene, &killed, every_s),
        &killed,
        window,
        "summary.json",
    );
    assert_foreign_checkpoints_refused(scene, &killed, every_s);
    let resumed = run(scene, &killed, every_s).output().unwrap();
    assert!(
        resumed.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&resumed.stderr)
    );
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

/// The built-in capture-quick (2 points x 4 runs, 1e4 free-draining particles each) shortened
/// to 0.5 s of Brownian time: killed after its first finished run and run again, it keeps the
/// finished runs (runs/) and computes the others, to the bytes of the uninterrupted ensemble.
#[test]
fn a_killed_brownian_capture_resumes_to_the_same_outputs() {
    let root = fresh_dir("brownian");
    let scene = shortened(
        &root,
        "capture-quick",
        &[("t_max_s = 5.0", "t_max_s = 0.5")],
    );
    let (whole, killed) = (root.join("whole"), root.join("killed"));
    ok(&mut run(&scene, &whole, "0"));
    let runs = killed.join("runs");
    let finished = || {
        std::fs::read_dir(&runs).is_ok_and(|mut d| {
            d.any(|e| e.is_ok_and(|e| !e.file_name().to_string_lossy().starts_with('.')))
        })
    };
    kill_after(
        run(&scene, &killed, "0"),
        finished,
        Duration::from_millis(1500),
        &killed.join("summary.json"),
    );
    let kept = std::fs::read_dir(&runs).unwrap().count();
    eprintln!("{kept} files in runs/ at the kill");
    ok(&mut run(&scene, &killed, "0"));
    assert_same_outputs(&whole, &killed);
}

// `porelab permeability --out`: the resolution ladder.

/// One sphere of radius 0.31 in the unit periodic box (a simple cubic array, phi 0.125).
const SIMPLE_CUBIC: &str = "1\nLattice=\"1 0 0 0 1 0 0 0 1\" Origin=\"0 0 0\" pbc=\"T T T\" \
Properties=type:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:radius:R:1:cylinder_length:R:1:\
superquadric_roundness:R:2\nsphere 0.5 0.5 0.5 0 0 0 1 0.31 0.31 0.31 0.31 0 1 1\n";

/// `porelab permeability XYZ --out OUT`: rungs of 8, 12, 18 and 27 cells, a tolerance the
/// ladder cannot meet (so that it climbs them all), a checkpoint at every check.
fn ladder(xyz: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = porelab();
    c.arg("permeability")
        .arg(xyz)
        .args(["--quiet", "--start", "8", "--max-resolution", "27"])
        .args(["--rtol", "1e-6", "--checkpoint-every", "0", "--out"])
        .arg(out)
        .args(extra);
    c
}

/// The ladder killed with SIGKILL at a random moment (in a finished rung's gap, mid-rung or
/// while it checks Darcy's law on the second), then run again with the same arguments and
/// `--out`, writes the bytes of the uninterrupted ladder (wall times excepted) and removes its
/// checkpoint; a checkpoint of other arguments, another packing file or another format is
/// refused, naming it.
#[test]
fn a_killed_permeability_ladder_resumes_to_the_same_outputs() {
    let root = fresh_dir("ladder");
    let xyz = root.join("sc.xyz");
    std::fs::write(&xyz, SIMPLE_CUBIC).unwrap();
    let (whole, killed) = (root.join("whole"), root.join("killed"));
    ok(&mut ladder(&xyz, &whole, &[]));
    assert!(!whole.join("checkpoint.json").exists());
    kill_after_first_checkpoint(
        ladder(&xyz, &killed, &[]),
        &killed,
        Duration::from_millis(1500),
        "permeability.json",
    );
    let cp = killed.join("checkpoint.json");
    let refused = |cmd: &mut Command, what: &str| refused(cmd, &cp, what);
    refused(
        &mut ladder(&xyz, &killed, &["--tau", "0.9"]),
        "different ladder",
    );
    let other = root.join("other.xyz");
    std::fs::write(
        &other,
        SIMPLE_CUBIC.replace("0.31 0.31 0.31 0.31", "0.3 0.3 0.3 0.3"),
    )
    .unwrap();
    refused(&mut ladder(&other, &killed, &[]), "different ladder");
    let saved = std::fs::read_to_string(&cp).unwrap();
    std::fs::write(&cp, with_format_99(&saved)).unwrap();
    refused(&mut ladder(&xyz, &killed, &[]), "checkpoint format 99");
    std::fs::write(&cp, saved).unwrap();
    let resumed = ladder(&xyz, &killed, &[]).output().unwrap();
    let stdout = String::from_utf8_lossy(&resumed.stdout);
    assert!(resumed.status.success(), "{stdout}");
    let resuming = stdout.lines().find(|l| l.starts_with("resuming from"));
    eprintln!("{}", resuming.expect("the rerun resumes"));
    assert!(!cp.exists(), "the finished ladder left its checkpoint");
    assert_same_outputs(&whole, &killed);
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

/// The built-in dem-small (300 spheres settling under gravity) cut to 0.3 s of simulated
/// time, checkpointing at every check of its stop rule.
#[test]
fn a_killed_dem_run_resumes_to_the_same_outputs() {
    let root = fresh_dir("dem");
    let scene = shortened(
        &root,
        "dem-small",
        &[("max_time_s = 1.0", "max_time_s = 0.3")],
    );
    kill_and_resume("dem", &scene, &root, "0", Duration::from_millis(1000));
}

/// The built-in coupled-quick (300 spheres under a drainage flow), checkpointing with every
/// porosity row.
#[test]
fn a_killed_coupled_run_resumes_to_the_same_outputs() {
    let root = fresh_dir("coupled");
    let scene = shortened(&root, "coupled-quick", &[]);
    kill_and_resume("coupled", &scene, &root, "0", Duration::from_millis(400));
}

/// The built-in packing-spheres with 300 spheres, checkpointing after every compression step.
/// A packing keeps its last checkpoint as an output (it holds the final state, bitwise), so
/// both folders end with one and the two are compared with the rest.
#[test]
fn a_killed_packing_run_resumes_to_the_same_outputs() {
    let root = fresh_dir("packing");
    let scene = shortened(&root, "packing-spheres", &[("n = 1000", "n = 300")]);
    let (whole, killed) = (root.join("whole"), root.join("killed"));
    ok(&mut run(&scene, &whole, "0"));
    kill_and_resume_after("packing", &scene, &root, "0", Duration::from_millis(300));
    assert!(killed.join("checkpoint.json").exists() && whole.join("checkpoint.json").exists());
    assert_same_outputs(&whole, &killed);
}
