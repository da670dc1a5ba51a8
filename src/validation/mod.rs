//! Validation tree: case discovery, tolerance policy, comparison and reports, shared by
//! `tests/validation.rs` and `porelab validate`.

pub mod case;
pub mod cases;

pub use case::{CaseContext, Row, Runner};

use crate::Result;
use std::process::ExitCode;

/// `porelab validate [IDS] [--all]` (filled in by the harness).
pub fn cli_validate(_ids: &[String], _all: bool) -> Result<ExitCode> {
    Err(crate::Error::Validation("validate: not built yet".into()))
}
