//! The interface between the harness and the code of one validation case.
//!
//! A case runner computes, for every row it checks, the value porelab produced (`got`), the
//! independent expected value (`expected`) and the scale that a relative tolerance multiplies
//! (`scale`, usually |expected| or the magnitude of the vector the component belongs to).
//! The harness passes a row when |got - expected| <= atol + rtol * scale, with atol and rtol
//! from `case.toml` (for statistical cases `z` acts as atol on a row whose `got` is a z-score).

use crate::Result;
use std::path::PathBuf;

/// One checked number.
#[derive(Debug, Clone)]
pub struct Row {
    /// Where: a short label naming the input (e.g. "rho=1e-12,z=0.3").
    pub label: String,
    pub got: f64,
    pub expected: f64,
    /// Scale for the relative tolerance (> 0).
    pub scale: f64,
}

impl Row {
    pub fn new(label: impl Into<String>, got: f64, expected: f64, scale: f64) -> Self {
        Row {
            label: label.into(),
            got,
            expected,
            scale,
        }
    }
    /// Error relative to `scale`.
    pub fn rel_error(&self) -> f64 {
        (self.got - self.expected).abs() / self.scale
    }
}

/// What a runner gets: the case folder and the repository root.
#[derive(Debug, Clone)]
pub struct CaseContext {
    pub id: String,
    pub case_dir: PathBuf,
    pub repo_root: PathBuf,
    /// The `expected` entry of case.toml (a path relative to the case folder, or starting with
    /// `reference/` for a table in the repository's reference folder).
    pub expected: String,
    /// The fixed seed of case.toml, for random cases.
    pub seed: Option<u64>,
}

/// A case runner: returns the checked rows, or an error (which fails the case).
pub type Runner = fn(&CaseContext) -> Result<Vec<Row>>;

/// A runner and the case numbers it answers, registered next to its function (see
/// `src/validation/cases/mod.rs`).
pub struct Registration {
    pub ids: &'static [&'static str],
    pub run: Runner,
}

/// Every registered runner, gathered at link time.
#[linkme::distributed_slice]
pub static RUNNERS: [Registration];

/// The runner registered for case `id` ("104"), if there is one.
pub fn runner_for(id: &str) -> Option<Runner> {
    RUNNERS.iter().find(|r| r.ids.contains(&id)).map(|r| r.run)
}

/// Case numbers registered more than once (each such number is a mistake: which runner would
/// answer it depends on link order).
pub fn registered_twice() -> Vec<&'static str> {
    let mut ids: Vec<&str> = RUNNERS.iter().flat_map(|r| r.ids.iter().copied()).collect();
    ids.sort_unstable();
    let mut twice: Vec<&str> = ids
        .windows(2)
        .filter(|w| w[0] == w[1])
        .map(|w| w[0])
        .collect();
    twice.dedup();
    twice
}
