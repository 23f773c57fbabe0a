//! What a spectrum reader hands over: each channel's spectrum at each time ([`SpectrumRow`],
//! to a [`SpectrumSink`]), and what it found in the file besides ([`FileFacts`]).
//!
//! A frame is every channel's spectrum at one time: the rows of one frame share their time and
//! follow each other in the file; a frame need not hold every channel (a missing channel's
//! gratings are gaps in that frame).

use fbg_shared::spectrum::{Grid, Spectrum};

use super::super::problems::{Problems, RowError};
use super::super::time_axis::TimeKind;

/// Largest channel number a file may use (a bound on what a corrupt cell can allocate).
pub(crate) const MAX_CHANNELS: usize = 64;

/// One channel's spectrum at one time.
pub(crate) struct SpectrumRow<'a> {
    /// Time on the file's axis \[s\].
    pub t: f64,
    /// Physical line of the row (of the spectrum's values).
    pub line: u64,
    /// Channel, 0-based.
    pub channel: usize,
    /// Linear intensities on the file's grid.
    pub spectrum: Spectrum<'a, f64>,
}

/// Receives a file's spectra in file order; a refused row comes back as a [`RowError`] for the
/// reader's `--on-error` policy.
pub(crate) trait SpectrumSink {
    /// One channel's spectrum.
    fn spectrum(&mut self, row: SpectrumRow<'_>) -> Result<(), RowError>;
}

/// What a reader found in a file besides its spectra.
pub(crate) struct FileFacts {
    /// The wavelength grid.
    pub grid: Grid<f64>,
    /// Samples per spectrum.
    pub points: usize,
    /// Lines before the first spectrum (header, metadata).
    pub metadata_lines: usize,
    /// Seconds or timestamps.
    pub time_kind: TimeKind,
    /// Calendar time.
    pub absolute: bool,
    /// The time column, for messages.
    pub time_column: String,
    /// The culture the file was read in (`de-DE (line 3)`), if any.
    pub culture: Option<String>,
    /// Bad rows.
    pub problems: Problems,
}

/// The grid in words: `uniform, 1530.000 nm + 0.008 nm·p, 1001 points`.
pub(crate) fn describe_grid(grid: &Grid<f64>, points: usize) -> String {
    match grid {
        Grid::Uniform { start_nm, step_nm } => {
            format!("uniform, {} nm + {} nm·p, {points} points", short(*start_nm), short(*step_nm))
        }
        Grid::Polynomial { coefficients } => {
            let c: Vec<String> = coefficients.iter().map(|c| format!("{c:e}")).collect();
            format!("polynomial λ = Σ cₖ·pᵏ nm, c = [{}], {points} pixels", c.join(", "))
        }
    }
}

/// `v` with at most 9 decimals, trailing zeros dropped (a grid step computed from its ends
/// prints as `0.01`, not `0.010000000000000004`).
fn short(v: f64) -> String {
    let s = format!("{v:.9}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}
