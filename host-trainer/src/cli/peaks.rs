//! `fbg-trainer peaks`: a spectrum file's peaks per frame and grating, with their quality.

use std::path::PathBuf;

use anyhow::{bail, Result};

use fbg_trainer::data::files::check_outputs;
use fbg_trainer::data::import::{self, ImportOptions, OnError, SplitChoice};

/// Detect the peaks of a spectrum file and write each frame's peak per grating with its
/// quality.
#[derive(clap::Args)]
pub struct PeaksArgs {
    /// Input layout: a `t_s,channel,<wavelengths>` CSV, an ENLIGHT / Hyperion Responses
    /// export, or a spectrometer's `t_s,channel,p0,…` pixels (with the map's [spectra]
    /// pixel_to_nm).
    #[arg(long, value_parser = ["spectra-csv", "enlight-responses", "pixels"])]
    format: String,
    /// The spectrum file.
    file: PathBuf,
    /// Map (TOML): the gratings' channels and windows ([[grating]] channel, window_nm, and a
    /// measured shape to refine each peak by: shape) and the detector's settings ([spectra]);
    /// without it each channel's peaks in its first spectrum become the gratings.
    #[arg(long)]
    map: Option<PathBuf>,
    /// The intensities are linear (counts, mW) or dB [default: the map's [spectra] scale, else
    /// dB for enlight-responses and linear for the others].
    #[arg(long, value_parser = ["linear", "db"])]
    scale: Option<String>,
    /// Output CSV: t_s, timestamp, line, grating, channel, wavelength_nm, snr_db, fwhm_nm,
    /// amplitude, floor, flags, method (directory created when missing).
    #[arg(long, default_value = "peaks.csv")]
    out: PathBuf,
    /// Bad rows: stop with an error naming file, line and column, or skip and count them.
    #[arg(long, value_parser = ["fail", "skip"], default_value = "fail")]
    on_error: String,
    /// With --on-error skip: the largest share of the file's rows, in percent, that may be
    /// skipped.
    #[arg(long, default_value_t = 100.0 * import::DEFAULT_MAX_SKIPPED, allow_negative_numbers = true)]
    max_skipped: f64,
    /// Print the summary (frames, gratings, flagged frames per flag) as JSON on stdout.
    #[arg(long)]
    json: bool,
}

impl PeaksArgs {
    pub fn run(self) -> Result<()> {
        if !(0.0..=100.0).contains(&self.max_skipped) {
            bail!("--max-skipped must be a percentage from 0 to 100 (got {})", self.max_skipped);
        }
        let on_error: OnError = self.on_error.parse().map_err(anyhow::Error::msg)?;
        let opts = ImportOptions {
            format: self.format.parse().map_err(anyhow::Error::msg)?,
            input: self.file,
            map: self.map,
            refs: None,
            split: SplitChoice::default(),
            on_error,
            max_skipped: self.max_skipped / 100.0,
            zero_from: None,
            start_unix_s: None,
            scale: self.scale.as_deref().map(str::parse).transpose().map_err(anyhow::Error::msg)?,
        };
        let mut inputs = vec![opts.input.as_path()];
        inputs.extend(opts.map.as_deref());
        check_outputs(&[&self.out], &inputs)?;
        let s = import::peaks_to_csv(&opts, &self.out)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&s)?);
        } else {
            eprintln!("{}", s.text());
        }
        Ok(())
    }
}
