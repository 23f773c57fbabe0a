//! `fbg-trainer simulate`: a simulated record, its `.record.json` (zero and clock) and its
//! `.meta.json` sidecar.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};

use fbg_trainer::data::files::{check_outputs, write_bytes_atomically, OutputSet};
use fbg_trainer::data::record_meta::sidecar_path;
use fbg_trainer::data::{Kind, Measurand};
use fbg_trainer::error::ShortNumber;
use fbg_trainer::sim::meta::{meta_path, SimMeta};
use fbg_trainer::sim::scenario::Pace;
use fbg_trainer::sim::spectrum::csv::write_spectra_csv;
use fbg_trainer::sim::spectrum::{DetectorModel, FrameSimulator, PixelGrid, SpectrumConfig};
use fbg_trainer::sim::{self, scenario::ScenarioConfig, Simulation};

use crate::args::ScenarioArgs;

/// Simulate an installation; write its CSV, its `.record.json` (zero and clock) and a
/// `.meta.json` sidecar (scenario, seed, per-sample oracle).
#[derive(clap::Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Output CSV.
    #[arg(long, default_value = "data.csv")]
    out: PathBuf,
    /// Print a JSON summary (samples, shape, std of each measurand, per-sample oracle) on stdout.
    #[arg(long)]
    json: bool,
    /// Also write the scenario as TOML (every parameter, for audit and editing).
    #[arg(long)]
    dump_config: Option<PathBuf>,
    /// An installation without an ambient thermometer: no `T_amb_C` column (the scenario
    /// key `ambient = false` does the same).
    #[arg(long)]
    no_ambient: bool,
    /// The same installation at another pace: the measurands' trajectories run F times
    /// faster (periods, holds, ramps and AR times ÷ F; 0.25 = four times slower); the
    /// instrument is unchanged (the scenario's `[pace] factor`).
    #[arg(long, value_name = "F", allow_negative_numbers = true)]
    pace: Option<f64>,
    /// With --pace: pace only this measurand (a column such as `p_kPa`).
    #[arg(long, value_name = "COLUMN", requires = "pace")]
    pace_of: Option<Measurand>,
    /// A steps record: the calibration part, then a hold-out stepping each measurand in
    /// turn through held levels (the scenario's `[steps]`).
    #[arg(long)]
    steps: bool,
    /// A plateau record: the calibration part, then a hold-out in which every measurand rests
    /// 4–16 h at random levels across its calibration range, with 10-min ramps (the
    /// scenario's `[plateaus]`).
    #[arg(long, conflicts_with = "steps")]
    plateaus: bool,
    /// Also write the record's simulated spectra to FILE (the spectra CSV: `t_s,channel,`
    /// then one column per grid wavelength in nm, one row per sample and channel, counts):
    /// uniform gratings of 0.3 nm FWHM at the record's wavelengths on a SLED, noise at
    /// --snr-db (the same frames `demo --spectra` detects for the same seed).
    #[arg(long, value_name = "FILE")]
    spectra: Option<PathBuf>,
    /// With --spectra: the pixel grid, `spectrometer` (512 pixels over 1510–1595 nm) or
    /// `swept` (8 pm, 10 626 points: about 60 kB per row and channel).
    #[arg(long, requires = "spectra", default_value = "spectrometer", value_parser = parse_grid)]
    grid: PixelGrid,
    /// With --spectra: the detector's SNR [dB], 10·log10(peak height/noise σ).
    #[arg(long, requires = "spectra", default_value_t = 30.0, allow_negative_numbers = true)]
    snr_db: f64,
}

fn parse_grid(s: &str) -> std::result::Result<PixelGrid, String> {
    PixelGrid::parse(s).ok_or_else(|| format!("`{s}`: `spectrometer` or `swept`"))
}

impl SimulateArgs {
    /// The scenario the flags ask for: the preset or file, then `--no-ambient`, `--pace`,
    /// `--steps`, `--plateaus`.
    fn scenario(&self) -> Result<ScenarioConfig> {
        let mut cfg = self.scenario.load()?;
        if self.no_ambient {
            cfg.ambient.thermometer = false;
        }
        if let Some(f) = self.pace {
            cfg = cfg.paced(f, self.pace_of);
        }
        if self.steps {
            cfg = cfg.steps();
        }
        if self.plateaus {
            cfg = cfg.plateaus();
        }
        if self.pace.is_some() || self.steps || self.plateaus {
            cfg.validate().map_err(|(key, message)| fbg_trainer::TrainerError::Config {
                origin: "--pace/--pace-of/--steps/--plateaus".into(),
                key,
                message,
            })?;
        }
        Ok(cfg)
    }

    /// The flags' own ranges, checked before any file is read: each error names its flag once.
    fn check_flags(&self) -> Result<()> {
        if let Some(f) = self.pace.filter(|&f| !Pace::accepts(f)) {
            bail!("--pace: {} is out of range [{}, {}]", ShortNumber(f), Pace::FACTOR_MIN, Pace::FACTOR_MAX);
        }
        if self.spectra.is_some() {
            crate::args::check_snr_db(self.snr_db)?;
        }
        Ok(())
    }

    pub fn run(self) -> Result<()> {
        self.check_flags()?;
        let out = &self.out;
        let side = meta_path(out);
        let record_side = sidecar_path(out);
        let mut outputs = vec![out.as_path(), side.as_path(), record_side.as_path()];
        outputs.extend(self.dump_config.as_deref());
        outputs.extend(self.spectra.as_deref());
        check_outputs(&outputs, &self.scenario.config.iter().map(|p| p.as_path()).collect::<Vec<_>>())?;
        let cfg = self.scenario()?;
        let s = sim::simulate(&cfg, self.scenario.seed);
        // The record and its sidecar are one output set: never a new record beside an old
        // sidecar (the oracle and studies read the sidecar as the record's truth).
        let set = OutputSet::beside(out)?;
        s.data.stage_csv(&set, out)?;
        set.stage_bytes(&side, SimMeta::of(&s).to_json()?.as_bytes())?;
        if let Some(path) = &self.spectra {
            let spectrum = SpectrumConfig {
                grid: self.grid,
                detector: DetectorModel { snr_db: self.snr_db, ..DetectorModel::default() },
                ..SpectrumConfig::default()
            };
            let nominal: Vec<f64> = s.data.meta.zero.iter().map(|z| z.nm).collect();
            let frames = FrameSimulator::new(&spectrum, &nominal)?;
            set.stage(path, |w| write_spectra_csv(w, &s.data, &frames, self.scenario.seed))?;
        }
        set.commit()?;
        if let Some(p) = &self.dump_config {
            let text = toml::to_string(&cfg).context("serialising the scenario")?;
            write_bytes_atomically(p, text.as_bytes())?;
        }
        if self.json {
            println!("{}", serde_json::to_string_pretty(&s.summary())?);
        } else {
            eprintln!("{}", self.summary_line(&cfg, &s));
        }
        Ok(())
    }

    /// "wrote … (N samples, shape; scenario, seed); per-sample oracle on the hold-out: …".
    fn summary_line(&self, cfg: &ScenarioConfig, s: &Simulation) -> String {
        let o = s.oracle_floor();
        let floor: Vec<String> = o
            .measurands
            .iter()
            .zip(&o.rmse_holdout)
            .map(|(m, v)| {
                let digits = if m.kind == Kind::Temperature { 3 } else { 2 };
                format!("{} {v:.digits$} {}", m.short_name(), m.unit())
            })
            .collect();
        format!(
            "wrote {} ({} samples, {}; scenario {}, seed {}); per-sample oracle on the hold-out: {}",
            self.out.display(),
            s.data.len(),
            s.data.shape(),
            cfg.name,
            self.scenario.seed,
            floor.join(", ")
        )
    }
}
