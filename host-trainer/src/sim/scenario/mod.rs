//! Scenario configuration (DESIGN §3): every parameter of the simulated installation, with the
//! presets (`paper`, `harsh`, `temperature-1`, `strain-pair`, `array-8`, `field`) and TOML
//! files where any parameter can be overridden. Every effect added after the first five
//! presets (other hysteresis models, the package's lag, creep and ageing, the thermometer's
//! resolution, clock jitter and gaps, pace, steps) is off by default, so a file without its
//! keys simulates what it always did.
//!
//! An installation has N gratings (1–8, the length of `gratings.nominal_nm`) and M measurands
//! (1–4, `measurands`: `T_C`, `strain_ue`, `strain2_ue`, `p_kPa`); the gauge matrix has one
//! row of M sensitivities per grating, in the order of `measurands`.
//!
//! Unknown keys and out-of-range values are errors that name the key.

mod instrument;
mod names;
mod presets;
mod trajectories;
mod validate;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::data::measurand::{Kind, Measurand};
use crate::error::{line_col, TrainerError};

pub use instrument::{
    Ageing, BoucWen, Drift, Electronics, Gratings, Hysteresis, HysteresisModel, Noise, Preisach, PreisachWeights, Scan,
};
pub(crate) use names::MAX_NAME_LEN;
use names::{short_number, with_suffix, without_segments};
pub use presets::Preset;
pub use trajectories::{Ambient, Pressure, Strain, Temperature};

/// Clock and split.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Clock {
    /// Duration \[days\].
    pub days: f64,
    /// Sample interval \[s\].
    pub dt_s: f64,
    /// Fraction of samples (from the start) used for calibration; the rest is the hold-out.
    pub cal_fraction: f64,
    /// σ of a Gaussian error of each recorded timestamp \[s\] (0 = off), clamped to ±0.45·dt_s
    /// so that the timestamps stay strictly increasing. The physics runs on the uniform grid:
    /// this is the logger stamping each sample late or early, not the sampling instant moving.
    pub jitter_s: f64,
    /// Mean number of recording gaps per day (0 = off). Gaps start as a Poisson process; the
    /// rows inside one are dropped from the record (`t_s` jumps), while the physics runs on
    /// underneath, so the installation is the same with and without them.
    pub gaps_per_day: f64,
    /// Mean length of a gap \[s\] (exponentially distributed).
    pub gap_mean_s: f64,
}

/// The same installation at another pace: the measurands' trajectories run `factor` times
/// faster (every period, hold, ramp and AR correlation time divided by it). The instrument
/// (thermometer lag, drift, noise, hysteresis, clock, duration) is untouched.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Pace {
    /// Speed multiplier (> 0; 1 = native, 4 = four times faster, 0.25 four times slower).
    pub factor: f64,
    /// Pace only this measurand (a column name such as `p_kPa`); absent = every measurand.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub only: Option<Measurand>,
}

impl Pace {
    /// Smallest factor accepted (a thousand times slower).
    pub const FACTOR_MIN: f64 = 1e-3;
    /// Largest factor accepted (a thousand times faster).
    pub const FACTOR_MAX: f64 = 1e3;

    /// Whether `factor` is within [`Pace::FACTOR_MIN`] ..= [`Pace::FACTOR_MAX`] (NaN is not).
    pub fn accepts(factor: f64) -> bool {
        (Pace::FACTOR_MIN..=Pace::FACTOR_MAX).contains(&factor)
    }
}

/// A steps record: the native calibration part, then a hold-out in which each measurand in
/// turn steps through `levels` held levels while the others stay at their calibration
/// medians (no AR wiggle in this part; every instrument artefact stays).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Steps {
    pub enabled: bool,
    /// Levels per measurand (≥ 5), evenly spaced from the 5th to the 95th percentile of its
    /// calibration part, visited low, high, second-lowest, second-highest, …, middle, each
    /// twice: approached from below, then from above (`sim::steps`).
    pub levels: u32,
    /// Length of each visit of a level \[s\]: the excursion and return ramps, then the hold.
    pub hold_s: f64,
    /// Each of the two linear ramps of a visit \[s\] (at most a quarter of `hold_s`).
    pub ramp_s: f64,
}

/// A plateau record: the native calibration part, then a hold-out in which every measurand,
/// each on its own schedule, rests at random levels across its calibration range for random
/// times, with linear ramps between (`sim::plateaus`); the record keeps its native length.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Plateaus {
    pub enabled: bool,
    /// Shortest rest \[s\].
    pub hold_min_s: f64,
    /// Longest rest \[s\] (rests are uniform between the two).
    pub hold_max_s: f64,
    /// Each ramp from one level to the next \[s\] (at most a quarter of `hold_min_s`).
    pub ramp_s: f64,
}

/// A whole scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScenarioConfig {
    /// Name shown in reports and model provenance.
    pub name: String,
    /// The measurands (reference columns) the installation measures, 1 to 4 of `T_C`,
    /// `strain_ue`, `strain2_ue`, `p_kPa`; the gauge matrix's columns follow this order.
    pub measurands: Vec<Measurand>,
    pub clock: Clock,
    pub temperature: Temperature,
    pub strain: Strain,
    /// A second strain location (`strain2_ue`); default: `strain`'s defaults, drawn from
    /// their own random streams.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strain2: Option<Strain>,
    pub pressure: Pressure,
    pub ambient: Ambient,
    pub gratings: Gratings,
    pub hysteresis: Hysteresis,
    pub scan: Scan,
    pub drift: Drift,
    pub electronics: Electronics,
    pub noise: Noise,
    /// Creep and ageing of the gratings (default none).
    pub ageing: Ageing,
    /// The measurands' pace (default native).
    pub pace: Pace,
    /// The steps hold-out (default off).
    pub steps: Steps,
    /// The plateau hold-out (default off; not with `steps`).
    pub plateaus: Plateaus,
}

impl Default for Clock {
    fn default() -> Self {
        Clock { days: 14.0, dt_s: 60.0, cal_fraction: 0.5, jitter_s: 0.0, gaps_per_day: 0.0, gap_mean_s: 600.0 }
    }
}
impl Default for Pace {
    fn default() -> Self {
        Pace { factor: 1.0, only: None }
    }
}
impl Default for Steps {
    fn default() -> Self {
        Steps { enabled: false, levels: 5, hold_s: 43_200.0, ramp_s: 1800.0 }
    }
}
impl Steps {
    /// Visits of each level: approached from below, then from above.
    pub(crate) const APPROACHES: usize = 2;
}
impl Default for Plateaus {
    fn default() -> Self {
        Plateaus { enabled: false, hold_min_s: 4.0 * 3600.0, hold_max_s: 16.0 * 3600.0, ramp_s: 600.0 }
    }
}
impl Default for ScenarioConfig {
    fn default() -> Self {
        ScenarioConfig {
            name: "paper".into(),
            measurands: Measurand::PAPER.to_vec(),
            clock: Clock::default(),
            temperature: Temperature::default(),
            strain: Strain::default(),
            strain2: None,
            pressure: Pressure::default(),
            ambient: Ambient::default(),
            gratings: Gratings::default(),
            hysteresis: Hysteresis::default(),
            scan: Scan::default(),
            drift: Drift::default(),
            electronics: Electronics::default(),
            noise: Noise::default(),
            ageing: Ageing::default(),
            pace: Pace::default(),
            steps: Steps::default(),
            plateaus: Plateaus::default(),
        }
    }
}

impl ScenarioConfig {
    /// Load a TOML file: keys not given keep the `paper` defaults; unknown keys and
    /// out-of-range values are errors naming the file and key.
    pub fn from_toml_file(path: &Path) -> Result<Self, TrainerError> {
        let text = std::fs::read_to_string(path).map_err(|e| TrainerError::io(path, e))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Parse TOML text; `origin` names the source in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, TrainerError> {
        let cfg: ScenarioConfig = toml::from_str(text).map_err(|e| TrainerError::Config {
            origin: origin.to_string(),
            key: e
                .span()
                .map(|s| match key_at(text, s.start) {
                    Some(k) => format!("{} ({k})", line_col(text, s.start)),
                    None => line_col(text, s.start),
                })
                .unwrap_or_default(),
            message: e.message().to_string(),
        })?;
        cfg.validate().map_err(|(key, message)| TrainerError::Config { origin: origin.to_string(), key, message })?;
        Ok(cfg)
    }

    /// Number of samples on the simulation grid (before recording gaps drop rows): the native
    /// record, or its calibration part followed by the steps part when `steps` is enabled.
    pub fn n_samples(&self) -> usize {
        if self.steps.enabled {
            self.n_cal() + self.n_steps_samples()
        } else {
            self.n_native_samples()
        }
    }

    /// Number of samples of the native record (`clock.days` at `clock.dt_s`).
    pub(crate) fn n_native_samples(&self) -> usize {
        (self.clock.days * 86_400.0 / self.clock.dt_s).round() as usize
    }

    /// Samples per held level of the steps part.
    pub(crate) fn steps_hold_samples(&self) -> usize {
        (self.steps.hold_s / self.clock.dt_s).round() as usize
    }

    /// Samples of the steps part (0 when it is off): every measurand through every level.
    pub(crate) fn n_steps_samples(&self) -> usize {
        if self.steps.enabled {
            self.measurands.len() * self.steps.levels as usize * Steps::APPROACHES * self.steps_hold_samples()
        } else {
            0
        }
    }

    /// The pace factor of measurand `m`'s trajectory (1 when `pace.only` names another).
    pub(crate) fn pace_for(&self, m: Measurand) -> f64 {
        match self.pace.only {
            Some(o) if o != m => 1.0,
            _ => self.pace.factor,
        }
    }

    /// This installation at another pace: the same configuration with `[pace]` set to
    /// `factor` (for `only`, or every measurand), named with a suffix (`paper@x4`,
    /// `paper@x0.25(p_kPa)`; the base name is shortened when the whole would exceed 24
    /// characters). Not validated here: [`validate`](Self::validate) names a bad factor.
    pub fn paced(&self, factor: f64, only: Option<Measurand>) -> ScenarioConfig {
        let mut c = self.clone();
        c.pace = Pace { factor, only };
        let mut suffix = format!("@x{}", short_number(factor));
        if let Some(m) = only {
            suffix.push_str(&format!("({m})"));
        }
        // A pace replaces an earlier one, in the name as in `[pace]`.
        let base = without_segments(&self.name, |seg| seg.starts_with('x'));
        c.name = with_suffix(&base, &suffix);
        c
    }

    /// This installation with the steps hold-out (`[steps] enabled = true`, the other step
    /// keys as they are), named with the suffix `@steps`.
    pub fn steps(&self) -> ScenarioConfig {
        let mut c = self.clone();
        c.steps.enabled = true;
        let base = without_segments(&self.name, |seg| seg == "steps");
        c.name = with_suffix(&base, "@steps");
        c
    }

    /// This installation with the plateau hold-out (`[plateaus] enabled = true`, the other
    /// keys as they are), named with the suffix `@plateaus`.
    pub fn plateaus(&self) -> ScenarioConfig {
        let mut c = self.clone();
        c.plateaus.enabled = true;
        let base = without_segments(&self.name, |seg| seg == "plateaus");
        c.name = with_suffix(&base, "@plateaus");
        c
    }

    /// Number of gratings.
    pub fn n_gratings(&self) -> usize {
        self.gratings.nominal_nm.len()
    }

    /// The second strain location's trajectory (`strain2_ue`).
    pub fn strain2(&self) -> Strain {
        self.strain2.clone().unwrap_or_default()
    }

    /// Number of calibration samples (the first ones of the grid): `clock.cal_fraction` of the
    /// native record, with or without the steps part after it.
    pub fn n_cal(&self) -> usize {
        (self.n_native_samples() as f64 * self.clock.cal_fraction).round() as usize
    }
}

/// The dotted key of the `key = value` line at byte `pos` of the TOML `text`, with the table
/// header above it (`hysteresis.model`): a value of the wrong type is then named by its key,
/// not only by its line.
fn key_at(text: &str, pos: usize) -> Option<String> {
    let before = text.get(..pos)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let line = text.get(line_start..)?.lines().next()?;
    let (key, _) = line.split_once('=')?;
    let key = key.trim().trim_matches('"');
    if key.is_empty() || key.starts_with('#') || key.starts_with('[') {
        return None;
    }
    let table = text[..line_start]
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('['))
        .map(|l| l.trim_start_matches('[').trim_end_matches(']').trim());
    Some(match table {
        Some(t) if !t.is_empty() => format!("{t}.{key}"),
        _ => key.to_string(),
    })
}

/// The measurands the simulator has trajectories for.
pub(crate) const SIMULATED: [Measurand; 4] =
    [Measurand::T, Measurand::STRAIN, Measurand { kind: Kind::Strain, index: 2 }, Measurand::P];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate() {
        for p in Preset::ALL {
            assert_eq!(p.config().validate(), Ok(()), "{}", p.name());
            assert_eq!(p.config().name, p.name());
        }
        assert_eq!(Preset::Paper.config().n_samples(), 20_160);
        assert_eq!(Preset::Paper.config().n_cal(), 10_080);
    }

    #[test]
    fn partial_toml_keeps_defaults() {
        let c = ScenarioConfig::from_toml_str("[drift]\nsigma_pm = 0.2\n", "x.toml").unwrap();
        assert_eq!(c.drift.sigma_pm, 0.2);
        assert_eq!(c.drift.channel_gain, [1.0, 1.1, 1.2]);
        let c = ScenarioConfig::from_toml_str("ambient = false\n", "x.toml").unwrap();
        assert!(!c.ambient.thermometer);
        assert_eq!(c.ambient.lag_tau_s, Ambient::default().lag_tau_s);
        let c = ScenarioConfig::from_toml_str("[ambient]\nthermometer = false\noffset_c = 1.0\n", "x.toml").unwrap();
        assert!(!c.ambient.thermometer && c.ambient.offset_c == 1.0);
        let e = ScenarioConfig::from_toml_str("[ambient]\nthermo = false\n", "x.toml").unwrap_err().to_string();
        assert!(e.contains("thermo") && e.contains("line 2"), "{e}");
        assert_eq!(c.temperature, Temperature::default());
    }

    #[test]
    fn a_cross_term_is_checked_against_the_measurands_and_its_range() {
        // One grating, temperature only: a T·T term is fine, a T·ε term names the strain.
        let mut c = Preset::Temperature1.config();
        c.gratings.c_tt = vec![0.01];
        assert_eq!(c.validate(), Ok(()));
        c.gratings.c_te = vec![0.01];
        let (key, why) = c.validate().unwrap_err();
        assert_eq!(key, "gratings.c_te");
        assert!(why.contains("`strain_ue`"), "{why}");
        // T and ε: an ε·p term names the pressure; an out-of-range T·T term its index.
        let mut c = Preset::StrainPair.config();
        c.gratings.c_ep = vec![0.0, 1e-4];
        let (key, why) = c.validate().unwrap_err();
        assert_eq!(key, "gratings.c_ep");
        assert!(why.contains("`p_kPa`"), "{why}");
        let mut c = Preset::StrainPair.config();
        c.gratings.c_tt = vec![0.012, 20.0];
        assert_eq!(c.validate().unwrap_err().0, "gratings.c_tt[1]");
    }

    #[test]
    fn unknown_key_is_named() {
        let e = ScenarioConfig::from_toml_str("[drift]\nsigma = 0.2\n", "x.toml").unwrap_err();
        let s = e.to_string();
        assert!(s.contains("x.toml") && s.contains("sigma") && s.contains("line 2"), "{s}");
    }

    #[test]
    fn out_of_range_value_is_named() {
        let e = ScenarioConfig::from_toml_str("[noise]\nwhite_sigma_pm = -1.0\n", "y.toml").unwrap_err().to_string();
        assert!(e.contains("y.toml") && e.contains("noise.white_sigma_pm"), "{e}");
        let e = ScenarioConfig::from_toml_str("[clock]\ncal_fraction = 1.5\n", "y.toml").unwrap_err().to_string();
        assert!(e.contains("clock.cal_fraction"), "{e}");
    }

    #[test]
    fn preset_round_trips_through_toml() {
        for p in Preset::ALL {
            let mut c = p.config();
            c.ambient.thermometer = false;
            let text = toml::to_string(&c).unwrap();
            let back = ScenarioConfig::from_toml_str(&text, "preset.toml").unwrap();
            assert_eq!(c, back, "{}", p.name());
        }
    }

    #[test]
    fn shape_mistakes_name_the_key() {
        let e = ScenarioConfig::from_toml_str("measurands = [\"T_C\"]\n", "z.toml").unwrap_err().to_string();
        assert!(e.contains("gratings.gauge[0]"), "{e}");
        let e = ScenarioConfig::from_toml_str("measurands = [\"T2_C\", \"strain_ue\", \"p_kPa\"]\n", "z.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("measurands") && e.contains("T2_C"), "{e}");
        let e = ScenarioConfig::from_toml_str("[drift]\nchannel_gain = [1.0]\n", "z.toml").unwrap_err().to_string();
        assert!(e.contains("drift.channel_gain"), "{e}");
    }
}
