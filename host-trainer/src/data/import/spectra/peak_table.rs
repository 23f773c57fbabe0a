//! `fbg-trainer peaks`: each frame's peak per grating with its quality, as a CSV.
//!
//! Columns: `t_s` (seconds from the first frame), `timestamp` (calendar time, empty for a
//! file in plain seconds), `line` (the line of the grating's channel's spectrum in the input), `grating` (1-based, the
//! dataset's dlN), `channel` (1-based), `wavelength_nm` (empty without a peak), `snr_db`
//! (10·log₁₀(height/σ)), `fwhm_nm`, `amplitude` and `floor` (in the file's linear intensity
//! unit), `flags` (`ok`, or the names joined by `|`: `low-snr|second-peak`), `method`. A
//! frame without the grating's channel has no row.

use std::io::Write;
use std::path::Path;

use serde::Serialize;

use super::super::problems::{self, FileSkips};
use super::super::summary::SpectraInfo;
use super::super::{ImportOptions, Map};
use crate::data::files::write_atomically;
use crate::data::timestamp::format_timestamp;
use crate::error::TrainerError;

/// The header of the peaks table.
pub const PEAKS_HEADER: &str =
    "t_s,timestamp,line,grating,channel,wavelength_nm,snr_db,fwhm_nm,amplitude,floor,flags,method";

/// What `peaks` did.
#[derive(Clone, Debug, Serialize)]
pub struct PeaksSummary {
    /// The input file.
    pub input: String,
    /// The table written.
    pub out: String,
    /// Rows written (one per frame and grating whose channel the frame holds).
    pub rows_written: usize,
    /// Bad rows of the input (`--on-error skip`).
    pub skipped: FileSkips,
    /// The file, the detection and the flagged frames per grating.
    pub spectra: SpectraInfo,
}

impl PeaksSummary {
    /// A few lines for a terminal.
    pub fn text(&self) -> String {
        let s = &self.spectra;
        let mut t = format!(
            "peaks of {}: {} frames, {} channels, {}; method {}; {} rows written to {}\n",
            self.input, s.frames, s.channels, s.grid, s.method, self.rows_written, self.out
        );
        if self.skipped.rows_skipped > 0 {
            t.push_str(&format!("  {} bad rows skipped\n", self.skipped.rows_skipped));
        }
        for f in &s.flagged {
            let by: Vec<String> = f.by_flag.iter().map(|(k, v)| format!("{k} {v}")).collect();
            let by = if by.is_empty() { String::new() } else { format!(" ({})", by.join(", ")) };
            t.push_str(&format!("  grating {}: {} frames, {} flagged{by}\n", f.output, f.frames, f.flagged));
        }
        t
    }
}

/// Read a spectrum file (`opts.format`, `opts.input`, `opts.map`, `opts.scale`,
/// `opts.on_error`, `opts.max_skipped`; the other options are the import's), detect the peaks
/// and write the table to `out` atomically.
pub fn peaks_to_csv(opts: &ImportOptions, out: &Path) -> Result<PeaksSummary, TrainerError> {
    let origin = opts.map.as_ref().map(|p| p.display().to_string());
    let map = match &opts.map {
        Some(p) => Some(Map::load(p)?),
        None => None,
    };
    if let (Some(m), Some(o)) = (&map, &origin) {
        m.validate(o, super::super::mapping::For::Spectra)?;
    }
    let read = super::read::<fbg_shared::spectrum::Peak<f64>>(
        opts.format,
        &opts.input,
        map.as_ref(),
        origin.as_deref().unwrap_or("map"),
        opts.scale,
        opts.on_error,
    )?;
    let skipped = read.facts.problems.summary();
    problems::refuse_too_many_skipped(std::slice::from_ref(&skipped), opts.max_skipped)?;
    let (_, spectra) = read.series(opts.format);
    let d = &read.detected;
    let t0 = d.t.first().copied().unwrap_or(0.0);
    let mut rows = 0usize;
    write_atomically(out, |w| {
        writeln!(w, "{PEAKS_HEADER}")?;
        for (k, &t) in d.t.iter().enumerate() {
            let stamp = if read.facts.absolute { format_timestamp(t) } else { String::new() };
            for (g, gp) in d.gratings.iter().enumerate() {
                let Some(Some(p)) = gp.peaks.get(k) else { continue };
                let line = gp.lines.get(k).copied().unwrap_or_default();
                let num = |v: f64, digits: usize| if v.is_finite() { format!("{v:.digits$}") } else { String::new() };
                let sci = |v: f64| if v.is_finite() { format!("{v:.6e}") } else { String::new() };
                let snr_db = if p.snr > 0.0 { p.snr_db() } else { f64::NAN };
                let flags = match (gp.implausible.get(k).copied().unwrap_or(false), p.flags.is_ok()) {
                    (false, _) => p.flags.to_string(),
                    (true, true) => super::plausible::IMPLAUSIBLE.to_string(),
                    (true, false) => format!("{}|{}", p.flags, super::plausible::IMPLAUSIBLE),
                };
                writeln!(
                    w,
                    "{:.6},{stamp},{line},{},{},{},{},{},{},{},{},{}",
                    t - t0,
                    g + 1,
                    gp.channel + 1,
                    num(p.wavelength_nm, 6),
                    num(snr_db, 2),
                    num(p.fwhm_nm, 5),
                    sci(p.amplitude),
                    sci(p.floor),
                    flags,
                    read.method_of(gp)
                )?;
                rows += 1;
            }
        }
        Ok(())
    })?;
    Ok(PeaksSummary {
        input: opts.input.display().to_string(),
        out: out.display().to_string(),
        rows_written: rows,
        skipped,
        spectra,
    })
}
