use super::*;
use crate::io::xyz::{self, Cell, XyzParticle};

/// Asserts that `toml` is refused before it runs with a message containing `words`.
fn refused(toml: &str, words: &str) {
    let e = check_scene(toml, "t").unwrap_err().to_string();
    assert!(e.contains(words), "{e}");
}

fn builtin(name: &str) -> Builtin {
    builtins().into_iter().find(|b| b.name == name).unwrap()
}

/// Every built-in is read; a key no flow has, a key of another flow and a value of the wrong
/// type are refused naming the key; an unknown flow names the flows there are.
#[test]
fn builtins_parse_and_unknown_keys_are_named() {
    for b in builtins() {
        check_scene(b.toml, &format!("builtin:{}", b.name))
            .unwrap_or_else(|e| panic!("{}: {e}", b.name));
    }
    let bad = format!("{}\nviscosity = 1.0\n", builtins()[0].toml);
    refused(&bad, "unknown field `viscosity`");
    let typed = builtins()[0]
        .toml
        .replace("acceleration_m_s2 = 1e-3", "acceleration_m_s2 = \"fast\"");
    refused(&typed, "acceleration_m_s2");
    refused(&typed, "expected f64");
    let common = builtins()[0].toml.replace("cells = 32", "cells = \"many\"");
    refused(&common, "`cells`");
    refused(
        &builtins()[0]
            .toml
            .replace("lattice = \"D3Q19\"", "lattice = \"D3Q27\""),
        "lattice = \"D3Q27\": must be \"D3Q15\" or \"D3Q19\"",
    );
    let no_flow = builtins()[0].toml.replace("flow = \"channel\"", "");
    refused(&no_flow, "missing key `flow`");
    let tmp = std::env::temp_dir().join(format!("porelab-lbm-scene-{}", std::process::id()));
    let e = run_scene(
        &builtins()[0]
            .toml
            .replace("flow = \"channel\"", "flow = \"pipe\""),
        "test",
        &tmp,
        &RunOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("flow = \"pipe\"") && e.contains("sphere-array"),
        "{e}"
    );
    let e = run_scene(
        &builtins()[0]
            .toml
            .replace("acceleration_m_s2 = 1e-3", "acceleration_m_s2 = 10.0"),
        "test",
        &tmp,
        &RunOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("Mach"), "{e}");
}

/// A lattice too large for the machine is refused at preparation, naming its size,
/// before the mask or the populations are built (it took 100 s and 2 GB before).
#[test]
fn oversized_lattice_is_refused_before_allocating() {
    let b = builtin("lbm-sphere-array");
    let need = crate::lbm::memory::bytes_needed(1_000_000_000, 19, 0);
    match crate::lbm::memory::memory_available() {
        Some(avail) if avail < need => {}
        _ => return eprintln!("skipped: this machine has room for a 1000^3 lattice"),
    }
    let big = b.toml.replace("cells = 32", "cells = 1000");
    let t = std::time::Instant::now();
    let tmp = std::env::temp_dir().join(format!("porelab-lbm-big-{}", std::process::id()));
    let e = run_scene(&big, "t", &tmp, &RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(t.elapsed().as_secs_f64() < 1.0, "{:?}", t.elapsed());
    assert!(e.contains("1000 x 1000 x 1000") && e.contains("GiB"), "{e}");
    assert!(!tmp.exists());
}

fn run_builtin_toml(toml: &str, tag: &str) -> std::path::PathBuf {
    let tmp = std::env::temp_dir().join(format!("porelab-lbm-{tag}-{}", std::process::id()));
    let quiet = RunOptions {
        quiet: true,
        ..Default::default()
    };
    run_scene(toml, "builtin:t", &tmp, &quiet).unwrap();
    tmp
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// The porous Couette builtin (Forchheimer term on) follows the finite-difference
/// reference; with the term off, the profile follows u = U sinh(r y) / sinh(r H), r =
/// sqrt(eps / K) (the Brinkman equation nu u'' = (eps nu / K) u, u(0) = 0, u(H) = U, walls
/// on the nodes), evaluated here from the SI keys, and the error falls with resolution
/// (measured 1.8e-4 of U at 16 cells, 5.4e-5 at 32: second order). Keys of other flows
/// and a missing wall velocity are refused by name.
#[test]
fn porous_couette_builtin_and_brinkman_couette_closed_form() {
    let b = builtin("lbm-porous-couette");
    let dir = run_builtin_toml(b.toml, "pc");
    let s = summary(&dir);
    assert_eq!(s["profile_reference"], "finite differences");
    assert!(s["profile_max_error_rel"].as_f64().unwrap() < 1e-3, "{s}");
    let _ = std::fs::remove_dir_all(&dir);
    let (u_wall, h, r) = (1e-2, 1e-3, (0.1f64 / 1e-8).sqrt());
    let err = |cells: usize| {
        let toml = b
            .toml
            .replace("cells = 32", &format!("cells = {cells}"))
            .replace("forchheimer = true", "forchheimer = false");
        let dir = run_builtin_toml(&toml, &format!("pc{cells}"));
        let text = std::fs::read_to_string(dir.join("profile.csv")).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let mut worst: f64 = 0.0;
        for l in text.lines().skip(1) {
            let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
            let exact = u_wall * (r * v[0]).sinh() / (r * h).sinh();
            worst = worst.max((v[1] - exact).abs() / u_wall);
        }
        assert_eq!(text.lines().count(), cells + 2);
        worst
    };
    let (e16, e32) = (err(16), err(32));
    eprintln!("porous Couette, Forchheimer off: max error / U = {e16:.3e} (16), {e32:.3e} (32)");
    assert!(e16 < 5e-4 && e32 < e16 / 2.5, "{e16:e} {e32:e}");
    let stray = format!("{}solid_fraction = 0.1\n", b.toml);
    refused(&stray, "unknown field `solid_fraction`");
    refused(
        &b.toml.replace("wall_velocity_m_s = 1e-2", ""),
        "missing field `wall_velocity_m_s`",
    );
}

/// The packing builtin runs from its built-in configuration and reports what `porelab
/// permeability` prints; a simple cubic configuration in a scene folder (relative `xyz`)
/// gives the permeability of the sphere-array flow of the same geometry (the same mask);
/// lattice keys are refused for packing and packing keys for the lattice flows.
#[test]
fn packing_builtin_and_sphere_array_agree() {
    let b = builtin("lbm-packing");
    let dir = run_builtin_toml(b.toml, "pk");
    let s = summary(&dir);
    let k = s["k_unit2"].as_f64().unwrap();
    assert!(k > 0.0 && (s["k_m2"].as_f64().unwrap() / (k * 1e-6) - 1.0).abs() < 1e-12);
    assert!(s["kozeny_constant"].as_f64().unwrap() > 0.0, "{s}");
    let text = std::fs::read_to_string(dir.join("permeability.txt")).unwrap();
    assert!(text.contains("resolution 16 (16 x 16 x 16") && text.contains("Kozeny"));
    assert!(dir.join("fields.vtk").is_file() && dir.join("configuration.xyz").is_file());
    let _ = std::fs::remove_dir_all(&dir);

    let folder = std::env::temp_dir().join(format!("porelab-lbm-sc-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let phi: f64 = 0.125;
    let r = (3.0 * phi / (4.0 * std::f64::consts::PI)).cbrt();
    let sphere = XyzParticle {
        species: "sphere".into(),
        position: nalgebra::Vector3::new(0.5, 0.5, 0.5),
        orientation: nalgebra::UnitQuaternion::identity(),
        aspherical_shape: [r; 3],
        radius: r,
        cylinder_length: 0.0,
        roundness: [1.0, 1.0],
    };
    xyz::write(&folder.join("sc.xyz"), &Cell::cubic(1.0), &[sphere], &[]).unwrap();
    let scene = folder.join("sc.toml");
    let toml = "kind = \"lbm\"\nflow = \"packing\"\nxyz = \"sc.xyz\"\nresolution = 16\n\
                unit_m = 1e-4\ntol = 1e-10\ncheck_every = 100\n";
    let quiet = RunOptions {
        quiet: true,
        ..Default::default()
    };
    run_scene(
        toml,
        &scene.display().to_string(),
        &folder.join("a"),
        &quiet,
    )
    .unwrap();
    let array = builtin("lbm-sphere-array")
        .toml
        .replace("cells = 32", "cells = 16")
        .replace("tol = 1e-7", "tol = 1e-10");
    run_scene(&array, "t", &folder.join("b"), &quiet).unwrap();
    let (ka, kb) = (
        summary(&folder.join("a"))["k_m2"].as_f64().unwrap(),
        summary(&folder.join("b"))["permeability_m2"]
            .as_f64()
            .unwrap(),
    );
    let _ = std::fs::remove_dir_all(&folder);
    assert!((ka / kb - 1.0).abs() < 1e-6, "{ka:e} {kb:e}");
    refused(
        &format!("{toml}cells = 16\n"),
        "cells: only the flows on a lattice of their own",
    );
    refused(
        &format!("{}resolution = 16\n", builtins()[0].toml),
        "flow = \"channel\": unknown field `resolution`",
    );
}

/// The channel builtin reproduces its own closed-form column (TRT: exact parabola).
#[test]
fn channel_builtin_profile_matches_poiseuille() {
    let tmp = std::env::temp_dir().join(format!("porelab-lbm-ch-{}", std::process::id()));
    run_scene(
        builtins()[0].toml,
        "builtin:lbm-channel",
        &tmp,
        &RunOptions::default(),
    )
    .unwrap();
    let text = std::fs::read_to_string(tmp.join("profile.csv")).unwrap();
    for l in text.lines().skip(1) {
        let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
        assert!((v[1] - v[2]).abs() < 1e-8 * v[2].abs(), "{l}");
    }
    assert!(tmp.join("fields.vtk").is_file() && tmp.join("summary.json").is_file());
    let _ = std::fs::remove_dir_all(&tmp);
}

/// The pressure-driven builtin reproduces the parabola of its pressure gradient at the
/// mid-length section (TRT walls are exact; what is left is the compressibility of a
/// 2.5e-3 density drop), and its keys are refused where they do not belong.
#[test]
fn pressure_channel_builtin_and_keys() {
    let b = builtin("lbm-pressure-channel");
    let tmp = std::env::temp_dir().join(format!("porelab-lbm-pch-{}", std::process::id()));
    run_scene(b.toml, "builtin", &tmp, &RunOptions::default()).unwrap();
    let text = std::fs::read_to_string(tmp.join("profile.csv")).unwrap();
    let peak = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse::<f64>().unwrap())
        .fold(0.0, f64::max);
    for l in text.lines().skip(1) {
        let v: Vec<f64> = l.split(',').map(|t| t.parse().unwrap()).collect();
        assert!((v[1] - v[2]).abs() < 1e-3 * peak, "{l}");
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let both = format!("{}inlet_velocity_m_s = 1e-3\n", b.toml);
    refused(&both, "exactly one of pressure_drop_pa");
    refused(&b.toml.replace("0.03", "300.0"), "pressure_drop_pa = 300");
    refused(&b.toml.replace("2e-3", "2.01e-3"), "whole number");
    let stray = format!("{}pressure_drop_pa = 1.0\n", builtins()[0].toml);
    refused(&stray, "unknown field `pressure_drop_pa`");
}

/// A scene file with the old spelling `rho_kg_m3` is read as `density_kg_m3` and gives the same
/// outputs, byte for byte; a file with both spellings is refused naming the old one.
#[test]
fn old_density_key_is_read_as_the_new_one() {
    let b = builtin("lbm-channel");
    assert!(b.toml.contains("density_kg_m3 = 1000.0") && !b.toml.contains("rho_kg_m3"));
    let old = b.toml.replace("density_kg_m3", "rho_kg_m3");
    let (a, o) = (
        run_builtin_toml(b.toml, "new-key"),
        run_builtin_toml(&old, "old-key"),
    );
    for f in ["summary.json", "profile.csv", "fields.vtk"] {
        let read = |d: &Path| std::fs::read(d.join(f)).unwrap();
        assert_eq!(read(&a), read(&o), "{f}");
    }
    let _ = (std::fs::remove_dir_all(&a), std::fs::remove_dir_all(&o));
    let both = format!("{}rho_kg_m3 = 1000.0\n", b.toml);
    refused(&both, "unknown field `rho_kg_m3`");
}
