//! Validation tree: case discovery, tolerance policy, comparison and reports, shared by
//! `tests/validation.rs` and `porelab validate`.
//!
//! A case is a folder `validation/NNN-slug/` with a `case.toml` ([`CaseSpec`]), an expected
//! table and `snapshots/`. Its runner (registered next to its function, see [`case::runner_for`]) returns the
//! checked [`Row`]s; the harness passes the case iff every row is finite and
//! `|got - expected| <= atol + rtol * scale` ([`Tolerance`]).

pub mod case;
pub mod cases;
pub mod harness;
pub mod report;
pub mod spec;
pub mod table;

pub use crate::io::repo_root;
pub use case::{CaseContext, Row, Runner};
pub use harness::{
    decade, discover, evaluate, run_case, run_case_with, Case, Outcome, Stats, Verdict,
};
pub use report::write_atomic;
pub use spec::{CaseSpec, Oracle, Tier, Tolerance};
pub use table::Table;

use crate::Result;
use rayon::prelude::*;
use std::process::ExitCode;

/// Which of `cases` a `validate` run selects: with no prefixes, every case of the fast tier
/// (all tiers with `all`); with prefixes, the cases whose folder name starts with one of
/// them, including slow ones (they were named explicitly). A prefix that matches nothing is
/// an error.
pub fn select<'a>(cases: &'a [Case], ids: &[String], all: bool) -> Result<Vec<&'a Case>> {
    if ids.is_empty() {
        return Ok(cases
            .iter()
            .filter(|c| all || c.tier() == Tier::Fast)
            .collect());
    }
    for p in ids {
        if !cases.iter().any(|c| c.folder.starts_with(p.as_str())) {
            let known: Vec<&str> = cases.iter().map(|c| c.folder.as_str()).collect();
            return Err(crate::Error::InvalidInput(format!(
                "no validation case matches '{p}' (cases: {})",
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            )));
        }
    }
    Ok(cases
        .iter()
        .filter(|c| ids.iter().any(|p| c.folder.starts_with(p.as_str())))
        .collect())
}

/// `porelab validate [IDS] [--all]`: runs the selected cases (in parallel), prints a table to
/// stdout, writes `target/porelab/validation-report.{csv,md}` under the repository root.
/// Exit code 0 when every case passes, 1 otherwise.
pub fn cli_validate(ids: &[String], all: bool) -> Result<ExitCode> {
    let root = repo_root();
    let cases = discover(&root)?;
    let selected = select(&cases, ids, all)?;
    if selected.is_empty() {
        // Zero work is a failure, not a pass (a wrong PORELAB_ROOT or id finds nothing).
        let skipped = cases.len();
        return crate::error::invalid(format!(
            "no validation cases to run under {}{}: nothing was checked",
            root.join("validation").display(),
            if skipped > 0 {
                format!(" ({skipped} cases not selected; slow ones need --all)")
            } else {
                " (no NNN-slug/case.toml folders; check PORELAB_ROOT)".to_string()
            }
        ));
    }
    let n = selected.len();
    eprintln!(
        "running {n} validation case(s) from {}",
        root.join("validation").display()
    );
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut outcomes: Vec<Outcome> = selected
        .par_iter()
        .map(|c| {
            let o = run_case(&root, c);
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            eprintln!(
                "[{k}/{n}] {} {} ({:.2} s)",
                o.folder,
                o.verdict().as_str(),
                o.seconds
            );
            o
        })
        .collect();
    outcomes.sort_by(|a, b| a.folder.cmp(&b.folder));
    print!("{}", report::text_table(&outcomes));
    let count = |v: Verdict| outcomes.iter().filter(|o| o.verdict() == v).count();
    let (failed, deviations) = (count(Verdict::Fail), count(Verdict::Deviation));
    let skipped = cases.len() - n;
    println!(
        "\n{} passed, {failed} failed{}{}",
        count(Verdict::Pass),
        if deviations > 0 {
            format!(", {deviations} documented deviation(s) (not passes)")
        } else {
            String::new()
        },
        if skipped > 0 {
            format!(", {skipped} not selected")
        } else {
            String::new()
        }
    );
    let [csv, md, html, rows] =
        report::write_reports(&root.join("target").join("porelab"), &outcomes)?;
    println!(
        "reports: {}, {} and {} (a browser opens it); every checked number: {}",
        csv.display(),
        md.display(),
        html.display(),
        rows.display()
    );
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn case(folder: &str, tier: Tier) -> Case {
        let text = format!(
            "id = \"{}\"\ntitle = \"t\"\nseed_doc = \"s\"\nequation = \"e\"\noracle = \"analytic\"\nrtol = 1.0\ntier = \"{tier}\"\nexpected = \"expected.csv\"\n",
            &folder[..3]
        );
        Case {
            folder: folder.into(),
            id: folder[..3].into(),
            dir: PathBuf::from(folder),
            spec: CaseSpec::parse(&text, &folder[..3]),
        }
    }

    #[test]
    fn selection() {
        let cs = vec![
            case("101-a", Tier::Fast),
            case("102-b", Tier::Slow),
            case("201-c", Tier::Fast),
        ];
        let names = |v: Vec<&Case>| v.iter().map(|c| c.folder.clone()).collect::<Vec<_>>();
        assert_eq!(names(select(&cs, &[], false).unwrap()), ["101-a", "201-c"]);
        assert_eq!(names(select(&cs, &[], true).unwrap()).len(), 3);
        assert_eq!(
            names(select(&cs, &["1".into()], false).unwrap()),
            ["101-a", "102-b"]
        );
        assert_eq!(
            names(select(&cs, &["102".into()], false).unwrap()),
            ["102-b"]
        );
        let e = select(&cs, &["9".into()], false).unwrap_err().to_string();
        assert!(e.contains("'9'") && e.contains("101-a"), "{e}");
    }
}
