//! Tests of the filter scene: its built-ins check, bad values are refused by key, and a
//! small run writes its files with the counts adding up.

use super::*;
use crate::scene::Scene as _;

fn builtin() -> &'static str {
    include_str!("../builtin/filter-quick.toml")
}

#[test]
fn builtins_check() {
    for b in Kind.builtins() {
        check_scene(b.toml, &format!("builtin:{}", b.name)).unwrap();
    }
}

#[test]
fn bad_values_are_refused_by_key_and_line() {
    for (from, to, needle) in [
        (
            "fibre_radius_m = 2e-4",
            "fibre_radius_m = -2e-4",
            "bed.fibre_radius_m",
        ),
        ("resolution = 24", "resolution = 2", "bed.resolution"),
        ("fed = 400", "fed = 0", "particles.fed"),
        ("dt_s = 0.02", "dt_s = 0.0", "run.dt_s"),
        (
            "superficial_velocity_m_s = 1e-3",
            "superficial_velocity_m_s = 10.0",
            "Reynolds",
        ),
        (
            "superficial_velocity_m_s = 1e-3",
            "pressure_drop_pa = 1.0\nsuperficial_velocity_m_s = 1e-3",
            "exactly one",
        ),
        (
            "direction = [0.0, 0.0, 1.0]",
            "direction = [0.0, 0.0, 0.0]",
            "field.direction",
        ),
        (
            "temperature_K = 298.0",
            "temperature_K = -1.0",
            "fluid.temperature_K",
        ),
        ("builtin:filter-rods.xyz", "builtin:none.xyz", "bed.xyz"),
        (
            "cutoff_m = 2.5e-3",
            "cutoff_m = 2.5e-3\nmethod = \"fast\"",
            "method",
        ),
        (
            "cutoff_m = 2.5e-3",
            "cutoff_m = 2.5e-3\ntable_tolerance = 1e-6",
            "field.table_tolerance = 0.000001: applies to method = \"tabulated\" only",
        ),
        (
            "cutoff_m = 2.5e-3",
            "cutoff_m = 2.5e-3\nmethod = \"tabulated\"\ntable_tolerance = 0.5",
            "field.table_tolerance = 0.5: must be in [1e-13, 0.1)",
        ),
    ] {
        let text = builtin().replace(from, to);
        assert_ne!(text, builtin(), "{from}");
        let e = check_scene(&text, "s.toml").unwrap_err().to_string();
        assert!(e.contains(needle) && e.contains("s.toml"), "{to}: {e}");
    }
    let e = check_scene(&builtin().replace("fed = 400", "fed = 0"), "s.toml")
        .unwrap_err()
        .to_string();
    let line = builtin()
        .lines()
        .position(|l| l.trim_start().starts_with("fed = 400"))
        .map(|i| i + 1)
        .unwrap();
    assert!(e.contains(&format!("(line {line})")), "{e}");
}

/// A short run of the built-in (fewer particles, one cell): every file is written and the
/// counts in the summary add up.
#[test]
fn a_small_run_writes_its_files() {
    let dir = std::env::temp_dir().join(format!("porelab-filter-scene-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let text = builtin()
        .replace("fed = 400", "fed = 20")
        .replace("cells_deep = 3", "cells_deep = 1")
        .replace("resolution = 24", "resolution = 12");
    let opts = RunOptions {
        quiet: true,
        ..Default::default()
    };
    run_scene(&text, "builtin:t", &dir, &opts).unwrap();
    for f in [
        "summary.json",
        "penetration.csv",
        "penetration.svg",
        "captures.csv",
        "captures.xyz",
    ] {
        assert!(dir.join(f).exists(), "{f}");
    }
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let n = |k: &str| s[k].as_u64().unwrap();
    assert_eq!(n("fed"), 20);
    assert_eq!(n("captured") + n("passed") + n("inside"), 20);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The field the built-in scene's run uses with `extra` keys in its `[field]`, and its bed.
fn field_of(
    extra: &str,
) -> (
    crate::filter::FibreBed,
    Box<dyn crate::brownian::FieldSource>,
) {
    let text = builtin().replace("cutoff_m = 2.5e-3", &format!("cutoff_m = 2.5e-3\n{extra}"));
    let scene = schema::parse(&text, "t.toml").unwrap();
    let schema::BedSource::Xyz(xyz) = scene.bed_source("t.toml").unwrap() else {
        panic!("the built-in's bed is an XYZ");
    };
    let plan = scene
        .plan(&text, "t.toml", schema::read_xyz(xyz, "t.toml").unwrap())
        .unwrap();
    let (field, _) = field::build_field(plan.field.unwrap()).unwrap();
    (plan.bed, field)
}

/// The tabulated field of the built-in scene agrees with its exact superposition at 400
/// random points of the fluid: the force on a moment along H, F = (grad H) H/|H| (per mu0 m),
/// errs by at most 10 x the table's tolerance (1e-6) of the rms force, as each image's field
/// and gradient err by at most that tolerance relative; a table at 1e-2 errs by more than ten
/// times as much, so the comparison can fail.
#[test]
fn tabulated_field_agrees_with_the_exact_superposition_to_its_tolerance() {
    use rand::{Rng, SeedableRng};
    let (bed, exact) = field_of("");
    let (_, fine) = field_of("method = \"tabulated\"\ntable_tolerance = 1e-6");
    let (_, loose) = field_of("method = \"tabulated\"\ntable_tolerance = 1e-2");
    let l = bed.lengths_m();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut points = Vec::new();
    while points.len() < 400 {
        let p = nalgebra::Vector3::from_fn(|k, _| rng.gen_range(0.0..l[k]));
        if bed.touching(&p).is_none() {
            points.push(p);
        }
    }
    let force = |f: &dyn crate::brownian::FieldSource, p| {
        let (h, g) = f.h_and_gradient(p);
        g * (h / h.norm())
    };
    let reference: Vec<_> = points.iter().map(|p| force(exact.as_ref(), p)).collect();
    let rms = (reference.iter().map(|f| f.norm_squared()).sum::<f64>() / 400.0).sqrt();
    let worst = |f: &dyn crate::brownian::FieldSource| {
        points
            .iter()
            .zip(&reference)
            .map(|(p, r)| (force(f, p) - r).norm() / rms)
            .fold(0.0f64, f64::max)
    };
    let (e_fine, e_loose) = (worst(fine.as_ref()), worst(loose.as_ref()));
    assert!(
        e_fine < 1e-5,
        "table 1e-6: largest force error {e_fine:e} of the rms"
    );
    assert!(
        e_loose > 10.0 * e_fine,
        "table 1e-2: {e_loose:e}, table 1e-6: {e_fine:e}"
    );
}

/// A bed from a packing scene in the same run: the packing runs into `bed/` and the filter
/// takes its `final.xyz`, so the same scene with `bed.xyz` naming that file gives the same
/// outputs (the summary but for the bed's source and the seconds); a rerun with the same
/// `--out` resumes the finished packing and gives the same outputs again.
#[test]
fn a_bed_packed_in_the_same_run_is_the_packings_final_configuration() {
    let dir = std::env::temp_dir().join(format!("porelab-filter-packed-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bed.toml"), crate::scene::packing::tests::SMALL).unwrap();
    let origin = dir.join("filter.toml").display().to_string();
    let small = builtin()
        .replace("fed = 400", "fed = 20")
        .replace("cells_deep = 3", "cells_deep = 1")
        .replace("resolution = 24", "resolution = 12");
    let packed = small.replace(
        "xyz = \"builtin:filter-rods.xyz\"",
        "packing = \"bed.toml\"",
    );
    let opts = RunOptions {
        quiet: true,
        ..Default::default()
    };
    check_scene(&packed, &origin).unwrap();
    run_scene(&packed, &origin, &dir.join("a"), &opts).unwrap();
    let final_xyz = dir.join("a/bed/final.xyz");
    assert!(final_xyz.exists());
    let from_file = small.replace("builtin:filter-rods.xyz", &final_xyz.display().to_string());
    run_scene(&from_file, &origin, &dir.join("b"), &opts).unwrap();
    let summary = |out: &str| -> serde_json::Value {
        let mut s: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(out).join("summary.json")).unwrap(),
        )
        .unwrap();
        s["bed"]["source"] = serde_json::Value::Null;
        s["seconds"] = serde_json::Value::Null;
        s
    };
    let read = |out: &str, f: &str| std::fs::read(dir.join(out).join(f)).unwrap();
    assert_eq!(summary("a"), summary("b"));
    for f in ["penetration.csv", "captures.csv", "captures.xyz"] {
        assert_eq!(read("a", f), read("b", f), "{f}");
    }
    let first = read("a", "captures.csv");
    let xyz_first = std::fs::read(&final_xyz).unwrap();
    run_scene(&packed, &origin, &dir.join("a"), &opts).unwrap();
    assert_eq!(read("a", "captures.csv"), first);
    assert_eq!(std::fs::read(&final_xyz).unwrap(), xyz_first);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bed.xyz` and `bed.packing`: exactly one, and a packing scene's own errors name its file.
#[test]
fn a_bed_names_one_source_and_a_bad_packing_is_refused_by_its_file() {
    let dir = std::env::temp_dir().join(format!("porelab-filter-bedsrc-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("bad.toml"),
        crate::scene::packing::tests::SMALL.replace("n = 40", "n = 40\nwrong = 1"),
    )
    .unwrap();
    let origin = dir.join("filter.toml").display().to_string();
    let both = builtin().replace(
        "xyz = \"builtin:filter-rods.xyz\"",
        "xyz = \"builtin:filter-rods.xyz\"\npacking = \"bad.toml\"",
    );
    let neither = builtin().replace("xyz = \"builtin:filter-rods.xyz\"", "");
    for text in [both, neither] {
        let e = check_scene(&text, &origin).unwrap_err().to_string();
        assert!(
            e.contains("exactly one of xyz") && e.contains("packing"),
            "{e}"
        );
    }
    let bad = builtin().replace(
        "xyz = \"builtin:filter-rods.xyz\"",
        "packing = \"bad.toml\"",
    );
    let e = check_scene(&bad, &origin).unwrap_err().to_string();
    assert!(e.contains("bad.toml") && e.contains("wrong"), "{e}");
    let missing = builtin().replace(
        "xyz = \"builtin:filter-rods.xyz\"",
        "packing = \"builtin:no-such\"",
    );
    let e = check_scene(&missing, &origin).unwrap_err().to_string();
    assert!(e.contains("packing-spheres"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// No field, no noise: a small random bed of fibres across the flow (R = 0.2 mm, 10 fibres
/// 1.2 mm long in a 2 mm cell, two cells deep) in its lattice Boltzmann flow at 5.6 voxels per
/// diameter, and particles of radius a = 5.6 nm. The flow alone captures only by interception:
/// with no slip on the exact surfaces it carries through the contact surface d = a at most
/// (a / delta)^2 of the inward flux at the layer's edge (the wall module), and that flux is at
/// most U_max S per cell (S the fibres' surface, U_max the lattice's largest speed), so in a
/// steady flow the captured fraction of flux-weighted tracers is at most
/// cells (a / delta)^2 (U_max / U) (S / A) (A the inlet's area): about 4e-7 here, so of 300
/// particles none. The control: without the no-slip layer (the lattice's interpolation up to
/// the exact surface) the same particles are captured in numbers far above that bound
/// (measured 49 of 300); at least 10 are required, so the count can fail.
#[test]
fn without_field_and_noise_the_flow_alone_captures_only_by_interception() {
    use crate::driver::NoHooks;
    use crate::filter::{driver, random_transverse_fibres, FibreBed, Filter, Setup};
    use crate::lbm::{CollisionKind, LatticeKind, SteadyControl};
    let (cell, r, a, u) = ([2e-3; 3], 2e-4, 5.6e-9, 1e-3);
    let (centres, axes) = random_transverse_fibres(10, cell, r, 3);
    let bed = crate::filter::FibreBed::new(cell, r, 6e-4, &centres, &axes, a).unwrap();
    let options = LatticeOptions {
        lattice: LatticeKind::D3Q19,
        collision: CollisionKind::Trt,
        tau: 1.0,
        force_lattice: 1e-6,
        ctl: SteadyControl {
            check_every: 100,
            tol: 1e-6,
            max_steps: 100_000,
        },
    };
    let flow = bed_flow(&bed, [28; 3], &options, &mut NoHooks).unwrap();
    assert!(flow.converged);
    let captured = |wall_layer_m: f64| {
        let setup = Setup {
            bed: FibreBed::clone(&bed),
            flow: flow.at(u).unwrap(),
            field: None,
            moment: crate::brownian::LangevinMoment::fixed(0.0).unwrap(),
            fluid: crate::brownian::Fluid::new(0.0, 1e-3).unwrap(),
            particles: 300,
            cells_deep: 2,
            dt_s: 0.02,
            max_step_fraction: 0.1,
            wall_layer_m,
            seed: 8,
        };
        let mut f = Filter::new(setup).unwrap();
        driver::run_to_end(&mut f, 20_000, &mut NoHooks).unwrap();
        let c = f.counts();
        eprintln!("wall layer {wall_layer_m:e} m: {c:?}");
        c.captured as f64 / c.fed as f64
    };
    let u_max = flow.shape.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let surface = 10.0 * std::f64::consts::TAU * r * (2.0 * 6e-4 + r);
    let bound = 2.0 * (a / flow.voxel_m).powi(2) * u_max * surface / (cell[0] * cell[1]);
    assert!(bound * 300.0 < 1e-3, "{bound:e}");
    let leaky = captured(0.0);
    let no_slip = captured(flow.voxel_m);
    eprintln!("captured: {leaky} without the no-slip layer, {no_slip} with (bound {bound:.2e})");
    assert!(no_slip <= bound, "with no slip: {no_slip} > {bound:e}");
    assert!(leaky * 300.0 >= 10.0, "without no slip: {leaky}");
}
