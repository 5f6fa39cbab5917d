//! The JSON `stats` and `check` print for more than one file: each file's report under its path,
//! then their total (the engine's `StatsTotal` or `CheckTotal`). The shape is the command line's
//! own output, so it lives here, not in the engine.

use serde::Serialize;

/// Several files' reports, each with its path, and their total.
#[derive(Debug, Clone, Serialize)]
pub struct PerFile<T, Total> {
    /// Each file's report.
    pub files: Vec<Named<T>>,
    /// Their total.
    pub total: Total,
}

/// One file's report with its path first.
#[derive(Debug, Clone, Serialize)]
pub struct Named<T> {
    /// The file's path as given.
    pub path: String,
    /// Its report.
    #[serde(flatten)]
    pub report: T,
}
