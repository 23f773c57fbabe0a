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
    /// An option out of its range, refused before any work (a fit's options, a command's
    /// flag); the message names the option, so it is printed as it is (no `fit: ` before it),
    /// and a front end may put its own spelling of the option first (`--drift-spec: …`).
    Options { message: String },
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
    /// The caller asked the work to stop (a fit's cancel flag: Ctrl-C in Python).
    Interrupted { what: String },
}

impl TrainerError {
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        TrainerError::Io { path: path.to_path_buf(), source }
    }
    pub fn data(path: &str, line: u64, column: &str, message: impl Into<String>) -> Self {
        // The column is a header cell when a file has no such column: quoted like any cell.
        TrainerError::Data { path: path.to_string(), line, column: quote_cell(column), message: message.into() }
    }
    pub fn fit(message: impl Into<String>) -> Self {
        TrainerError::Fit { message: message.into() }
    }
    pub fn options(message: impl Into<String>) -> Self {
        TrainerError::Options { message: message.into() }
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
            TrainerError::Options { message } => f.write_str(message),
            TrainerError::Model { path, message } => write!(f, "{path}: {message}"),
            TrainerError::Output { path, message } => write!(f, "{}: {message}", path.display()),
            TrainerError::Device { message } => f.write_str(message),
            TrainerError::Interrupted { what } => write!(f, "{what}: interrupted"),
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

/// Characters of a cell an error message quotes; the rest is elided.
pub const QUOTE_CHARS: usize = 40;

/// A cell (or any text read from a user's file) as an error message quotes it: at most
/// [`QUOTE_CHARS`] characters, then `…` and the cell's length, so a 20 MB cell is not
/// printed whole.
pub fn quote_cell(cell: &str) -> String {
    match cell.char_indices().nth(QUOTE_CHARS) {
        None => cell.to_string(),
        Some((cut, _)) => format!("{}… ({} bytes)", &cell[..cut], cell.len()),
    }
}

/// A number read from a user's file as an error message prints it: the shortest form that
/// reads back to the same value, in exponent form when the plain one would be long (`{}`
/// prints 1e308 as 309 digits), so never more than [`QUOTE_CHARS`] characters.
pub fn quote_number(v: f64) -> String {
    ShortNumber(v).to_string()
}

/// [`quote_number`] as a `Display` (nothing formatted until a message is).
#[derive(Clone, Copy, Debug)]
pub struct ShortNumber(pub f64);

impl std::fmt::Display for ShortNumber {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (v, a) = (self.0, self.0.abs());
        if !v.is_finite() || a == 0.0 || (1e-4..1e15).contains(&a) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quotes_are_cut_to_forty_characters() {
        assert_eq!(quote_cell("1545.0"), "1545.0");
        let forty = "x".repeat(QUOTE_CHARS);
        assert_eq!(quote_cell(&forty), forty);
        let big = "é".repeat(20_000_000);
        let q = quote_cell(&big);
        assert_eq!(q, format!("{}… (40000000 bytes)", "é".repeat(QUOTE_CHARS)));
        let e = TrainerError::data("f.csv", 3, &"c".repeat(1000), "bad");
        assert!(e.to_string().len() < 100, "{e}");
    }

    #[test]
    fn numbers_print_short_and_read_back() {
        for (v, s) in [
            (1545.031, "1545.031"),
            (-250.5, "-250.5"),
            (0.0, "0"),
            (1e308, "1e308"),
            (-1.7976931348623157e308, "-1.7976931348623157e308"),
            (1e15, "1e15"),
            (5e-324, "5e-324"),
            (1.25e-5, "1.25e-5"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(quote_number(v), s);
            assert!(quote_number(v).chars().count() <= QUOTE_CHARS);
            if v.is_finite() {
                assert_eq!(quote_number(v).parse::<f64>().unwrap().to_bits(), v.to_bits());
            }
        }
    }
}
