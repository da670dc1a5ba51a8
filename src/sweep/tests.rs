//! Unit tests of planning (grid, zip, seeds, key paths, refusals), the manifest and the
//! statistics of collect. The runs themselves are tested through the binary (tests/sweep.rs).

use super::collect::{flatten, mean_sem};
use super::plan::{job_seed, plan_text, set_path, splitmix64};
use super::*;
use std::path::Path;

/// A packing scene that runs in well under a second.
const BASE: &str = r#"
kind = "packing"
[particles]
n = 20
[mcm]
delta_v_per_particle = 0.05
halvings = 2
[analysis]
s4_trials = 50
"#;

fn with_base(dir_name: &str, sweep: &str) -> Result<Plan> {
    let dir = std::env::temp_dir().join(format!(
        "porelab-sweep-unit-{}-{dir_name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("base.toml"), BASE).unwrap();
    let r = plan_text(sweep, &dir, "sweep.toml");
    std::fs::remove_dir_all(&dir).unwrap();
    r
}

fn err(r: Result<Plan>) -> String {
    r.expect_err("the plan must be refused").to_string()
}

#[test]
fn grid_puts_the_first_key_slowest_and_runs_innermost() {
    let p = with_base(
        "grid",
        "scene = \"base.toml\"\nruns_per_point = 2\n[vary]\n\"particles.n\" = [20, 30]\n\
         mcm.phi0 = [0.05, 0.1, 0.15]\n",
    )
    .unwrap();
    assert_eq!(p.keys, ["particles.n", "mcm.phi0"]);
    assert_eq!(p.jobs.len(), 12);
    let got: Vec<(usize, usize, Vec<String>)> = p
        .jobs
        .iter()
        .map(|j| (j.point, j.run, j.values.clone()))
        .collect();
    let mut want = vec![];
    for (pt, (n, phi)) in [
        (20, 0.05),
        (20, 0.1),
        (20, 0.15),
        (30, 0.05),
        (30, 0.1),
        (30, 0.15),
    ]
    .iter()
    .enumerate()
    {
        for r in 0..2 {
            want.push((pt, r, vec![n.to_string(), phi.to_string()]));
        }
    }
    assert_eq!(got, want);
    // The values really are in the job's scene (read back as TOML, not as text).
    let t: toml::Table = toml::from_str(&p.jobs[7].scene).unwrap();
    assert_eq!(t["particles"]["n"].as_integer(), Some(30));
    assert_eq!(t["mcm"]["phi0"].as_float(), Some(0.05));
    assert_eq!(
        t["mcm"]["seed"].as_integer(),
        Some(job_seed(1, 3, 1) as i64)
    );
}

#[test]
fn zip_pairs_the_lists_and_refuses_unequal_lengths() {
    let p = with_base(
        "zip",
        "scene = \"base.toml\"\ncombine = \"zip\"\n[vary]\n\"particles.n\" = [20, 30]\n\
         \"mcm.phi0\" = [0.05, 0.1]\n",
    )
    .unwrap();
    let vals: Vec<Vec<String>> = p.jobs.iter().map(|j| j.values.clone()).collect();
    assert_eq!(vals, [vec!["20", "0.05"], vec!["30", "0.1"]]);
    let e = err(with_base(
        "zip-bad",
        "scene = \"base.toml\"\ncombine = \"zip\"\n[vary]\n\"particles.n\" = [20, 30]\n\
         \"mcm.phi0\" = [0.05, 0.1, 0.15]\n",
    ));
    assert!(e.contains("zip") && e.contains("[2, 3]"), "{e}");
    let e = err(with_base(
        "comb",
        "scene = \"base.toml\"\ncombine = \"cross\"\n",
    ));
    assert!(e.contains("combine = \"cross\""), "{e}");
}

#[test]
fn splitmix64_matches_the_reference_generator() {
    // First output of Vigna's splitmix64.c (and Java's SplittableRandom) from state 0.
    assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF);
}

#[test]
fn seeds_are_deterministic_distinct_and_fit_toml_integers() {
    let mut seen = std::collections::HashSet::new();
    for p in 0..100 {
        for r in 0..100 {
            let s = job_seed(42, p, r);
            assert_eq!(s, job_seed(42, p, r));
            assert!(s <= i64::MAX as u64);
            assert!(seen.insert(s), "seed {s} repeats at point {p} run {r}");
        }
    }
    assert_ne!(job_seed(1, 0, 0), job_seed(2, 0, 0));
    // Swapping point and run gives another seed.
    assert_ne!(job_seed(1, 1, 2), job_seed(1, 2, 1));
}

#[test]
fn dotted_paths_set_nested_tables_and_array_entries() {
    let mut t: toml::Table =
        toml::from_str("a = 1\n[b]\nc = 2\n[[s]]\nx = 1\n[[s]]\nx = 2\n").unwrap();
    set_path(&mut t, "b.c", toml::Value::Integer(5)).unwrap();
    set_path(&mut t, "d.e.f", toml::Value::Float(0.5)).unwrap();
    set_path(&mut t, "s.1.x", toml::Value::Integer(9)).unwrap();
    assert_eq!(t["b"]["c"].as_integer(), Some(5));
    assert_eq!(t["d"]["e"]["f"].as_float(), Some(0.5));
    assert_eq!(t["s"][1]["x"].as_integer(), Some(9));
    assert_eq!(t["s"][0]["x"].as_integer(), Some(1));
    let e = set_path(&mut t, "a.z", toml::Value::Integer(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("vary.a.z") && e.contains("not a table"), "{e}");
    let e = set_path(&mut t, "s.7.x", toml::Value::Integer(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no index 7"), "{e}");
    let e = set_path(&mut t, "s.x", toml::Value::Integer(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("must be an index"), "{e}");
}

#[test]
fn a_misspelt_key_is_refused_by_name_with_its_point() {
    let e = err(with_base(
        "badkey",
        "scene = \"base.toml\"\n[vary]\n\"mcm.phio\" = [0.05]\n",
    ));
    assert!(e.contains("phio") && e.contains("point 0"), "{e}");
}

#[test]
fn a_bad_value_is_refused_naming_the_point_and_the_key() {
    // phi0 must lie in (0, 0.2] (src/scene/packing.rs); the second value breaks it.
    let e = err(with_base(
        "badvalue",
        "scene = \"base.toml\"\n[vary]\n\"mcm.phi0\" = [0.05, 0.5]\n",
    ));
    assert!(e.contains("point 1 (mcm.phi0 = 0.5)"), "{e}");
    assert!(e.contains("phi0"), "{e}");
    // A value of the wrong type.
    let e = err(with_base(
        "badtype",
        "scene = \"base.toml\"\n[vary]\n\"particles.n\" = [20, \"many\"]\n",
    ));
    assert!(
        e.contains("point 1") && e.contains("particles.n = \"many\""),
        "{e}"
    );
}

#[test]
fn sweep_files_refuse_unknown_keys_and_unclear_bases() {
    let e = err(with_base("unknown", "scene = \"base.toml\"\nruns = 3\n"));
    assert!(e.contains("unknown field `runs`"), "{e}");
    let e = err(with_base("nobase", "runs_per_point = 2\n"));
    assert!(e.contains("exactly one of"), "{e}");
    let e = err(with_base(
        "both",
        "scene = \"base.toml\"\nbuiltin = \"lbm-channel\"\n",
    ));
    assert!(e.contains("exactly one of"), "{e}");
    let e = err(with_base(
        "nolist",
        "scene = \"base.toml\"\n[vary]\n\"mcm.phi0\" = 0.1\n",
    ));
    assert!(e.contains("vary.mcm.phi0 = 0.1: must be a list"), "{e}");
    let e = err(with_base(
        "empty",
        "scene = \"base.toml\"\n[vary]\n\"mcm.phi0\" = []\n",
    ));
    assert!(e.contains("at least one value"), "{e}");
    let e = err(with_base(
        "seed",
        "scene = \"base.toml\"\n[vary]\n\"mcm.seed\" = [1, 2]\n",
    ));
    assert!(
        e.contains("vary.mcm.seed") && e.contains("base_seed"),
        "{e}"
    );
    let e = err(with_base(
        "zero",
        "scene = \"base.toml\"\nruns_per_point = 0\n",
    ));
    assert!(e.contains("runs_per_point = 0"), "{e}");
}

#[test]
fn every_engine_takes_its_seed_at_the_planned_key() {
    // Each built-in scene, planned with two runs: the engine's own schema (deny_unknown_fields)
    // would refuse a seed at a key it does not have. LBM draws no random numbers.
    for b in crate::scene::builtins() {
        let kind = if b.name.starts_with("lbm") { "lbm" } else { "" };
        let sweep = format!("builtin = \"{}\"\nruns_per_point = 2\n", b.name);
        let r = plan_text(&sweep, Path::new("."), "sweep.toml");
        if kind == "lbm" {
            let e = err(r);
            assert!(e.contains("has no seed"), "{}: {e}", b.name);
            assert!(plan_text(&format!("builtin = \"{}\"\n", b.name), Path::new("."), "s").is_ok());
        } else {
            let p = r.unwrap_or_else(|e| panic!("{}: {e}", b.name));
            assert_eq!(p.jobs.len(), 2);
            assert_ne!(p.jobs[0].seed, p.jobs[1].seed);
            assert_ne!(p.jobs[0].hash, p.jobs[1].hash);
        }
    }
}

#[test]
fn the_manifest_reads_back_as_written() {
    let p = with_base(
        "manifest",
        "scene = \"base.toml\"\nruns_per_point = 2\n[vary]\n\"mcm.phi0\" = [0.05, 0.1]\n",
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("porelab-sweep-manifest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(MANIFEST), p.manifest_csv()).unwrap();
    let back = Plan::read(&dir).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let mut want = p.clone();
    for j in &mut want.jobs {
        j.scene.clear();
    }
    assert_eq!(back, want);
    assert_eq!(
        back.job(9).unwrap_err().to_string(),
        "job 9: the sweep has jobs 0..=3"
    );
}

#[test]
fn fnv1a64_matches_the_published_test_vectors() {
    // Test vectors of the FNV reference (Fowler, Noll, Vo; isthe.com/chongo/tech/comp/fnv).
    assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
    assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
    assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
}

#[test]
fn mean_and_standard_error_match_the_closed_form() {
    // 1, 2, 3, 4: mean 5/2, sample variance 5/3, standard error sqrt(5/3 / 4).
    let (m, s, n) = mean_sem(&[1.0, 2.0, 3.0, 4.0]);
    assert_eq!((m, n), (2.5, 4));
    assert!((s.unwrap() - (5.0f64 / 12.0).sqrt()).abs() < 1e-15);
    assert_eq!(mean_sem(&[7.0]), (7.0, None, 1));
}

#[test]
fn summaries_flatten_to_numbers_without_timings() {
    let v = serde_json::json!({
        "packing_fraction": 0.6, "jammed": true, "seconds": 1.5, "threads": 2, "seed": 9,
        "title": "x", "list": [1, 2], "none": null,
        "nested": {"a": 1, "start_seconds": 0.1, "deeper": {"b": false}},
    });
    let mut m = std::collections::BTreeMap::new();
    flatten("", &v, &mut m);
    let got: Vec<(&str, f64)> = m.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    assert_eq!(
        got,
        [
            ("jammed", 1.0),
            ("nested.a", 1.0),
            ("nested.deeper.b", 0.0),
            ("packing_fraction", 0.6)
        ]
    );
}
