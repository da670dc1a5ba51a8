//! Tests of the DEM scene: built-ins parse, a run interrupted and resumed writes the
//! uninterrupted run's outputs, bad keys are named, the contact sub-models read as the presets.

use super::run::run_scene_limited;
use super::*;
use crate::io::xyz;
use crate::scene::RunOptions;
use std::path::Path;

#[test]
fn builtins_parse() {
    for b in builtins() {
        parse_scene(b.toml, b.name).unwrap();
    }
}

fn quiet() -> RunOptions {
    RunOptions {
        out: None,
        threads: None,
        quiet: true,
        checkpoint_every_seconds: None,
    }
}

/// 100 spheres for 0.03 s of settling, a frame every 0.01 s, coarse pore grid.
fn short_scene() -> String {
    include_str!("../builtin/dem-small.toml")
        .replace("n = 300", "n = 100")
        .replace("porosity = 0.75", "porosity = 0.7")
        .replace("max_time_s = 1.0", "max_time_s = 0.03")
        .replace(
            "check_every_s = 0.01",
            "check_every_s = 0.005\ntrajectory_every_s = 0.01\npore_voxels_per_d = 6\nrdf_max_over_d = 1.0",
        )
}

/// A run stopped after two checks and resumed from its checkpoint writes bitwise the
/// outputs of the uninterrupted run (all but the wall-clock figures of the summary).
#[test]
fn interrupted_run_resumes_to_the_same_result() {
    let base = std::env::temp_dir().join(format!("porelab-dem-resume-{}", std::process::id()));
    let (whole, killed) = (base.join("whole"), base.join("killed"));
    let text = short_scene();
    run_scene(&text, "test", &whole, &quiet()).unwrap();
    run_scene_limited(&text, "test", &killed, &quiet(), Some(2)).unwrap();
    assert!(killed.join("checkpoint.json").exists());
    assert!(!killed.join("final.xyz").exists());
    run_scene(&text, "test", &killed, &quiet()).unwrap();
    assert!(!killed.join("checkpoint.json").exists());
    let read = |d: &Path, f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    for f in [
        "final.xyz",
        "history.csv",
        "profile.csv",
        "rdf.csv",
        "pore_sizes.csv",
        "trajectory/frame_000000.xyz",
        "trajectory/frame_000001.xyz",
        "trajectory/frame_000003.xyz",
    ] {
        assert!(read(&whole, f) == read(&killed, f), "{f} differs");
    }
    // every frame of the run is there and OVITO's reader sees radius per particle
    let (_, parts) = xyz::parse(&read(&whole, "trajectory/frame_000003.xyz"), "t").unwrap();
    assert_eq!(parts.len(), 100);
    assert!(parts.iter().all(|p| p.radius == 2e-4));
    let strip = |d: &Path| -> serde_json::Value {
        let mut v: serde_json::Value = serde_json::from_str(&read(d, "summary.json")).unwrap();
        for k in ["seconds", "neighbour_share"] {
            v.as_object_mut().unwrap().remove(k);
        }
        v
    };
    assert_eq!(strip(&whole), strip(&killed));
    // a checkpoint of another scene is refused, naming the file
    run_scene_limited(&text, "test", &killed, &quiet(), Some(1)).unwrap();
    crate::scene::assert_other_scene_refused(|t| run_scene(t, "test", &killed, &quiet()), &text);
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn bad_keys_are_named() {
    let base = include_str!("../builtin/dem-small.toml");
    let e = parse_scene(&base.replace("[run]", "[run]\nbogus_key = 1"), "t")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("bogus_key"), "{e}");
    let e = parse_scene(&base.replace("restitution = 0.5", "restitution = 1.5"), "t")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("contact.restitution") && e.contains("1.5"),
        "{e}"
    );
    let e = parse_scene(&base.replace("young_pa = 1e7", "young_pa = -1"), "t")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("young_pa") && e.contains("-1"), "{e}");
}

/// The `[contact]` table of the built-in dem-small.
const CONTACT: &str = "[contact]\nmodel = \"hertz-mindlin\"\nyoung_pa = 1e7\npoisson = 0.3\nrestitution = 0.5\nfriction = 0.3\n";

/// The contact of dem-small written as three sub-models gives the preset's model exactly.
#[test]
fn sub_models_read_as_the_presets() {
    let preset = include_str!("../builtin/dem-small.toml");
    let base = parse_scene(preset, "t").unwrap();
    let contact = "[contact]\nyoung_pa = 1e7\npoisson = 0.3\n\
                   normal = { model = \"hertz\" }\n\
                   damping = { model = \"restitution\", restitution = 0.5 }\n\
                   tangential = { model = \"mindlin\", friction = 0.3 }\n";
    let split = preset.replace(CONTACT, contact);
    assert_ne!(split, preset);
    let s = parse_scene(&split, "t").unwrap();
    assert_eq!(s.setup.contact, base.setup.contact);
    assert_eq!(s.setup.particle_material, base.setup.particle_material);
    // zhou2002 with its defaults, and the linear preset at friction 0
    let zhou = parse_scene(
        &preset
            .replace("model = \"hertz-mindlin\"", "model = \"zhou2002\"")
            .replace("restitution = 0.5\n", ""),
        "t",
    )
    .unwrap();
    let want = crate::dem::ContactModel::new(
        crate::dem::NormalModel::Hertz,
        crate::dem::DampingModel::Zhou { c_n: 0.3 },
        crate::dem::TangentialModel::Zhou { mu: 0.3, c_t: 0.3 },
    )
    .unwrap();
    assert_eq!(zhou.setup.contact, want);
    let linear = "[contact]\nmodel = \"linear\"\nk_n_n_per_m = 1e3\nfriction = 0.0\n";
    let text = preset.replace(CONTACT, linear);
    let s = parse_scene(&text, "t").unwrap();
    assert!(s.setup.contact.tangential().is_none());
}

#[test]
fn contact_keys_are_used_or_refused() {
    let preset = include_str!("../builtin/dem-small.toml");
    let refused = |from: &str, to: &str, want: &[&str]| {
        let text = preset.replace(from, to);
        assert_ne!(text, preset);
        let e = parse_scene(&text, "s.toml").err().unwrap().to_string();
        for w in want {
            assert!(e.contains(w), "{w} not in: {e}");
        }
    };
    // a coefficient the preset does not read
    refused(
        "friction = 0.3",
        "c_n = 0.2",
        &["s.toml", "contact.c_n", "\"zhou2002\""],
    );
    refused(
        "model = \"hertz-mindlin\"",
        "model = \"hertz\"",
        &["contact.friction", "not read by model = \"hertz\""],
    );
    // moduli a linear law does not read
    refused(
        "model = \"hertz-mindlin\"",
        "model = \"linear\"\nk_n_n_per_m = 1e3",
        &["contact.young_pa", "not read"],
    );
    // preset and sub-models together, an unknown preset, an unknown sub-model
    refused(
        "friction = 0.3",
        "friction = 0.3\nnormal = { model = \"hertz\" }",
        &["give one or the other"],
    );
    refused(
        "model = \"hertz-mindlin\"",
        "model = \"hooke\"",
        &["s.toml", "hooke", "hertz-mindlin"],
    );
    refused(
        CONTACT,
        "[contact]\nyoung_pa = 1e7\nnormal = { model = \"hertz\" }\n\
         damping = { model = \"none\" }\ntangential = { model = \"coulomb\", friction = 0.3 }\n",
        &["coulomb", "mindlin"],
    );
    // a combination the model refuses, named by its table
    refused(
        CONTACT,
        "[contact]\nnormal = { model = \"linear\", k_n_n_per_m = 1e3 }\n\
         damping = { model = \"zhou2002\", c_n = 0.3 }\ntangential = { model = \"none\" }\n",
        &["contact:", "Hertz"],
    );
    // a size key the size does not read
    refused(
        "diameter_m = 4e-4",
        "diameter_m = 4e-4\nsigma_ln = 0.2",
        &["sigma_ln"],
    );
}

/// Old spellings of keys are read under their new names, giving the same scene.
#[test]
fn old_key_spellings_are_read() {
    let preset = include_str!("../builtin/dem-small.toml");
    let old = preset.replace("density_kg_m3 = 2500.0", "rho_kg_m3 = 2500.0");
    assert_ne!(old, preset);
    let (a, b) = (
        parse_scene(preset, "t").unwrap(),
        parse_scene(&old, "t").unwrap(),
    );
    assert_eq!(a.setup.density_kg_m3, b.setup.density_kg_m3);
    assert_eq!(a.setup.start.radii(), b.setup.start.radii());
}
