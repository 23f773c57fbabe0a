//! `fbg-trainer compensate`: run a model over a logged field record, as the device would.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use fbg_trainer::compensate::{self, FieldOptions, Precision};
use fbg_trainer::data::files::check_outputs;
use fbg_trainer::sign::HostTrust;

use crate::utc_timestamp;

/// Compensate a logged field record with a model, as the device would: every row's
/// measurands with their 95 % band and flags; gaps stay gaps; references are optional (when
/// present, their errors are printed).
#[derive(clap::Args)]
pub struct CompensateArgs {
    /// The model blob (Model-H or Model-P).
    #[arg(long)]
    model: PathBuf,
    /// The record: `t_s`, the model's gratings `dl1_pm..dlN_pm` and `T_amb_C` when the model
    /// reads it (references and `split` optional).
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
    #[command(flatten)]
    trust: TrustArgs,
}

/// The signature check of a command that runs a model on the host.
#[derive(clap::Args)]
pub struct TrustArgs {
    /// A public key the model's signature is checked against (`lab.pub`, raw 32 bytes, or
    /// `lab.pub.hex`); repeat for several. A signed model that does not verify with them, or
    /// that no key was given for, is named on stderr.
    #[arg(long, value_name = "FILE")]
    pubkey: Vec<PathBuf>,
    /// Refuse a model that is unsigned, signed by a key not given with --pubkey, or changed
    /// after signing.
    #[arg(long)]
    require_signature: bool,
}

impl TrustArgs {
    /// Check the signatures of `models`: a warning on stderr for each that does not verify, an
    /// error instead when a signature is required.
    pub fn check(&self, models: &[&Path]) -> Result<()> {
        let trust = HostTrust::load(&self.pubkey, self.require_signature)?;
        for m in models {
            let bytes = std::fs::read(m).with_context(|| format!("{}: cannot read", m.display()))?;
            if let Some(w) = trust.check(m, &bytes)? {
                eprintln!("warning: {w}");
            }
        }
        Ok(())
    }

    /// The key files (inputs: no output may be one).
    pub fn inputs(&self) -> impl Iterator<Item = &Path> {
        self.pubkey.iter().map(PathBuf::as_path)
    }
}

impl CompensateArgs {
    pub fn run(self) -> Result<()> {
        // The record's sidecar (its zero and clock) is an input too.
        let side = fbg_trainer::data::record_meta::sidecar_path(&self.data);
        let inputs: Vec<&Path> =
            [self.model.as_path(), &self.data, &side].into_iter().chain(self.trust.inputs()).collect();
        check_outputs(&[&self.out], &inputs)?;
        self.trust.check(&[&self.model])?;
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
