//! A corpus of bad inputs, kept as a test: every one must be refused with exit status 2 and a
//! message naming what it refuses; none may panic, abort, hang or succeed.
//!
//! - **Scene files**, generated from every built-in scene: each number of the file in turn
//!   replaced by NaN, by infinity and by a string, and, for counts and for sizes, times,
//!   densities, viscosities and temperatures (keys ending in `_m`, `_s`, `_m2`, `_m3`,
//!   `_kg_m3`, `_pa_s`, `_K`), by -1. Each mutated file goes through `porelab run FILE --check`,
//!   which parses and checks a scene exactly as a run does before it starts. The message must
//!   name the file and the key (its last name).
//! - **Command lines**: options given negative, zero, NaN or malformed values, and missing
//!   files, for every subcommand; the message must name the option or the file.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn porelab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_porelab"))
}

/// A fresh folder of one test (the tests run at the same time).
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("porelab-bad-inputs-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// How a refusal went wrong, or None when it was right.
fn judge(mut cmd: Command, dir: &Path, needles: &[&str]) -> Option<String> {
    let mut child = cmd
        .current_dir(dir)
        .env("PORELAB_ROOT", env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            return Some("hang: no answer within 120 s".into());
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let first = err.lines().last().unwrap_or("").to_string();
    if err.contains("panicked") {
        return Some(format!("panic: {first}"));
    }
    match status.code() {
        None => return Some(format!("killed by a signal (abort?): {first}")),
        Some(0) => return Some("accepted (exit 0): a silent success".into()),
        Some(2) => {}
        Some(c) => return Some(format!("exit {c} instead of 2: {first}")),
    }
    let missing: Vec<&&str> = needles.iter().filter(|n| !err.contains(**n)).collect();
    if !missing.is_empty() {
        return Some(format!("message does not name {missing:?}: {}", err.trim()));
    }
    None
}

/// Numbers of a scene file: (key path, last key name, is an integer).
fn numbers(v: &toml::Value, path: &mut Vec<String>, out: &mut Vec<(Vec<String>, bool)>) {
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                path.push(k.clone());
                numbers(v, path, out);
                path.pop();
            }
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                if v.is_table() {
                    path.push(i.to_string());
                    numbers(v, path, out);
                    path.pop();
                }
            }
        }
        toml::Value::Integer(_) => out.push((path.clone(), true)),
        toml::Value::Float(_) => out.push((path.clone(), false)),
        _ => {}
    }
}

fn set(v: &mut toml::Value, path: &[String], new: toml::Value) {
    let mut at = v;
    for k in path {
        at = match at {
            toml::Value::Table(t) => t.get_mut(k).unwrap(),
            toml::Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
            _ => unreachable!(),
        };
    }
    *at = new;
}

/// Keys whose values are sizes, times, densities, viscosities or temperatures (never negative).
fn never_negative(key: &str) -> bool {
    let velocity = key.ends_with("_m_s") || key.ends_with("_m_s2");
    !velocity
        && ["_m", "_s", "_m2", "_m3", "_kg_m3", "_pa_s", "_K"]
            .iter()
            .any(|s| key.ends_with(s))
}

fn builtin_names() -> Vec<String> {
    let o = porelab().args(["run", "--list"]).output().unwrap();
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

#[test]
fn scene_files_with_bad_numbers_are_refused_naming_file_and_key() {
    let dir = scratch("scenes");
    let mut tried = 0;
    let mut failures = Vec::new();
    for name in builtin_names() {
        let o = porelab().args(["run", "--show", &name]).output().unwrap();
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let scene: toml::Value = toml::from_str(&text).unwrap();
        let mut keys = Vec::new();
        numbers(&scene, &mut Vec::new(), &mut keys);
        for (path, integer) in keys {
            let leaf = path.last().unwrap().as_str();
            let mut bad = vec![
                toml::Value::Float(f64::NAN),
                toml::Value::Float(f64::INFINITY),
                toml::Value::String("text".into()),
            ];
            if integer {
                bad.push(toml::Value::Integer(-1));
            } else if never_negative(leaf) {
                bad.push(toml::Value::Float(-1.0));
            }
            for b in bad {
                let mut s = scene.clone();
                set(&mut s, &path, b.clone());
                let file = dir.join(format!("{name}.toml"));
                std::fs::write(&file, toml::to_string(&s).unwrap()).unwrap();
                let mut cmd = porelab();
                cmd.arg("run").arg(&file).arg("--check");
                let file_name = file.display().to_string();
                tried += 1;
                if let Some(why) = judge(cmd, &dir, &[&file_name, leaf]) {
                    failures.push(format!("{name}: {} = {b}: {why}", path.join(".")));
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "{tried} bad scene files, {} refused wrongly",
        failures.len()
    );
    assert!(tried >= 250, "the corpus shrank to {tried} scene files");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Runs too large for memory or for any reasonable time, and an output folder that cannot be
/// written, are refused before any work (a run that started would hang the 120 s judge).
#[test]
fn oversized_runs_and_unwritable_outputs_are_refused_before_work() {
    let dir = scratch("sizes");
    let show = |name: &str| {
        let o = porelab().args(["run", "--show", name]).output().unwrap();
        String::from_utf8(o.stdout).unwrap()
    };
    let (dem, coupled, lbm) = (
        show("dem-small"),
        show("coupled-quick"),
        show("lbm-channel"),
    );
    let scenes = [
        // allocations of 1e9 and 1e10 spheres aborted the run
        (
            "dem-1e9.toml",
            dem.replace("n = 300", "n = 1000000000"),
            vec!["particles.n", "1000000000"],
        ),
        (
            "dem-1e10.toml",
            dem.replace("n = 300", "n = 10000000000"),
            vec!["particles.n", "10000000000"],
        ),
        // 300 spheres for 1e4 s: 3.3e12 particle-steps
        (
            "dem-long.toml",
            dem.replace("max_time_s = 1.0", "max_time_s = 1e4"),
            vec!["max_particle_steps", "max_time_s"],
        ),
        // dx_m = 1e-5: a 150 x 150 x 1800 lattice grew to 4 GB before a word
        (
            "coupled-fine.toml",
            coupled.replace("dx_m = 5e-4", "dx_m = 1e-5"),
            vec!["fluid.dx_m", "max_cell_updates"],
        ),
        // a channel 100000 cells across would run for days and end unconverged
        (
            "lbm-wide.toml",
            lbm.replace("cells = 32", "cells = 100000"),
            vec!["cells = 100000", "max_steps"],
        ),
    ];
    let mut failures = Vec::new();
    for (name, text, needles) in &scenes {
        assert!(text.contains("kind"), "{name}: the built-in was not shown");
        std::fs::write(dir.join(name), text).unwrap();
        for check in [true, false] {
            let mut cmd = porelab();
            cmd.args(["run", name, "--quiet", "--out", "out"]);
            if check {
                cmd.arg("--check");
            }
            let mut want = needles.clone();
            want.push(name);
            if let Some(why) = judge(cmd, &dir, &want) {
                failures.push(format!("{name} (check {check}): {why}"));
            }
        }
    }
    // --out a file, or under one: refused before the run (dem-seed-gravity runs for minutes)
    std::fs::write(dir.join("a-file"), "").unwrap();
    for out in ["a-file", "a-file/sub"] {
        let mut cmd = porelab();
        cmd.args([
            "run",
            "--builtin",
            "dem-seed-gravity",
            "--quiet",
            "--out",
            out,
        ]);
        if let Some(why) = judge(cmd, &dir, &["--out", "a-file"]) {
            failures.push(format!("--out {out}: {why}"));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn command_lines_with_bad_values_are_refused_naming_the_option() {
    let dir = scratch("options");
    let xyz = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/lammps_spheres.dump");
    let xyz = xyz.to_str().unwrap();
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["run", "--builtin", "dem-small", "--threads", "-1"],
            vec!["--threads"],
        ),
        (
            vec!["run", "--builtin", "dem-small", "--threads", "0"],
            vec!["--threads"],
        ),
        (
            vec!["run", "--builtin", "dem-small", "--checkpoint-every", "-1"],
            vec!["checkpoint"],
        ),
        (
            vec!["run", "--builtin", "dem-small", "--checkpoint-every", "nan"],
            vec!["checkpoint"],
        ),
        (
            vec!["run", "--builtin", "no-such-scene"],
            vec!["no-such-scene"],
        ),
        (vec!["run", "no-such-file.toml"], vec!["no-such-file.toml"]),
        (
            vec!["run", "--show", "no-such-scene"],
            vec!["no-such-scene"],
        ),
        (
            vec!["permeability", "no-such-file.xyz"],
            vec!["no-such-file.xyz"],
        ),
        (
            vec!["permeability", xyz, "--resolution", "-1"],
            vec!["--resolution"],
        ),
        (vec!["permeability", xyz, "--rtol", "-1"], vec!["--rtol"]),
        (vec!["permeability", xyz, "--rtol", "nan"], vec!["--rtol"]),
        (vec!["permeability", xyz, "--tol", "-1"], vec!["--tol"]),
        (
            vec!["permeability", xyz, "--unit-m", "-1"],
            vec!["--unit-m"],
        ),
        (vec!["permeability", xyz, "--unit-m", "0"], vec!["--unit-m"]),
        (
            vec!["permeability", xyz, "--max-overlap", "-1"],
            vec!["--max-overlap"],
        ),
        (vec!["permeability", xyz, "--tau", "0.4"], vec!["tau"]),
        (vec!["permeability", xyz, "--lattice", "D2Q9"], vec!["D2Q9"]),
        (vec!["permeability", xyz, "--frame", "7"], vec!["frame"]),
        (
            vec!["permeability", xyz, "--checkpoint-every", "-1"],
            vec!["--checkpoint-every"],
        ),
        (
            vec![
                "field",
                "--radius",
                "-1",
                "--half-length",
                "1",
                "--magnetization",
                "1,0,0",
                "--points",
                "p.csv",
            ],
            vec!["radius"],
        ),
        (
            vec![
                "field",
                "--radius",
                "1",
                "--half-length",
                "1",
                "--magnetization",
                "1,0",
                "--points",
                "p.csv",
            ],
            vec!["magnetization"],
        ),
        (
            vec![
                "field",
                "--radius",
                "1",
                "--half-length",
                "1",
                "--magnetization",
                "1,0,0",
                "--points",
                "no-such.csv",
            ],
            vec!["no-such.csv"],
        ),
        (vec!["shape", "sphere", "--radius", "-1"], vec!["radius"]),
        (vec!["shape", "sphere", "--radius", "nan"], vec!["radius"]),
        (
            vec!["shape", "spherocylinder", "--radius", "1", "--length", "-2"],
            vec!["length"],
        ),
        (
            vec!["shape", "ellipsoid", "--semi-axes", "1,2"],
            vec!["semi"],
        ),
        (
            vec![
                "shape",
                "superquadric",
                "--semi-axes",
                "1,1,1",
                "--exponents",
                "1,2,2",
            ],
            vec!["exponent"],
        ),
        (
            vec!["drag", "--semi-axes", "1,1,-1", "--viscosity", "1e-3"],
            vec!["semi"],
        ),
        (
            vec!["drag", "--semi-axes", "1,1,1", "--viscosity", "-1"],
            vec!["viscosity"],
        ),
        (
            vec!["contact", "no-such-pairs.jsonl"],
            vec!["no-such-pairs.jsonl"],
        ),
        (vec!["validate", "999"], vec!["999"]),
        (
            vec!["sweep", "plan", "no-such-sweep.toml", "--out", "sw"],
            vec!["no-such-sweep.toml"],
        ),
        (vec!["bench", "lbm", "--sizes", "0"], vec!["--sizes"]),
        (vec!["bench", "dem", "--sizes", "-5"], vec!["--sizes"]),
    ];
    std::fs::write(dir.join("p.csv"), "x,y,z\n0,0,3\n").unwrap();
    let mut failures = Vec::new();
    for (args, needles) in &cases {
        let mut cmd = porelab();
        cmd.args(args);
        if let Some(why) = judge(cmd, &dir, needles) {
            failures.push(format!("porelab {}: {why}", args.join(" ")));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
