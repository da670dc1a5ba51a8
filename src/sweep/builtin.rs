//! Built-in sweeps: the sweep files that redraw the seed figures (seed 000 Figs. 3-7, 9, 14),
//! and `porelab sweep figure NAME --out DIR`, which plans, runs and collects one of them.

use super::plan::{plan_text, write_plan};
use crate::error::{invalid, Result};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// A built-in sweep file: its name and text.
pub struct BuiltinSweep {
    pub name: &'static str,
    pub toml: &'static str,
}

/// Every built-in sweep, by name.
pub fn builtin_sweeps() -> Vec<BuiltinSweep> {
    macro_rules! sweep {
        ($name:literal) => {
            BuiltinSweep {
                name: $name,
                toml: include_str!(concat!("builtin/", $name, ".toml")),
            }
        };
    }
    vec![
        sweep!("deposition-fig3"),
        sweep!("deposition-fig5"),
        sweep!("deposition-fig7"),
        sweep!("deposition-fig14"),
    ]
}

#[derive(Debug, clap::Args)]
pub struct FigureArgs {
    /// The built-in sweep (see --list).
    name: Option<String>,
    /// The sweep folder (created; an existing one with the same plan is resumed).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Jobs at once.
    #[arg(long, default_value_t = 1)]
    jobs: usize,
    /// Worker threads per job (default: the cores divided by --jobs).
    #[arg(long)]
    threads: Option<usize>,
    /// Runs per point instead of the sweep's own (the seed's figures average 20).
    #[arg(long)]
    runs_per_point: Option<usize>,
    /// List the built-in sweeps with their titles.
    #[arg(long)]
    list: bool,
}

/// The title line of a sweep file's text.
fn title_of(text: &str) -> &str {
    text.lines()
        .find_map(|l| l.strip_prefix("title = \""))
        .map_or("", |t| t.trim_end_matches('"'))
}

/// The built-in sweep `name`'s text, with `runs_per_point` replaced when given.
pub fn sweep_text(name: &str, runs_per_point: Option<usize>) -> Result<String> {
    let all = builtin_sweeps();
    let Some(b) = all.iter().find(|b| b.name == name) else {
        let names: Vec<_> = all.iter().map(|b| b.name).collect();
        return invalid(format!(
            "no built-in sweep `{name}` (known: {})",
            names.join(", ")
        ));
    };
    let Some(n) = runs_per_point else {
        return Ok(b.toml.to_string());
    };
    if n == 0 {
        return invalid("--runs-per-point 0: must be at least 1".to_string());
    }
    Ok(b.toml
        .lines()
        .map(|l| {
            if l.starts_with("runs_per_point = ") {
                format!("runs_per_point = {n}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n")
}

/// `porelab sweep figure NAME --out DIR`: plan (or find the same plan), run the unfinished
/// jobs, collect. Exit 1 while any job is not done, as `sweep run`.
pub fn cli_figure(a: &FigureArgs) -> Result<ExitCode> {
    if a.list {
        for b in builtin_sweeps() {
            println!("{:<20} {}", b.name, title_of(b.toml));
        }
        return Ok(ExitCode::SUCCESS);
    }
    let (Some(name), Some(dir)) = (&a.name, &a.out) else {
        return invalid(
            "porelab sweep figure NAME --out DIR (or --list): both NAME and --out are needed"
                .to_string(),
        );
    };
    let text = sweep_text(name, a.runs_per_point)?;
    let plan = plan_text(&text, Path::new("."), &format!("builtin sweep {name}"))?;
    write_plan(&text, &plan, dir)?;
    let code = super::run::cli_run(dir, a.jobs, a.threads, false)?;
    // a partial table when some jobs are not done: the exit code says so
    super::cli_collect(dir, true)?;
    Ok(code)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every built-in sweep plans: each of its jobs' scenes passes its engine's checks.
    #[test]
    fn every_builtin_sweep_plans() {
        for b in builtin_sweeps() {
            let plan = plan_text(b.toml, Path::new("."), b.name)
                .unwrap_or_else(|e| panic!("{}: {e}", b.name));
            assert!(!plan.jobs.is_empty(), "{}", b.name);
            assert!(!title_of(b.toml).is_empty(), "{}", b.name);
        }
    }

    #[test]
    fn runs_per_point_is_replaced_and_zero_refused() {
        let t = sweep_text("deposition-fig3", Some(2)).unwrap();
        let plan = plan_text(&t, Path::new("."), "t").unwrap();
        assert_eq!(plan.jobs.len(), 8 * 3 * 2);
        assert!(sweep_text("deposition-fig3", Some(0)).is_err());
        assert!(sweep_text("nope", None)
            .unwrap_err()
            .to_string()
            .contains("known:"));
    }
}
