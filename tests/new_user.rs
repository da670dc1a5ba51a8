//! The binary as a new user meets it: zero work is a failure, expensive or meaningless input is
//! refused up front with a message naming the key, the value and the rule, I/O errors name the
//! path, refused runs leave no output folder, results go to stdout and progress to stderr.
//! Each test runs `porelab` itself (`CARGO_BIN_EXE_porelab`) in a folder of its own.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn porelab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_porelab"))
}

/// A fresh empty folder under the system temp dir.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("porelab-new-user-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Asserts exit status 2 with one stderr line containing every `needle`; returns stderr.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = text(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(2),
        "expected a refusal, got {:?}: {err}",
        o.status
    );
    for n in needles {
        assert!(err.contains(n), "message lacks {n:?}: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// Writes `scene` to DIR/scene.toml and runs it with `--out DIR/out --quiet`.
fn run_scene(dir: &Path, scene: &str, extra: &[&str]) -> Output {
    let f = dir.join("scene.toml");
    std::fs::write(&f, scene).unwrap();
    porelab()
        .arg("run")
        .arg(&f)
        .arg("--out")
        .arg(dir.join("out"))
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn validate_with_no_cases_fails() {
    let d = scratch("validate");
    let o = porelab()
        .arg("validate")
        .env("PORELAB_ROOT", &d)
        .output()
        .unwrap();
    refused(&o, &["no validation cases", "nothing was checked"]);
}

#[test]
fn packing_that_cannot_compress_is_refused() {
    let d = scratch("absurd-packing");
    let o = run_scene(
        &d,
        "kind = \"packing\"\n[mcm]\ndelta_v_per_particle = 1e6\n",
        &[],
    );
    refused(&o, &["delta_v_per_particle = 1000000", "free volume"]);
    let o = run_scene(&d, "kind = \"packing\"\n[mcm]\nbeta = 100.0\n", &[]);
    refused(&o, &["beta = 100", "below 2"]);
    assert!(
        !d.join("out").exists(),
        "a refused scene left its output folder"
    );
}

#[test]
fn bench_field_with_no_oracle_sample_is_refused() {
    let d = scratch("bench-sample");
    let o = porelab()
        .args(["bench", "field", "--points", "100", "--sample", "0"])
        .current_dir(&d)
        .output()
        .unwrap();
    refused(&o, &["--sample 0"]);
}

#[test]
fn memory_and_threads_are_checked_up_front() {
    let d = scratch("expensive");
    if porelab::scene::available_memory_bytes().is_some() {
        let o = run_scene(
            &d,
            "kind = \"packing\"\n[particles]\nn = 100000000000\n",
            &[],
        );
        refused(&o, &["n = 100000000000", "bytes", "memory available"]);
    } else {
        eprintln!("skipped the memory check: /proc/meminfo is not readable here");
    }
    let o = porelab()
        .args(["run", "--builtin", "packing-spheres", "--threads", "10000"])
        .arg("--out")
        .arg(d.join("out"))
        .output()
        .unwrap();
    refused(&o, &["--threads 10000", "per core"]);
    assert!(!d.join("out").exists());
}

#[test]
fn messages_name_the_key_value_and_rule() {
    let d = scratch("messages");
    let cases: [(&str, &[&str]); 4] = [
        (
            "kind = \"brownian\"\n[fluid]\ntemperature_K = 0.0\n",
            &["fluid.temperature_K = 0", "positive"],
        ),
        (
            "kind = \"brownian\"\n[particles]\nn_top = 0\nn_side = 0\n",
            &["particles.n_top = 0", "at least one particle"],
        ),
        (
            "kind = \"brownian\"\n[particles]\nradius_m = -75e-9\n",
            &["particles.radius_m = -7.5e-8", "positive"],
        ),
        (
            "kind = \"packing\"\n[container]\nshape = \"wedge\"\nlength = 10.0\nangle_deg = 95.0\n",
            &["container.angle_deg = 95", "(0, 90)"],
        ),
    ];
    for (scene, needles) in cases {
        let err = refused(&run_scene(&d, scene, &["--quiet"]), needles);
        assert!(err.contains("scene.toml"), "the file is not named: {err}");
        assert!(
            !err.contains("Mie epsilon") && !err.contains("0x0") && !err.contains("Table 6.1"),
            "{err}"
        );
        assert!(
            !d.join("out").exists(),
            "refused scene left a folder: {scene}"
        );
    }
    let o = porelab()
        .args([
            "drag",
            "--semi-axes",
            "1e-300,1,1e300",
            "--viscosity",
            "1e-3",
        ])
        .output()
        .unwrap();
    let err = refused(&o, &["semi-axes", "smallest / largest"]);
    assert!(!err.contains("elliprf"), "{err}");
}

#[test]
fn io_errors_name_the_path() {
    let d = scratch("io");
    let small = "kind = \"packing\"\n[particles]\nn = 20\n";
    let f = d.join("small.toml");
    std::fs::write(&f, small).unwrap();
    let run = |out: &Path| {
        porelab()
            .arg("run")
            .arg(&f)
            .arg("--out")
            .arg(out)
            .arg("--quiet")
            .output()
            .unwrap()
    };
    refused(&run(Path::new("/proc/porelab-x")), &["/proc/porelab-x"]);
    let file = d.join("a-file");
    std::fs::write(&file, "x").unwrap();
    refused(&run(&file), &[&file.display().to_string()]);
    let ck = d.join("ck");
    std::fs::create_dir_all(ck.join("checkpoint.json")).unwrap();
    refused(&run(&ck), &["checkpoint.json"]);
}

#[test]
fn contact_far_apart_is_finite_and_zero_length_rods_are_spheres() {
    let d = scratch("contact");
    let far = r#"{"a": {"shape": "sphere", "radius": 0.5, "position": [0,0,0]}, "b": {"shape": "sphere", "radius": 0.5, "position": [1e160,0,0]}}
{"a": {"shape": "spherocylinder", "radius": 0.5, "length": 2, "position": [0,0,0]}, "b": {"shape": "spherocylinder", "radius": 0.5, "length": 2, "position": [1e160,0,0]}}
{"a": {"shape": "sphere", "radius": 0.5, "position": [0,0,0]}, "b": {"shape": "ellipsoid", "semi_axes": [1,0.5,0.5], "position": [1e160,0,0]}}
{"a": {"shape": "spherocylinder", "radius": 0.5, "length": 0, "position": [0,0,0]}, "b": {"shape": "sphere", "radius": 0.5, "position": [2,0.5,0]}}
"#;
    std::fs::write(d.join("pairs.jsonl"), far).unwrap();
    let o = porelab()
        .arg("contact")
        .arg(d.join("pairs.jsonl"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let lines: Vec<serde_json::Value> = text(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 4);
    for (k, c) in lines[..3].iter().enumerate() {
        let gap = c["gap"].as_f64().unwrap_or(f64::NAN);
        // The surfaces are 1e160 minus at most 1.5 apart: 1e160 to rounding.
        assert!((gap - 1e160).abs() <= 1e145, "pair {k}: gap {gap}");
        let n: Vec<f64> = (0..3).map(|i| c["normal"][i].as_f64().unwrap()).collect();
        assert_eq!(n, vec![1.0, 0.0, 0.0], "pair {k}");
        for key in ["point_a", "point_b"] {
            assert!(
                (0..3).all(|i| c[key][i].as_f64().is_some_and(f64::is_finite)),
                "pair {k}: {key} {}",
                c[key]
            );
        }
    }
    // L = 0: the sphere-sphere gap |(2, 0.5, 0)| - 1, as `porelab shape` treats it as a sphere.
    let gap = lines[3]["gap"].as_f64().unwrap();
    let exact = (4.25f64).sqrt() - 1.0;
    assert!(
        (gap - exact).abs() <= 4.0 * f64::EPSILON,
        "{gap} vs {exact}"
    );
    let o = porelab()
        .args([
            "shape",
            "spherocylinder",
            "--radius",
            "0.5",
            "--length",
            "0",
        ])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let vol = v["volume"].as_f64().unwrap();
    assert!(
        (vol - std::f64::consts::PI / 6.0).abs() <= 2.0 * f64::EPSILON,
        "{vol}"
    );
}

#[test]
fn packing_summary_on_stdout_progress_on_stderr() {
    let d = scratch("packing-stdout");
    let o = run_scene(
        &d,
        "kind = \"packing\"\n[particles]\nn = 20\n",
        &["--threads", "1"],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["porelab_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(summary["threads"], 1);
    assert!(summary["compression_steps"].as_u64().unwrap() > 0);
    assert!(text(&o.stderr).contains("packing: 20 particles"));
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/summary.json")).unwrap())
            .unwrap();
    assert_eq!(file, summary);
}

#[test]
fn brownian_summary_spells_choices_as_the_scene_does() {
    let d = scratch("brownian-summary");
    let scene = "kind = \"brownian\"\n[run]\nruns = 1\nt_max_s = 0.01\ndt_s = 1e-3\n\
                 sample_every_s = 0.005\n[particles]\nn_top = 2\nn_side = 2\n\
                 [hydrodynamics]\nmobility = \"free-draining\"\n";
    let o = run_scene(&d, scene, &["--threads", "1"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("alpha = 90.0 deg"),
        "{}",
        text(&o.stdout)
    );
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/summary.json")).unwrap())
            .unwrap();
    assert_eq!(s["experiment"], "capture");
    assert_eq!(s["parameters"]["placement"], "top-side");
    assert_eq!(s["parameters"]["magnetization"], "stoner-wohlfarth");
    assert_eq!(s["active_terms"][0], "mobility: free-draining");
    assert_eq!(s["porelab_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(s["threads"], 1);
}

#[test]
fn bench_lbm_filters_select_one_kernel_and_refuse_unknown_names() {
    let d = scratch("bench-lbm");
    for (arg, value) in [
        ("--modes", "foo"),
        ("--lattices", "D3Q27"),
        ("--collisions", "mrt"),
    ] {
        let o = porelab()
            .args(["bench", "lbm", "--no-peer", arg, value])
            .current_dir(&d)
            .output()
            .unwrap();
        refused(&o, &[arg, value]);
    }
    let o = porelab()
        .args([
            "bench",
            "lbm",
            "--sizes",
            "8",
            "--threads",
            "1",
            "--seconds",
            "0",
        ])
        .args([
            "--lattices",
            "D3Q19",
            "--collisions",
            "trt",
            "--modes",
            "porous",
        ])
        .arg("--no-peer")
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let csv = std::fs::read_to_string(d.join("target/porelab/bench/lbm.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 1, "{csv}");
    // lattice, collision, forcing, mask, kernel_mib, n, threads, ...
    let f: Vec<&str> = rows[0].split(',').collect();
    assert_eq!(
        (f[0], f[1], f[2], f[3], f[5], f[6]),
        ("D3Q19", "TRT", "guo-zhao", "open", "8", "1"),
        "{csv}"
    );
}

#[test]
fn bench_writes_under_the_working_folder() {
    let d = scratch("bench-cwd");
    let o = porelab()
        .args(["bench", "field", "--points", "200", "--sample", "3"])
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(d.join("target/porelab/bench-field.csv").is_file());
}

#[test]
fn field_csv_header_has_units() {
    let d = scratch("field");
    std::fs::write(d.join("p.csv"), "x,y,z\n0,0,2e-3\n").unwrap();
    let o = porelab()
        .args(["field", "--radius", "3e-4", "--half-length", "3e-3"])
        .args(["--magnetization", "985e3,0,0", "--gradient", "--points"])
        .arg(d.join("p.csv"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    let header = out.lines().next().unwrap();
    assert!(header.starts_with("x_m,y_m,z_m,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m,Bx_T,By_T,Bz_T,"));
    assert!(header.ends_with(",dHz_dz_A_per_m2"), "{header}");
    assert_eq!(header.split(',').count(), 18);
}

#[test]
fn run_show_prints_the_builtin_scene() {
    let o = porelab()
        .args(["run", "--show", "packing-spheres"])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(
        text(&o.stdout),
        include_str!("../src/scene/builtin/packing-spheres.toml")
    );
    let o = porelab().args(["run", "--show", "nope"]).output().unwrap();
    refused(&o, &["--show nope", "packing-spheres"]);
}
