//! `fbg-trainer compensate`: run a model over a logged field record, as the device would.

use std::path::PathBuf;

use anyhow::Result;

use fbg_trainer::compensate::{self, FieldOptions, Precision};
use fbg_trainer::data::files::check_outputs;

use crate::utc_timestamp;

/// Compensate a logged field record with a model, as the device would: every row's
/// measurands with their 95 % band and flags; gaps stay gaps; references are optional (when
/// present, their errors are printed).
#[derive(clap::Args)]
pub struct CompensateArgs {
    /// The model blob (Model-H or Model-P).
    #[arg(long)]
    model: PathBuf,
    /// The record: `t_s`, `T_amb_C`, `dl1_pm..dl3_pm` (references and `split` optional).
    #[arg(long)]
    data: PathBuf,
    /// Output CSV: `t_s`, each measurand and its `_band95`, `flags` (bits: 1 non-finite, 2
    /// out of the calibration envelope or a jump faster than it showed, 4 weak RBF support, 8
    /// lead unknown, 16 implausible, 32/64 peak fault/quality, 128 fallback to Model-P: the
    /// memory not trusted for that row) and `flag_names`.
    #[arg(long)]
    out: PathBuf,
    /// Run the device's f32 arithmetic instead of the host's f64.
    #[arg(long)]
    f32: bool,
    /// Absolute time of the record's `t_s = 0` (UTC, `YYYY-MM-DDThh:mm:ss[.fff]`), when the
    /// record does not say: the band's lead is then absolute time since calibration.
    #[arg(long)]
    start: Option<String>,
    /// Compensate even when the shifts look like another unit than pm (against the
    /// model's calibration envelope).
    #[arg(long)]
    trust_units: bool,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    json: bool,
}

impl CompensateArgs {
    pub fn run(self) -> Result<()> {
        check_outputs(&[&self.out], &[&self.model, &self.data])?;
        let field = FieldOptions {
            start_unix_s: self.start.as_deref().map(|s| utc_timestamp(s, "--start")).transpose()?,
            trust_units: self.trust_units,
        };
        let precision = if self.f32 { Precision::F32 } else { Precision::F64 };
        let s = compensate::run(&self.model, &self.data, &self.out, precision, field, !self.json)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&s)?);
        } else {
            eprintln!("{}", s.text());
        }
        Ok(())
    }
}
