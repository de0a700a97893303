//! What can be wrong with a log, located.

use thiserror::Error;

/// A log that cannot be read, or a column mapping that cannot be used: the file, the line and
/// column where known, and what was expected.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{file}: {}{}{message}", line.map(|l| format!("line {l}: ")).unwrap_or_default(), column.as_ref().map(|c| format!("column {c}: ")).unwrap_or_default())]
pub struct LogError {
    /// The file as named to the reader (or the option, for a column mapping).
    pub file: String,
    /// The 1-based line, where the problem is in one.
    pub line: Option<u64>,
    /// The column (as the log names it), where the problem is in one.
    pub column: Option<String>,
    /// What is wrong and what was expected.
    pub message: String,
}

impl LogError {
    /// A problem of the whole file.
    pub fn file(file: &str, message: impl Into<String>) -> Self {
        LogError {
            file: file.to_string(),
            line: None,
            column: None,
            message: message.into(),
        }
    }

    /// A problem on one line (and column).
    pub fn at(file: &str, line: u64, column: Option<&str>, message: impl Into<String>) -> Self {
        LogError {
            file: file.to_string(),
            line: Some(line),
            column: column.map(str::to_string),
            message: message.into(),
        }
    }
}
