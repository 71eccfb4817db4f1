//! Errors of the mock robot library.

use thiserror::Error;

/// Why a simulation could not be configured, started or logged.
#[derive(Debug, Error)]
pub enum SimError {
    /// The scenario TOML text could not be parsed.
    #[error("scenario file is not valid TOML for a mock-robot scenario: {0}")]
    ScenarioParse(#[from] toml::de::Error),
    /// A configuration value is out of its allowed range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// Reading a scenario or writing a log or socket failed.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

/// Returns `Err(SimError::InvalidConfig)` with `message` unless `ok`.
pub(crate) fn ensure(ok: bool, message: impl FnOnce() -> String) -> Result<(), SimError> {
    if ok {
        Ok(())
    } else {
        Err(SimError::InvalidConfig(message()))
    }
}
