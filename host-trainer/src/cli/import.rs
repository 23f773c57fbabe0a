//! `fbg-trainer import`: an interrogator export into the dataset CSV.

use std::path::PathBuf;

use anyhow::{bail, Result};

use fbg_trainer::data::files::check_outputs;
use fbg_trainer::data::import::{self, ImportOptions, SplitChoice};
use fbg_trainer::data::record_meta::sidecar_path;
use fbg_trainer::export;

use crate::utc_timestamp;

/// Import a real interrogator export into the dataset CSV (--format): ENLIGHT / Hyperion
/// peaks (`enlight`, the references from --refs), any logger CSV whose columns a map names
/// (`csv`), or spectra whose peaks are detected per grating (`spectra-csv`,
/// `enlight-responses`, `pixels`).
#[derive(clap::Args)]
pub struct ImportArgs {
    /// Input layout: ENLIGHT peaks, a logger CSV, or spectra (a `t_s,channel,<wavelengths>`
    /// CSV, an ENLIGHT / Hyperion Responses export, a spectrometer's `t_s,channel,p0,…` pixels
    /// with the map's [spectra] pixel_to_nm).
    #[arg(long, value_parser = ["enlight", "csv", "spectra-csv", "enlight-responses", "pixels"])]
    format: String,
    /// The export (ENLIGHT peaks file, logger CSV or spectrum file).
    file: PathBuf,
    /// Map (TOML): which column or peak is what, in which unit (docs/reference/file-formats.md,
    /// "Import maps").
    #[arg(long)]
    map: Option<PathBuf>,
    /// ENLIGHT: CSV with time, ambient temperature and references, read with the map's
    /// column mapping and interpolated onto the peak times.
    #[arg(long)]
    refs: Option<PathBuf>,
    /// Output dataset CSV (DESIGN §3 columns; directory created when missing).
    #[arg(long, default_value = "data.csv")]
    out: PathBuf,
    /// Rows up to this time calibrate: seconds from the first row, or a timestamp.
    #[arg(long, conflicts_with = "cal_fraction", allow_negative_numbers = true)]
    cal_until: Option<String>,
    /// Fraction of the record's duration that calibrates [default: 0.5].
    #[arg(long, allow_negative_numbers = true)]
    cal_fraction: Option<f64>,
    /// Bad rows: stop with an error naming file, line and column, or skip and count them.
    #[arg(long, value_parser = ["fail", "skip"], default_value = "fail")]
    on_error: String,
    /// With --on-error skip: the largest share of a file's rows, in percent, that may be
    /// skipped; above it the import fails with the counts by reason.
    #[arg(long, default_value_t = 100.0 * import::DEFAULT_MAX_SKIPPED, allow_negative_numbers = true)]
    max_skipped: f64,
    /// Zero absolute wavelengths on this model's λ_ref (a field record read against its
    /// calibration's zero) instead of the map's `ref_nm` or the first reading.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Absolute time of the first row (UTC, `YYYY-MM-DDThh:mm:ss[.fff]`) for an export whose
    /// times are plain seconds: the band's clock.
    #[arg(long)]
    start: Option<String>,
    /// Spectrum formats: the intensities are linear (counts, mW) or dB [default: the map's
    /// [spectra] scale, else dB for enlight-responses and linear for the others].
    #[arg(long, value_parser = ["linear", "db"])]
    scale: Option<String>,
    /// Print the import summary (rows, skips by reason, gratings, references, split) as
    /// JSON on stdout.
    #[arg(long)]
    json: bool,
}

impl ImportArgs {
    pub fn run(self) -> Result<()> {
        let max_skipped = self.max_skipped;
        if !(0.0..=100.0).contains(&max_skipped) {
            bail!("--max-skipped must be a percentage from 0 to 100 (got {max_skipped})");
        }
        let split = match self.cal_until {
            Some(t) => SplitChoice::Until(t),
            None => SplitChoice::Fraction(self.cal_fraction.unwrap_or(0.5)),
        };
        split.check()?;
        let opts = ImportOptions {
            format: self.format.parse().map_err(anyhow::Error::msg)?,
            input: self.file,
            map: self.map,
            refs: self.refs,
            split,
            on_error: self.on_error.parse().map_err(anyhow::Error::msg)?,
            max_skipped: max_skipped / 100.0,
            zero_from: match &self.model {
                Some(m) => {
                    let p = export::read_blob(m)?;
                    Some(import::ModelZero {
                        model: m.display().to_string(),
                        lambda_ref_nm: (0..p.dims.gratings()).map(|g| p.field.lambda_ref(g)).collect(),
                    })
                }
                None => None,
            },
            start_unix_s: self.start.as_deref().map(|s| utc_timestamp(s, "--start")).transpose()?,
            scale: self.scale.as_deref().map(str::parse).transpose().map_err(anyhow::Error::msg)?,
        };
        let mut inputs = vec![opts.input.as_path()];
        inputs.extend(self.model.as_deref());
        inputs.extend(opts.map.as_deref());
        inputs.extend(opts.refs.as_deref());
        check_outputs(&[&self.out, &sidecar_path(&self.out)], &inputs)?;
        let s = import::import_to_csv(&opts, &self.out)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&s)?);
        } else {
            eprintln!("{}", s.text());
        }
        Ok(())
    }
}
