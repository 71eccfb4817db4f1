//! Why a log cannot be replayed: every error names the file, and a malformed value its line (or
//! MCAP message), its column and the range it must lie in.

use std::fmt;
use std::path::PathBuf;

/// Where in a log a problem is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A CSV line, 1-based (the header is line 1).
    Line(usize),
    /// A `/joint_states` message of an MCAP file, 1-based.
    Message(usize),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Line(n) => write!(f, "line {n}"),
            Self::Message(n) => write!(f, "/joint_states message {n}"),
        }
    }
}

/// A CSV column or a message field, as an error names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    /// 1-based column number (0 for a message field).
    pub number: usize,
    /// Header name or field name (`q4`, `position[3]`).
    pub name: String,
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.number > 0 {
            write!(f, "column {} (`{}`)", self.number, self.name)
        } else {
            write!(f, "field `{}`", self.name)
        }
    }
}

/// Why a log cannot be replayed.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The file cannot be opened.
    #[error("cannot open the log {path}: {source}")]
    Open {
        /// The path given.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The path is a symbolic link (refused: give the file itself).
    #[error("{path} is a symbolic link; give the log file itself")]
    Symlink {
        /// The path given.
        path: PathBuf,
    },
    /// The path is not a regular file (a directory, FIFO or device).
    #[error("{path} is not a regular file")]
    NotAFile {
        /// The path given.
        path: PathBuf,
    },
    /// The file is larger than a replay reads.
    #[error(
        "{path}: {bytes} bytes, more than the {limit} bytes a replayed log may have; \
         cut it into shorter logs"
    )]
    TooLarge {
        /// The path given.
        path: PathBuf,
        /// Its size (or the bytes read before giving up), bytes.
        bytes: u64,
        /// The limit, bytes.
        limit: u64,
    },
    /// The log has more rows than a replay holds.
    #[error("{path}: more than {limit} rows; cut it into shorter logs")]
    TooManyRows {
        /// The path given.
        path: PathBuf,
        /// The limit, rows.
        limit: usize,
    },
    /// The log has fewer than two rows (nothing to interpolate).
    #[error("{path}: {rows} data rows; a replay needs at least 2")]
    TooShort {
        /// The path given.
        path: PathBuf,
        /// Rows found.
        rows: usize,
    },
    /// A line, message or value is malformed or out of range.
    #[error("{path}: {at}{}: {problem}", column.as_ref().map(|c| format!(", {c}")).unwrap_or_default())]
    Invalid {
        /// The path given.
        path: PathBuf,
        /// The line or message.
        at: Location,
        /// The column or field, when one is at fault.
        column: Option<Column>,
        /// What is wrong, with the allowed range.
        problem: String,
    },
    /// The file as a whole is not a log this replay reads (unreadable MCAP, wrong schema).
    #[error("{path}: {problem}")]
    Format {
        /// The path given.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The replay's cycle is out of range.
    #[error("cycle_ms must be 1..=100 ms, got {cycle_ms}")]
    Cycle {
        /// The cycle asked for, ms.
        cycle_ms: u32,
    },
    /// Reading failed.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The path given.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
}
