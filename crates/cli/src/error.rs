//! One error type for every subcommand: a readable message and the process exit code.

use std::fmt;

/// A failed command. `Usage` (exit 2) is a bad argument; `Failed` (exit 1) is bad input data or a
/// result the user asked us to treat as failure; `Interrupted` (exit 130, as for SIGINT) is a run
/// stopped by Ctrl-C after saving what it had.
#[derive(Debug)]
pub enum CliError {
    Usage(String),
    Failed(String),
    Interrupted(String),
}

impl CliError {
    pub fn usage(msg: impl Into<String>) -> Self {
        CliError::Usage(msg.into())
    }
    pub fn failed(msg: impl Into<String>) -> Self {
        CliError::Failed(msg.into())
    }
    pub fn interrupted(msg: impl Into<String>) -> Self {
        CliError::Interrupted(msg.into())
    }
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Usage(_) => 2,
            CliError::Failed(_) => 1,
            CliError::Interrupted(_) => 130,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Usage(m) | CliError::Failed(m) | CliError::Interrupted(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CliError {}
