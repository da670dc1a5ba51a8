//! The one error type of porelab. Bad input is an `Err` whose message names the value and
//! the rule it breaks; nothing in the library panics on user input.

/// Errors returned by porelab.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A value supplied by the user breaks a rule (the message names value and rule).
    #[error("{0}")]
    InvalidInput(String),
    /// A file could not be read or parsed (the message names the file and, where known, the line).
    #[error("{path}: {msg}")]
    File { path: String, msg: String },
    /// A validation case could not be run or did not pass.
    #[error("{0}")]
    Validation(String),
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

pub type Result<T> = std::result::Result<T, Error>;

/// Shorthand for `Err(Error::InvalidInput(..))`.
pub fn invalid<T>(msg: impl Into<String>) -> Result<T> {
    Err(Error::InvalidInput(msg.into()))
}

/// `Ok(value)` when it is positive and finite, else the error "{what}: must be positive and
/// finite", where `what` names the quantity with its value and unit (e.g. "cylinder radius -1 m").
pub fn require_positive(value: f64, what: impl FnOnce() -> String) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(Error::InvalidInput(format!(
            "{}: must be positive and finite",
            what()
        )))
    }
}
