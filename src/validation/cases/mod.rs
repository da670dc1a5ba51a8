//! Registry of case runners, keyed by the three-digit case id.

use super::case::Runner;

/// The runner for case `id` ("104"), if one is registered.
pub fn runner_for(id: &str) -> Option<Runner> {
    match id {
        _ => None,
    }
}
