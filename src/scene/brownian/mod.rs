//! Brownian capture scenes (thesis 003, sections 6.3–6.4): TOML schema -> experiment -> files.
//!
//! Every key has the thesis default of section 6.3 unless noted; the schema is documented in
//! README ("Scene files"). `experiment` selects what runs:
//! - `"capture"`: capture fraction against time per start region for every combination of the
//!   `[sweep]` lists (alpha, particle radius, aspect ratio), `run.runs` runs each;
//! - `"cascade"`: the cascade estimate, random and/or optimal (section 6.4.5);
//! - `"capture-volume"`: capture-volume maps and volumes (section 6.4.1).
//!
//! `schema.rs` reads the file (old key spellings such as `fluid.viscosity_Pa_s` are read under
//! their new names, with a note) and builds the engine's capture experiment
//! ([`crate::brownian::experiment::CaptureExperiment`]) of every sweep point; `run.rs` runs
//! them, each run stepped by the engine's driver; `outputs.rs` writes the files.
//!
//! Outputs (folder `--out`, default `target/porelab/run/<scene>/`), all written atomically:
//! `capture.csv` (or `cascade.csv`, `capture_volume.csv` + `capture_volume_plane.csv`),
//! `positions.csv` (capture scenes: start and end positions of every particle of every run),
//! `summary.json` (parameters, active terms, final results, seconds).

mod outputs;
mod run;
mod schema;

pub use run::{check_scene, run_scene};

use super::{Builtin, RunOptions};
use crate::Result;
use std::path::Path;

/// The built-in Brownian scenes.
pub fn builtins() -> Vec<Builtin> {
    vec![
        Builtin {
            name: "capture-thesis-6.3",
            about:
                "section 6.3 defaults: R = 75 nm, L/D = 20, alpha 0-90 deg, 30 runs x 50 s (hours)",
            toml: include_str!("../builtin/capture-thesis-6.3.toml"),
        },
        Builtin {
            name: "capture-quick",
            about:
                "a one-minute capture run: R = 125 nm, L/D = 20, alpha 0 and 90 deg, 4 runs x 5 s",
            toml: include_str!("../builtin/capture-quick.toml"),
        },
        Builtin {
            name: "capture-sizes",
            about: "Fig. 6.6a: final capture fraction against particle size (Table 6.1) and alpha",
            toml: include_str!("../builtin/capture-sizes.toml"),
        },
        Builtin {
            name: "cascade",
            about: "section 6.4.5: random and optimal cascades, R = 125 nm, 0.5 s per stage",
            toml: include_str!("../builtin/cascade.toml"),
        },
        Builtin {
            name: "capture-volume",
            about: "section 6.4.1 / Fig. 6.3: capture volumes, L/D = 5/3 and 20/3, alpha 0/45/90",
            toml: include_str!("../builtin/capture-volume.toml"),
        },
        Builtin {
            name: "chains",
            about:
                "section 6.4.6: 500 particles of 75 nm in a dense block near the rim, dipoles on",
            toml: include_str!("../builtin/chains.toml"),
        },
    ]
}

/// `kind = "brownian"`.
pub struct Kind;

impl super::Scene for Kind {
    fn kind(&self) -> &'static str {
        "brownian"
    }
    fn builtins(&self) -> Vec<Builtin> {
        builtins()
    }
    fn seed_key(&self) -> Option<&'static str> {
        Some("run.seed")
    }
    fn check(&self, text: &str, origin: &str) -> Result<()> {
        check_scene(text, origin)
    }
    fn run(&self, text: &str, origin: &str, out: &Path, opts: &RunOptions) -> Result<()> {
        run_scene(text, origin, out, opts)
    }
}

#[cfg(test)]
mod tests {
    use super::schema::parse;
    use super::*;

    #[test]
    fn every_builtin_parses_and_builds() {
        for b in builtins() {
            let s = parse(b.toml, b.name).unwrap_or_else(|e| panic!("{}: {e}", b.name));
            for c in s.combos() {
                s.experiment(c)
                    .unwrap_or_else(|e| panic!("{}: {e}", b.name));
            }
        }
    }

    /// `fluid.viscosity_Pa_s`, the earlier spelling, is read as `viscosity_pa_s`; both in one
    /// table are refused, naming the old one.
    #[test]
    fn old_viscosity_key_is_read_under_its_new_name() {
        let old = parse(
            "kind = \"brownian\"\n[fluid]\nviscosity_Pa_s = 2e-3\n",
            "x.toml",
        )
        .unwrap();
        let new = parse(
            "kind = \"brownian\"\n[fluid]\nviscosity_pa_s = 2e-3\n",
            "x.toml",
        )
        .unwrap();
        let eta = |s: &schema::Scene| s.experiment(s.combos()[0]).unwrap().fluid.viscosity_pa_s();
        assert_eq!((eta(&old), eta(&new)), (2e-3, 2e-3));
        let e = parse(
            "kind = \"brownian\"\n[fluid]\nviscosity_Pa_s = 2e-3\nviscosity_pa_s = 1e-3\n",
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("viscosity_Pa_s"), "{e}");
    }

    #[test]
    fn unknown_keys_are_named() {
        let e = parse("kind = \"brownian\"\n[run]\nseeed = 3\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("seeed"), "{e}");
        let e = parse("kind = \"brownian\"\n[cylinder]\nalpha = 3\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("alpha"), "{e}");
    }

    #[test]
    fn bad_values_are_named() {
        let e = parse(
            "kind = \"brownian\"\n[hydrodynamics]\nmobility = \"rotne\"\n",
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("rotne") && e.contains("rpy"), "{e}");
        let s = parse(
            "kind = \"brownian\"\n[particles]\nradius_m = 60e-9\n",
            "x.toml",
        )
        .unwrap();
        let e = s.experiment(s.combos()[0]).unwrap_err().to_string();
        assert!(e.contains("Table 6.1"), "{e}");
        let s = parse(
            "kind = \"brownian\"\n[particles]\nplacement = \"uniform\"\n",
            "x.toml",
        )
        .unwrap();
        let e = s.experiment(s.combos()[0]).unwrap_err().to_string();
        assert!(e.contains("uniform") && e.contains("cascade"), "{e}");
    }

    /// The outputs depend only on the seed: one worker thread and two give identical files.
    #[test]
    fn outputs_do_not_depend_on_thread_count() {
        let scene = "kind = \"brownian\"\n[run]\nseed = 9\nruns = 3\nt_max_s = 0.05\n\
                     dt_s = 5e-4\nsample_every_s = 0.01\n[particles]\nradius_m = 212e-9\n\
                     n_top = 3\nn_side = 3\nregion_thickness_m = 20e-6\n\
                     [hydrodynamics]\nmobility = \"free-draining\"\n";
        let base = std::env::temp_dir().join(format!("porelab-threads-{}", std::process::id()));
        let mut outputs = Vec::new();
        for threads in [1, 2] {
            let out = base.join(threads.to_string());
            let opts = RunOptions {
                out: None,
                threads: Some(threads),
                quiet: true,
                checkpoint_every_seconds: None,
            };
            run_scene(scene, "test", &out, &opts).unwrap();
            let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
            outputs.push((read("capture.csv"), read("positions.csv")));
        }
        std::fs::remove_dir_all(&base).ok();
        assert_eq!(outputs[0], outputs[1]);
        assert!(outputs[0].1.lines().count() == 1 + 3 * 6);
    }

    /// A killed ensemble resumes from its finished runs and ends with the same outputs as an
    /// uninterrupted run; a run file of another scene is refused.
    #[test]
    fn resumes_from_finished_runs() {
        let scene = "kind = \"brownian\"\n[run]\nseed = 11\nruns = 3\nt_max_s = 0.05\n\
                     dt_s = 5e-4\nsample_every_s = 0.01\n[particles]\nradius_m = 212e-9\n\
                     n_top = 3\nn_side = 3\nregion_thickness_m = 20e-6\n\
                     [hydrodynamics]\nmobility = \"free-draining\"\n";
        let base = std::env::temp_dir().join(format!("porelab-resume-{}", std::process::id()));
        // a folder left by an earlier process of the same id would be resumed from
        std::fs::remove_dir_all(&base).ok();
        let opts = RunOptions {
            quiet: true,
            ..Default::default()
        };
        let read = |out: &Path| {
            ["capture.csv", "positions.csv"].map(|f| std::fs::read_to_string(out.join(f)).unwrap())
        };
        let whole = base.join("whole");
        run_scene(scene, "test", &whole, &opts).unwrap();
        // The "killed" run: run 1 never finished (its file is gone, a stale temporary stays),
        // and no outputs were written.
        let killed = base.join("killed");
        run_scene(scene, "test", &killed, &opts).unwrap();
        let runs = killed.join("runs");
        std::fs::remove_file(runs.join("point000-run0001.json")).unwrap();
        std::fs::write(runs.join(".point000-run0001.json.tmp-1-0"), b"{half").unwrap();
        for f in ["capture.csv", "positions.csv", "summary.json"] {
            std::fs::remove_file(killed.join(f)).unwrap();
        }
        run_scene(scene, "test", &killed, &opts).unwrap();
        assert!(read(&whole) == read(&killed), "resumed outputs differ");
        // The same folder with another scene text is refused, naming the run file.
        let other = scene.replace("seed = 11", "seed = 12");
        let e = run_scene(&other, "test", &killed, &opts)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("different scene") && e.contains("run0000.json"),
            "{e}"
        );
        std::fs::remove_dir_all(&base).ok();
    }
}
