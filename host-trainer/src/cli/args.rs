//! The arguments several commands share: where a scenario comes from, the model variant, the
//! signing flags; and the command line's names of the library's enums.

use std::path::PathBuf;

use anyhow::Result;
use clap::builder::PossibleValue;
use clap::ValueEnum;

use fbg_trainer::fit::FeatureChoice;
use fbg_trainer::sign::{self, BlobSigner, SignOptions};
use fbg_trainer::sim::scenario::{Preset, ScenarioConfig};

/// Where the scenario comes from.
#[derive(clap::Args, Clone)]
pub struct ScenarioArgs {
    /// Built-in scenario preset.
    #[arg(long, value_enum, default_value = "paper", conflicts_with = "config")]
    pub preset: PresetArg,
    /// Scenario TOML file; keys not given keep the `paper` defaults.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Random seed.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
}

impl ScenarioArgs {
    /// The scenario: the file's, else the preset's.
    pub fn load(&self) -> Result<ScenarioConfig> {
        match &self.config {
            Some(p) => Ok(ScenarioConfig::from_toml_file(p)?),
            None => Ok(self.preset.0.config()),
        }
    }
}

/// A [`Preset`] on the command line: its name, its description in `--help`.
#[derive(Clone, Copy, Debug)]
pub struct PresetArg(pub Preset);

const PRESETS: [PresetArg; Preset::ALL.len()] = {
    let mut all = [PresetArg(Preset::Paper); Preset::ALL.len()];
    let mut i = 0;
    while i < all.len() {
        all[i] = PresetArg(Preset::ALL[i]);
        i += 1;
    }
    all
};

impl ValueEnum for PresetArg {
    fn value_variants<'a>() -> &'a [Self] {
        &PRESETS
    }
    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.0.name()).help(self.0.description()))
    }
}

/// A [`FeatureChoice`] on the command line: its name only (`--help` lists the names on one
/// line; `train --help` explains them).
#[derive(Clone, Copy, Debug)]
pub struct FeaturesArg(pub FeatureChoice);

const FEATURES: [FeaturesArg; FeatureChoice::ALL.len()] = {
    let mut all = [FeaturesArg(FeatureChoice::Memory); FeatureChoice::ALL.len()];
    let mut i = 0;
    while i < all.len() {
        all[i] = FeaturesArg(FeatureChoice::ALL[i]);
        i += 1;
    }
    all
};

impl ValueEnum for FeaturesArg {
    fn value_variants<'a>() -> &'a [Self] {
        &FEATURES
    }
    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.0.name()))
    }
}

/// `--sign KEY [--serial N] [--allow-rollback]` of `train`, `recalibrate` and `fleet`.
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct SignArgs {
    /// Sign the written blob(s) with this private key (from `fbg-trainer keygen`): a signature
    /// trailer with the key id and a serial follows the blob's CRC; devices accept signed
    /// models only.
    #[arg(long, value_name = "KEY")]
    pub sign: Option<PathBuf>,
    /// Serial of the signature (default: the next serial of the key id, kept in its ledger in
    /// the signing state directory).
    #[arg(long, requires = "sign")]
    pub serial: Option<u64>,
    /// Sign a rollback: a device built to accept rollbacks accepts this model over the one
    /// serial `--replaces` names (only while that serial runs), although its `--serial` is
    /// lower.
    #[arg(long, requires_all = ["sign", "serial", "replaces"])]
    pub allow_rollback: bool,
    /// The serial a rollback may replace (with `--allow-rollback`; above `--serial`).
    #[arg(long, value_name = "N", requires = "allow_rollback")]
    pub replaces: Option<u64>,
    /// The signing state directory holding the serial ledger per key id (default:
    /// `$FBG_SIGNING_STATE_DIR`, else `$XDG_STATE_HOME/fbg-trainer/signing`, else
    /// `~/.local/state/fbg-trainer/signing`).
    #[arg(long, value_name = "DIR", requires = "sign")]
    pub serial_state: Option<PathBuf>,
}

impl SignArgs {
    /// The signing options, when `--sign` was given.
    pub fn options(&self) -> Option<SignOptions> {
        self.sign.as_ref().map(|key| SignOptions {
            key: key.clone(),
            serial: self.serial,
            allow_rollback: self.allow_rollback,
            replaces: self.replaces,
            state_dir: self.serial_state.clone(),
        })
    }

    /// Load the signer, when `--sign` was given (a private key readable by others is warned
    /// about on stderr).
    pub fn signer(&self) -> Result<Option<BlobSigner>> {
        let Some(opts) = self.options() else { return Ok(None) };
        let s = BlobSigner::load(&opts)?;
        if s.too_open {
            eprintln!(
                "warning: {} can be read by other users; a lab key should be private (chmod 600)",
                s.path().display()
            );
        }
        Ok(Some(s))
    }

    /// The files of the signing key a command reads or updates (the key, its serial state and
    /// lock): never an output.
    pub fn key_files(&self) -> Vec<PathBuf> {
        sign::key_inputs(self.options().as_ref())
    }
}

/// `--snr-db` of `simulate` and `demo`, checked before anything is simulated, naming the flag.
pub fn check_snr_db(snr_db: f64) -> Result<()> {
    if !fbg_trainer::sim::spectrum::DetectorModel::accepts_snr_db(snr_db) {
        anyhow::bail!("--snr-db: {} is not a number of dB", fbg_trainer::error::ShortNumber(snr_db));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_names_are_the_library_names() {
        for (a, p) in PRESETS.iter().zip(Preset::ALL) {
            assert_eq!(a.to_possible_value().map(|v| v.get_name().to_string()).as_deref(), Some(p.name()));
            assert_eq!(PresetArg::from_str(p.name(), false).map(|a| a.0), Ok(p));
        }
        for (a, c) in FEATURES.iter().zip(FeatureChoice::ALL) {
            assert_eq!(a.to_possible_value().map(|v| v.get_name().to_string()).as_deref(), Some(c.name()));
            assert_eq!(FeaturesArg::from_str(c.name(), false).map(|a| a.0), Ok(c));
        }
    }
}
