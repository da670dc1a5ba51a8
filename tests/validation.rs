//! `cargo test --test validation`: one test per case folder in `validation/` (fast tier;
//! `-- --ignored` runs the slow tier). Each test runs the same code as `porelab validate` and
//! then checks the case's insta snapshot `validation/NNN-slug/snapshots/NNN.snap` (a rounded
//! summary for review; the tolerance lives in case.toml). A case marked `deviation` in its
//! case.toml that fails is held to its snapshot (result: DEVIATION) instead.
//!
//! A new case has no snapshot and fails until it is accepted:
//! `INSTA_UPDATE=always cargo test --release --test validation`, or review the `.snap.new`
//! files with `cargo insta review`.

use libtest_mimic::{Arguments, Failed, Trial};
use porelab::validation::{self, Case, Tier};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn check(root: &Path, case: &Case) -> Result<(), Failed> {
    let outcome = validation::run_case(root, case);
    // A documented deviation is not a pass: its snapshot (result: DEVIATION, the worst error's
    // decade) is what it is held to, so a change in how far it misses shows in review.
    if let Some(why) = outcome.deviation.as_deref().filter(|_| !outcome.passed) {
        eprintln!(
            "{} DEVIATION (documented, not a pass): {why}",
            outcome.folder
        );
    } else if !outcome.passed {
        return Err(format!(
            "{} FAILED: {}",
            outcome.folder,
            outcome.message.unwrap_or_default()
        )
        .into());
    }
    let summary = outcome.snapshot_summary();
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path(case.dir.join("snapshots"));
    settings.set_prepend_module_to_snapshot(false);
    settings.set_omit_expression(true);
    settings.set_input_file(case.dir.join("case.toml"));
    let id = outcome.id.clone();
    let res = catch_unwind(AssertUnwindSafe(|| {
        settings.bind(|| insta::assert_snapshot!(id.as_str(), summary));
    }));
    let snap = case
        .dir
        .join("snapshots")
        .join(format!("{}.snap", outcome.id));
    res.map_err(|_| {
        let what = if snap.is_file() {
            format!(
                "the summary differs from {} (see the diff above)",
                snap.display()
            )
        } else {
            format!("no snapshot yet: {} is missing", snap.display())
        };
        Failed::from(format!(
            "{}: {what}.\nAccept a new or changed summary with \
             `INSTA_UPDATE=always cargo test --release --test validation` or `cargo insta review`.",
            case.folder
        ))
    })
}

fn main() {
    let args = Arguments::from_args();
    let root: PathBuf = validation::repo_root();
    let cases = match validation::discover(&root) {
        Ok(c) => c,
        Err(e) => {
            eprintln!(
                "validation: cannot list the cases under {}: {e}",
                root.display()
            );
            std::process::exit(2);
        }
    };
    let trials: Vec<Trial> = cases
        .into_iter()
        .map(|case| {
            let slow = case.tier() == Tier::Slow;
            let name = case.folder.clone();
            let root = root.clone();
            Trial::test(name, move || check(&root, &case)).with_ignored_flag(slow)
        })
        .collect();
    libtest_mimic::run(&args, trials).exit();
}
