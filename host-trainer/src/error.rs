//! Errors of the trainer library. Every variant names the place: file, line, column or key.

use std::path::{Path, PathBuf};

/// What went wrong in the trainer.
#[derive(Debug)]
#[non_exhaustive]
pub enum TrainerError {
    /// A file could not be read or written.
    Io { path: PathBuf, source: std::io::Error },
    /// A scenario configuration problem.
    Config { origin: String, key: String, message: String },
    /// A data file problem at a line and column.
    Data { path: String, line: u64, column: String, message: String },
    /// A whole-dataset problem (too few samples, no variation, ...).
    Dataset { message: String },
    /// A model could not be fitted.
    Fit { message: String },
    /// A model file problem.
    Model { path: String, message: String },
    /// An output that must not be written (DESIGN §9): not a regular file, one of the inputs,
    /// or a directory that cannot be created or written.
    Output { path: PathBuf, message: String },
    /// Talking to a device over the serial link (`stream`, `device status`) cannot go on: the
    /// device cannot be reached, does not answer in time or answers otherwise than the host
    /// expects, or the record has nothing to stream; the message names the address, the
    /// request or the file.
    Device { message: String },
}

impl TrainerError {
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        TrainerError::Io { path: path.to_path_buf(), source }
    }
    pub fn data(path: &str, line: u64, column: &str, message: impl Into<String>) -> Self {
        TrainerError::Data { path: path.to_string(), line, column: column.to_string(), message: message.into() }
    }
    pub fn fit(message: impl Into<String>) -> Self {
        TrainerError::Fit { message: message.into() }
    }
    pub fn device(message: impl Into<String>) -> Self {
        TrainerError::Device { message: message.into() }
    }
}

impl std::fmt::Display for TrainerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TrainerError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            TrainerError::Config { origin, key, message } => {
                if key.is_empty() {
                    write!(f, "{origin}: {message}")
                } else {
                    write!(f, "{origin}: {key}: {message}")
                }
            }
            TrainerError::Data { path, line, column, message } => {
                write!(f, "{path}: line {line}, column {column}: {message}")
            }
            TrainerError::Dataset { message } => write!(f, "dataset: {message}"),
            TrainerError::Fit { message } => write!(f, "fit: {message}"),
            TrainerError::Model { path, message } => write!(f, "{path}: {message}"),
            TrainerError::Output { path, message } => write!(f, "{}: {message}", path.display()),
            TrainerError::Device { message } => f.write_str(message),
        }
    }
}

impl std::error::Error for TrainerError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        // `Io` already prints its cause in its message; returning it here too would make
        // anyhow's `{:#}` print the cause twice.
        None
    }
}

/// "line L, column C" (1-based) of a byte offset in `text`, for the position of a TOML error
/// (scenario files, import maps, fleet manifests).
pub(crate) fn line_col(text: &str, offset: usize) -> String {
    let before = text.get(..offset.min(text.len())).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("line {line}, column {col}")
}
