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

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::data::measurand::{Kind, Measurand, MAX_GRATINGS, MAX_MEASURANDS};
use crate::error::{line_col, TrainerError};

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

/// Temperature trajectory T(t) [°C].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Temperature {
    pub mean_c: f64,
    pub diurnal_amp_c: f64,
    pub diurnal_phase_rad: f64,
    pub weekly_amp_c: f64,
    pub weekly_phase_rad: f64,
    /// Slow seasonal excursion (0 in `paper`; `harsh` uses it to leave the calibration range).
    pub seasonal_amp_c: f64,
    pub seasonal_period_days: f64,
    pub seasonal_phase_rad: f64,
    pub ar_sigma_c: f64,
    pub ar_tau_s: f64,
}

/// Strain trajectory ε(t) \[µε\].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Strain {
    /// Quasi-static load levels, uniform in [level_lo_ue, level_hi_ue].
    pub level_lo_ue: f64,
    pub level_hi_ue: f64,
    /// Time each level is held, ramp included \[s\].
    pub hold_s: f64,
    /// Linear ramp from the previous level \[s\].
    pub ramp_s: f64,
    pub sine1_amp_ue: f64,
    pub sine1_period_s: f64,
    pub sine2_amp_ue: f64,
    pub sine2_period_s: f64,
    pub ar_sigma_ue: f64,
    pub ar_tau_s: f64,
}

/// Pressure trajectory p(t) \[kPa\].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Pressure {
    pub mean_kpa: f64,
    pub sine1_amp_kpa: f64,
    pub sine1_period_s: f64,
    pub sine2_amp_kpa: f64,
    pub sine2_period_s: f64,
    pub ar_sigma_kpa: f64,
    pub ar_tau_s: f64,
}

impl Strain {
    /// This trajectory `factor` times faster: hold, ramp, sine periods and AR correlation time
    /// divided by it (amplitudes and levels unchanged).
    pub fn paced(&self, factor: f64) -> Strain {
        Strain {
            hold_s: self.hold_s / factor,
            ramp_s: self.ramp_s / factor,
            sine1_period_s: self.sine1_period_s / factor,
            sine2_period_s: self.sine2_period_s / factor,
            ar_tau_s: self.ar_tau_s / factor,
            ..self.clone()
        }
    }
}

impl Pressure {
    /// This trajectory `factor` times faster: sine periods and AR correlation time divided by it.
    pub fn paced(&self, factor: f64) -> Pressure {
        Pressure {
            sine1_period_s: self.sine1_period_s / factor,
            sine2_period_s: self.sine2_period_s / factor,
            ar_tau_s: self.ar_tau_s / factor,
            ..self.clone()
        }
    }
}

/// Reference (ambient) thermometer T_amb(t) [°C]. The ambient temperature drives the
/// electronics drift whether or not a thermometer reads it; `thermometer = false` (or the
/// top-level shorthand `ambient = false`) is an installation without the reading, whose CSV
/// has no `T_amb_C` column.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Ambient {
    /// Whether the installation has an ambient thermometer (default true).
    pub thermometer: bool,
    /// First-order lag of the thermometer behind T \[s\].
    pub lag_tau_s: f64,
    pub offset_c: f64,
    pub noise_sigma_c: f64,
    /// Resolution of the reading [°C] (0 = off): the noisy reading is rounded to a multiple of
    /// it, as a digital thermometer reports it (0.0625 °C for a DS18B20 at 12 bits).
    pub resolution_c: f64,
}

/// The `[ambient]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct AmbientTable {
    thermometer: bool,
    lag_tau_s: f64,
    offset_c: f64,
    noise_sigma_c: f64,
    resolution_c: f64,
}

impl Default for AmbientTable {
    fn default() -> Self {
        let a = Ambient::default();
        AmbientTable {
            thermometer: a.thermometer,
            lag_tau_s: a.lag_tau_s,
            offset_c: a.offset_c,
            noise_sigma_c: a.noise_sigma_c,
            resolution_c: a.resolution_c,
        }
    }
}

impl<'de> Deserialize<'de> for Ambient {
    /// The `[ambient]` table, or `ambient = true|false` (the thermometer, defaults otherwise).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Ambient;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("an [ambient] table or `ambient = false` (no ambient thermometer)")
            }
            fn visit_bool<E: serde::de::Error>(self, b: bool) -> Result<Ambient, E> {
                Ok(Ambient { thermometer: b, ..Ambient::default() })
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Ambient, A::Error> {
                let t = AmbientTable::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(Ambient {
                    thermometer: t.thermometer,
                    lag_tau_s: t.lag_tau_s,
                    offset_c: t.offset_c,
                    noise_sigma_c: t.noise_sigma_c,
                    resolution_c: t.resolution_c,
                })
            }
        }
        d.deserialize_any(V)
    }
}

/// Gratings and their physics (paper Eq. 2-3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Gratings {
    /// Nominal Bragg wavelengths \[nm\], one per grating (1 to 8 gratings).
    pub nominal_nm: Vec<f64>,
    /// Gauge matrix rows per grating, one sensitivity per measurand in the order of
    /// `measurands`: pm/°C, pm/µε, pm/kPa.
    pub gauge: Vec<Vec<f64>>,
    /// Relative manufacturing dispersion of every gauge entry (σ of the factor 1 + N(0, σ)).
    pub dispersion: f64,
    /// Cross-terms per grating (one entry per grating, or empty for none) [pm/°C²],
    /// [pm/(°C·µε)], [pm/(°C·kPa)], [pm/µε²], [pm/kPa²], [pm/(µε·kPa)], on the first
    /// measurand of each kind (`T_C`, `strain_ue`, `p_kPa`).
    pub c_tt: Vec<f64>,
    pub c_te: Vec<f64>,
    pub c_tp: Vec<f64>,
    pub c_ee: Vec<f64>,
    pub c_pp: Vec<f64>,
    pub c_ep: Vec<f64>,
    /// Reference point of the Δ's: T [°C], ε \[µε\], p \[kPa\].
    pub ref_t_c: f64,
    pub ref_strain_ue: f64,
    pub ref_p_kpa: f64,
    /// Thermal time constant of each grating's package \[s\] (one per grating, or empty for
    /// none; 0 = none for that grating): the grating sees the structure's temperature through a
    /// first-order lag, in its temperature column and its cross-terms alike. The reference
    /// `T_C` stays the structure's temperature.
    pub thermal_lag_s: Vec<f64>,
}

/// Interrogator hysteresis on each grating's shift: one of three models (`model`), each with
/// its own parameters; `beta`, `gamma`, `rho` and `play_half_width_pm` are those of
/// `eq9-play`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Hysteresis {
    pub enabled: bool,
    /// `eq9-play` (default), `bouc-wen` or `preisach`.
    pub model: HysteresisModel,
    /// Eq. 9's β, γ, ρ (dimensionless).
    pub beta: f64,
    pub gamma: f64,
    pub rho: f64,
    /// Play (backlash) half-width \[pm\].
    pub play_half_width_pm: f64,
    pub bouc_wen: BoucWen,
    pub preisach: Preisach,
}

/// Which hysteresis model the interrogator has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum HysteresisModel {
    /// Paper Eq. 9 followed by a play operator (rate-dependent through Eq. 9's terms).
    #[default]
    #[serde(rename = "eq9-play")]
    Eq9Play,
    /// A rate-independent Bouc–Wen model driven by the shift's increments.
    #[serde(rename = "bouc-wen")]
    BoucWen,
    /// A discrete Preisach sum of relays.
    #[serde(rename = "preisach")]
    Preisach,
}

/// Bouc–Wen hysteresis in the form used for piezo-driven actuators (a tunable filter's):
/// the reading is y = x − h, with h \[pm\] following each increment dx of the physical shift
/// x \[pm\] as dh = a·dx − β·|dx|·|h|^(n−1)·h − γ·dx·|h|^n. Driven by increments, not by
/// time, it is rate-independent. A long rise takes h to h_s = (a/(β+γ))^(1/n) (the reading
/// is h_s low), a long fall to −h_s: the major loop is 2·h_s wide, reached after about
/// h_s/a of travel. The defaults give h_s = 3 pm within about 25 pm, loops of a few pm on
/// the `paper` swings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BoucWen {
    /// Initial slope a of h against x after a reversal (dimensionless).
    pub a: f64,
    /// β \[pm^−n\]: with β > |γ| the branch is steep just after a reversal, then flattens.
    pub beta: f64,
    /// γ \[pm^−n\].
    pub gamma: f64,
    /// Sharpness n of the approach to saturation (1 = exponential).
    pub n: f64,
}

/// A discrete Preisach model: relays on a triangular grid of thresholds (up α ≥ down β),
/// `cells` per axis across [lo_pm, hi_pm] of the physical shift. A relay reads +1 once the
/// shift has reached α and −1 once it has fallen to β. The contribution is w·(Σμ·R − L(x)),
/// the weights μ summing to 1, L the straight line from −1 at `lo_pm` to +1 at `hi_pm` (the
/// relays' mean rise, a gain, taken out) and w set so that the major loop is `loop_width_pm`
/// wide at its widest. Rate-independent: only the extrema of the shift count.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Preisach {
    /// Width of the major loop at its widest \[pm\].
    pub loop_width_pm: f64,
    /// Threshold range \[pm\] of the physical shift (beyond it every relay is switched).
    pub lo_pm: f64,
    pub hi_pm: f64,
    /// Thresholds per axis (cells·(cells+1)/2 relays).
    pub cells: u32,
    /// `uniform` or `gaussian` (μ ∝ exp(−w²/2σ²) in the relay half-width w = (α−β)/2: narrow
    /// relays dominate and small reversals draw relatively wider loops).
    pub weights: PreisachWeights,
    /// σ of the Gaussian weights \[pm\].
    pub sigma_pm: f64,
}

/// Relay weights of the Preisach model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PreisachWeights {
    #[default]
    Uniform,
    Gaussian,
}

/// Slow changes of a bonded grating itself: adhesive creep of the strain transfer and ageing of
/// the Bragg wavelength.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ageing {
    /// Fraction of the applied strain each grating loses to adhesive creep (one per grating, or
    /// empty for none) \[1\]: the grating sees ε − c, where the creep state c follows
    /// creep_fraction·ε with the time constant `creep_tau_s` (settled at the first sample).
    pub creep_fraction: Vec<f64>,
    /// Time constant of the creep \[s\].
    pub creep_tau_s: f64,
    /// Initial rate of each grating's Bragg-wavelength ageing (one per grating, or empty for
    /// none) \[pm/day\]: the shift is rate·τ·(1 − exp(−t/τ)) with τ = `ageing_tau_days`,
    /// monotonic and saturating at rate·τ.
    pub drift_pm_per_day: Vec<f64>,
    /// Saturation time constant of the ageing \[days\].
    pub ageing_tau_days: f64,
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

/// Scan nonlinearity of the tunable filter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scan {
    pub enabled: bool,
    pub ripple_amp_pm: f64,
    pub ripple_period_nm: f64,
    /// Ripple phase per grating \[rad\].
    pub ripple_phase_rad: Vec<f64>,
    /// Quadratic bow reaching `bow_pm` at ±`bow_half_span_nm` from `bow_centre_nm`.
    pub bow_pm: f64,
    pub bow_half_span_nm: f64,
    pub bow_centre_nm: f64,
}

/// Random-walk drift (paper Eq. 8), common to the interrogator.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Drift {
    pub enabled: bool,
    /// σ_d per step \[pm\].
    pub sigma_pm: f64,
    /// Gain of the common walk per grating.
    pub channel_gain: Vec<f64>,
}

/// Electronics thermal drift driven by the ambient temperature.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Electronics {
    pub enabled: bool,
    pub lin_pm_per_c: f64,
    pub quad_pm_per_c2: f64,
    pub ref_c: f64,
}

/// Per-channel additive noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Noise {
    pub enabled: bool,
    /// 1/f (pink) noise σ \[pm\] (Voss–McCartney).
    pub pink_sigma_pm: f64,
    /// Octaves of the pink generator (lowest frequency = fs / 2^octaves).
    pub pink_octaves: u32,
    pub white_sigma_pm: f64,
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
}

impl Default for Clock {
    fn default() -> Self {
        Clock { days: 14.0, dt_s: 60.0, cal_fraction: 0.5, jitter_s: 0.0, gaps_per_day: 0.0, gap_mean_s: 600.0 }
    }
}
impl Default for Temperature {
    fn default() -> Self {
        Temperature {
            mean_c: 20.0,
            diurnal_amp_c: 4.0,
            diurnal_phase_rad: 0.0,
            weekly_amp_c: 2.0,
            weekly_phase_rad: 0.0,
            seasonal_amp_c: 0.0,
            seasonal_period_days: 28.0,
            seasonal_phase_rad: 0.0,
            ar_sigma_c: 0.3,
            ar_tau_s: 1800.0,
        }
    }
}
impl Default for Strain {
    fn default() -> Self {
        Strain {
            level_lo_ue: -150.0,
            level_hi_ue: 150.0,
            hold_s: 6.0 * 3600.0,
            ramp_s: 1800.0,
            sine1_amp_ue: 60.0,
            sine1_period_s: 3.0 * 3600.0,
            sine2_amp_ue: 20.0,
            sine2_period_s: 40.0 * 60.0,
            ar_sigma_ue: 5.0,
            ar_tau_s: 600.0,
        }
    }
}
impl Default for Pressure {
    fn default() -> Self {
        Pressure {
            mean_kpa: 150.0,
            sine1_amp_kpa: 25.0,
            sine1_period_s: 12.0 * 3600.0,
            sine2_amp_kpa: 8.0,
            sine2_period_s: 2.5 * 3600.0,
            ar_sigma_kpa: 1.0,
            ar_tau_s: 1800.0,
        }
    }
}
impl Default for Ambient {
    fn default() -> Self {
        Ambient { thermometer: true, lag_tau_s: 1200.0, offset_c: 0.5, noise_sigma_c: 0.1, resolution_c: 0.0 }
    }
}
impl Default for Gratings {
    fn default() -> Self {
        Gratings {
            nominal_nm: vec![1535.0, 1545.0, 1555.0],
            gauge: vec![vec![10.0, 1.20, 0.02], vec![9.8, 0.05, 0.01], vec![11.0, 0.10, 1.0]],
            dispersion: 0.03,
            c_tt: vec![0.012, 0.011, 0.013],
            c_te: vec![1e-3, 0.0, 0.0],
            c_tp: vec![0.0, 0.0, 4e-3],
            c_ee: vec![0.0; 3],
            c_pp: vec![0.0; 3],
            c_ep: vec![0.0; 3],
            ref_t_c: 20.0,
            ref_strain_ue: 0.0,
            ref_p_kpa: 150.0,
            thermal_lag_s: vec![],
        }
    }
}
impl Default for Hysteresis {
    fn default() -> Self {
        Hysteresis {
            enabled: true,
            model: HysteresisModel::Eq9Play,
            beta: 0.97,
            gamma: 0.03,
            rho: 0.05,
            play_half_width_pm: 4.0,
            bouc_wen: BoucWen::default(),
            preisach: Preisach::default(),
        }
    }
}
impl Default for BoucWen {
    fn default() -> Self {
        BoucWen { a: 0.12, beta: 0.03, gamma: 0.01, n: 1.0 }
    }
}
impl Default for Preisach {
    fn default() -> Self {
        Preisach {
            loop_width_pm: 6.0,
            lo_pm: -300.0,
            hi_pm: 300.0,
            cells: 40,
            weights: PreisachWeights::Uniform,
            sigma_pm: 50.0,
        }
    }
}
impl Default for Ageing {
    fn default() -> Self {
        Ageing { creep_fraction: vec![], creep_tau_s: 2.0 * 86_400.0, drift_pm_per_day: vec![], ageing_tau_days: 60.0 }
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
impl Default for Scan {
    fn default() -> Self {
        Scan {
            enabled: true,
            ripple_amp_pm: 3.0,
            ripple_period_nm: 0.8,
            ripple_phase_rad: vec![0.0, 2.1, 4.2],
            bow_pm: 2.0,
            bow_half_span_nm: 10.0,
            bow_centre_nm: 1545.0,
        }
    }
}
impl Default for Drift {
    fn default() -> Self {
        Drift { enabled: true, sigma_pm: 0.05, channel_gain: vec![1.0, 1.1, 1.2] }
    }
}
impl Default for Electronics {
    fn default() -> Self {
        Electronics { enabled: true, lin_pm_per_c: 0.8, quad_pm_per_c2: 0.05, ref_c: 20.0 }
    }
}
impl Default for Noise {
    fn default() -> Self {
        Noise { enabled: true, pink_sigma_pm: 1.0, pink_octaves: 16, white_sigma_pm: 0.8 }
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
        }
    }
}

/// Built-in presets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// DESIGN §3 defaults: three gratings (strain, temperature reference, pressure diaphragm),
    /// outputs T, ε, p.
    Paper,
    /// Drift σ×4, play 8 pm, a ±15 °C seasonal swing so the hold-out leaves the calibration range.
    Harsh,
    /// One temperature grating (10 pm/°C), output T.
    #[value(name = "temperature-1")]
    #[serde(rename = "temperature-1")]
    Temperature1,
    /// A strain grating (1.2 pm/µε, 10 pm/°C) and a strain-free temperature-reference grating
    /// beside it, outputs T and ε.
    #[value(name = "strain-pair")]
    #[serde(rename = "strain-pair")]
    StrainPair,
    /// Eight gratings on one fibre: an axial and a transverse (Poisson) strain grating and a
    /// temperature reference at each of two locations, a pressure diaphragm and its
    /// temperature reference; outputs T, ε, ε2, p.
    #[value(name = "array-8")]
    #[serde(rename = "array-8")]
    Array8,
    /// The `paper` installation as a field deployment sees it: Bouc–Wen hysteresis of a
    /// piezo-tuned filter instead of Eq. 9 + play; package thermal lags of 5 / 10 / 15 min (the
    /// strain grating bonded to the surface follows fastest, the reference loose in its tube
    /// slower, the diaphragm inside its housing slowest); 2 % adhesive creep of the bonded
    /// strain grating over 2 days; Bragg-wavelength ageing of 0.2 pm/day on every grating
    /// (saturating over 60 days); a digital ambient thermometer with 0.0625 °C steps (a
    /// DS18B20 at 12 bits); logger timestamps jittered by 2 s; about two recording gaps a day
    /// of 10 min on average (link drop-outs, reboots).
    Field,
}

impl Preset {
    /// The preset's configuration.
    pub fn config(self) -> ScenarioConfig {
        match self {
            Preset::Paper => ScenarioConfig::default(),
            Preset::Harsh => {
                let mut c = ScenarioConfig { name: "harsh".into(), ..ScenarioConfig::default() };
                c.drift.sigma_pm *= 4.0;
                c.hysteresis.play_half_width_pm = 8.0;
                // Half a 28-day period over the 14 days: T climbs from −15 to +15 °C about the
                // mean, so the hold-out (second week) lies above the calibration range.
                c.temperature.seasonal_amp_c = 15.0;
                c.temperature.seasonal_period_days = 28.0;
                c.temperature.seasonal_phase_rad = -std::f64::consts::FRAC_PI_2;
                c
            }
            Preset::Temperature1 => {
                let mut c = ScenarioConfig {
                    name: "temperature-1".into(),
                    measurands: vec![Measurand::T],
                    ..ScenarioConfig::default()
                };
                c.gratings = Gratings {
                    nominal_nm: vec![1550.0],
                    gauge: vec![vec![10.0]],
                    c_tt: vec![0.012],
                    c_te: vec![],
                    c_tp: vec![],
                    c_ee: vec![],
                    c_pp: vec![],
                    c_ep: vec![],
                    ..Gratings::default()
                };
                c.scan.ripple_phase_rad = vec![1.3];
                c.drift.channel_gain = vec![1.0];
                c
            }
            Preset::StrainPair => {
                let mut c = ScenarioConfig {
                    name: "strain-pair".into(),
                    measurands: vec![Measurand::T, Measurand::STRAIN],
                    ..ScenarioConfig::default()
                };
                // The strain grating is bonded (10 pm/°C + 1.2 pm/µε, its strain sensitivity
                // rising with temperature); the reference sits loose in a tube beside it and
                // sees almost no strain.
                c.gratings = Gratings {
                    nominal_nm: vec![1540.0, 1550.0],
                    gauge: vec![vec![10.0, 1.20], vec![9.8, 0.02]],
                    c_tt: vec![0.012, 0.011],
                    c_te: vec![1e-3, 0.0],
                    c_tp: vec![],
                    c_ee: vec![],
                    c_pp: vec![],
                    c_ep: vec![],
                    ..Gratings::default()
                };
                c.scan.ripple_phase_rad = vec![0.0, 2.1];
                c.drift.channel_gain = vec![1.0, 1.1];
                c
            }
            Preset::Array8 => {
                let e2 = Measurand { kind: Kind::Strain, index: 2 };
                let mut c = ScenarioConfig {
                    name: "array-8".into(),
                    measurands: vec![Measurand::T, Measurand::STRAIN, e2, Measurand::P],
                    ..ScenarioConfig::default()
                };
                // Columns T [pm/°C], ε [pm/µε], ε2 [pm/µε], p [pm/kPa]. Location A (ε) and B
                // (ε2) each carry an axial strain grating, a transverse one reading −ν·ε
                // (ν ≈ 0.3) and a loose temperature reference; the pressure port a diaphragm
                // grating (1 pm/kPa) and an unbonded reference. 5 nm apart on one fibre.
                c.gratings = Gratings {
                    nominal_nm: vec![1530.0, 1535.0, 1540.0, 1545.0, 1550.0, 1555.0, 1560.0, 1565.0],
                    gauge: vec![
                        vec![10.0, 1.20, 0.0, 0.02],
                        vec![10.0, -0.36, 0.0, 0.02],
                        vec![9.8, 0.05, 0.0, 0.01],
                        vec![10.1, 0.0, 1.20, 0.02],
                        vec![10.1, 0.0, -0.36, 0.02],
                        vec![9.9, 0.0, 0.05, 0.01],
                        vec![11.0, 0.10, 0.0, 1.0],
                        vec![10.5, 0.0, 0.0, 0.05],
                    ],
                    c_tt: vec![0.012, 0.012, 0.011, 0.012, 0.012, 0.011, 0.013, 0.011],
                    c_te: vec![1e-3, -3e-4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                    c_tp: vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 4e-3, 0.0],
                    c_ee: vec![],
                    c_pp: vec![],
                    c_ep: vec![],
                    ..Gratings::default()
                };
                c.strain2 = Some(Strain {
                    level_lo_ue: -100.0,
                    level_hi_ue: 100.0,
                    hold_s: 8.0 * 3600.0,
                    ramp_s: 2400.0,
                    sine1_amp_ue: 40.0,
                    sine1_period_s: 5.0 * 3600.0,
                    sine2_amp_ue: 15.0,
                    sine2_period_s: 25.0 * 60.0,
                    ar_sigma_ue: 4.0,
                    ar_tau_s: 900.0,
                });
                // The scan covers 1525–1570 nm: the bow reaches 2 pm at its ends.
                c.scan.bow_centre_nm = 1547.5;
                c.scan.bow_half_span_nm = 22.5;
                c.scan.ripple_phase_rad = vec![0.0, 2.1, 4.2, 0.7, 2.8, 4.9, 1.4, 3.5];
                c.drift.channel_gain = vec![1.0, 1.05, 1.1, 1.15, 1.2, 1.1, 1.2, 1.0];
                c
            }
            Preset::Field => {
                let mut c = ScenarioConfig { name: "field".into(), ..ScenarioConfig::default() };
                c.hysteresis.model = HysteresisModel::BoucWen;
                c.gratings.thermal_lag_s = vec![300.0, 600.0, 900.0];
                c.ageing = Ageing {
                    creep_fraction: vec![0.02, 0.0, 0.0],
                    creep_tau_s: 2.0 * 86_400.0,
                    drift_pm_per_day: vec![0.2, 0.2, 0.2],
                    ageing_tau_days: 60.0,
                };
                c.ambient.resolution_c = 0.0625;
                c.clock.jitter_s = 2.0;
                c.clock.gaps_per_day = 2.0;
                c.clock.gap_mean_s = 600.0;
                c
            }
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::Harsh => "harsh",
            Preset::Temperature1 => "temperature-1",
            Preset::StrainPair => "strain-pair",
            Preset::Array8 => "array-8",
            Preset::Field => "field",
        }
    }
    /// Every preset.
    pub const ALL: [Preset; 6] =
        [Preset::Paper, Preset::Harsh, Preset::Temperature1, Preset::StrainPair, Preset::Array8, Preset::Field];
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
    pub fn n_native_samples(&self) -> usize {
        (self.clock.days * 86_400.0 / self.clock.dt_s).round() as usize
    }

    /// Samples per held level of the steps part.
    pub fn steps_hold_samples(&self) -> usize {
        (self.steps.hold_s / self.clock.dt_s).round() as usize
    }

    /// Samples of the steps part (0 when it is off): every measurand through every level.
    pub fn n_steps_samples(&self) -> usize {
        if self.steps.enabled {
            self.measurands.len()
                * self.steps.levels as usize
                * crate::sim::steps::APPROACHES
                * self.steps_hold_samples()
        } else {
            0
        }
    }

    /// The pace factor of measurand `m`'s trajectory (1 when `pace.only` names another).
    pub fn pace_for(&self, m: Measurand) -> f64 {
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

    /// Check ranges; the error is (key path, message).
    pub fn validate(&self) -> Result<(), (String, String)> {
        let mut v = Checker::default();
        let c = &self.clock;
        v.range("clock.days", c.days, 1.0 / 24.0, 3650.0);
        v.range("clock.dt_s", c.dt_s, 1e-3, 86_400.0);
        v.range("clock.cal_fraction", c.cal_fraction, 0.05, 0.95);
        v.nonneg("clock.jitter_s", c.jitter_s, 1e4);
        v.nonneg("clock.gaps_per_day", c.gaps_per_day, 1e3);
        v.nonneg("clock.gap_mean_s", c.gap_mean_s, 10.0 * 86_400.0);
        // Expected fraction of the record inside gaps (a renewal process of gaps and runs).
        let gap_days = c.gaps_per_day * c.gap_mean_s / 86_400.0;
        if v.ok() && gap_days / (1.0 + gap_days) > 0.5 {
            v.fail("clock.gap_mean_s", "the gaps would drop more than half of the record on average");
        }
        let st = &self.steps;
        if !(5..=1000).contains(&st.levels) {
            v.fail("steps.levels", &format!("{} is out of range [5, 1000]", st.levels));
        }
        // A hold needs samples only when the steps part is simulated.
        v.range("steps.hold_s", st.hold_s, if st.enabled { 4.0 * c.dt_s } else { 1e-3 }, 1e8);
        v.range("steps.ramp_s", st.ramp_s, 0.0, 0.25 * st.hold_s);
        if v.ok() && self.n_native_samples() < 100 {
            v.fail("clock.days", "fewer than 100 samples: increase days or decrease dt_s");
        }
        if v.ok() && self.n_native_samples() > 50_000_000 {
            v.fail("clock.days", "more than 5e7 samples");
        }
        if v.ok() && self.n_samples() > 50_000_000 {
            v.fail("steps.hold_s", "the steps part makes the record more than 5e7 samples");
        }
        let t = &self.temperature;
        v.range("temperature.mean_c", t.mean_c, -100.0, 300.0);
        v.nonneg("temperature.diurnal_amp_c", t.diurnal_amp_c, 100.0);
        v.finite("temperature.diurnal_phase_rad", t.diurnal_phase_rad);
        v.nonneg("temperature.weekly_amp_c", t.weekly_amp_c, 100.0);
        v.finite("temperature.weekly_phase_rad", t.weekly_phase_rad);
        v.nonneg("temperature.seasonal_amp_c", t.seasonal_amp_c, 100.0);
        v.range("temperature.seasonal_period_days", t.seasonal_period_days, 0.1, 10_000.0);
        v.finite("temperature.seasonal_phase_rad", t.seasonal_phase_rad);
        v.nonneg("temperature.ar_sigma_c", t.ar_sigma_c, 50.0);
        v.range("temperature.ar_tau_s", t.ar_tau_s, 1e-3, 1e8);
        validate_strain(&mut v, "strain", &self.strain);
        let p = &self.pressure;
        v.range("pressure.mean_kpa", p.mean_kpa, 0.0, 1e5);
        v.nonneg("pressure.sine1_amp_kpa", p.sine1_amp_kpa, 1e5);
        v.range("pressure.sine1_period_s", p.sine1_period_s, 1e-3, 1e9);
        v.nonneg("pressure.sine2_amp_kpa", p.sine2_amp_kpa, 1e5);
        v.range("pressure.sine2_period_s", p.sine2_period_s, 1e-3, 1e9);
        v.nonneg("pressure.ar_sigma_kpa", p.ar_sigma_kpa, 1e5);
        v.range("pressure.ar_tau_s", p.ar_tau_s, 1e-3, 1e8);
        if let Some(s) = &self.strain2 {
            validate_strain(&mut v, "strain2", s);
        }
        let m = &self.measurands;
        if m.is_empty() || m.len() > MAX_MEASURANDS {
            v.fail("measurands", &format!("{} measurands; 1 to {MAX_MEASURANDS} are simulated", m.len()));
        }
        for (i, x) in m.iter().enumerate() {
            if m[..i].contains(x) {
                v.fail("measurands", &format!("`{x}` is listed twice"));
            }
            if !SIMULATED.contains(x) {
                let names: Vec<String> = SIMULATED.iter().map(|m| m.column()).collect();
                v.fail("measurands", &format!("`{x}` is not simulated; the simulator has {}", names.join(", ")));
            }
        }
        let n_g = self.n_gratings();
        if n_g == 0 || n_g > MAX_GRATINGS {
            v.fail("gratings.nominal_nm", &format!("{n_g} gratings; 1 to {MAX_GRATINGS} are simulated"));
        }
        if v.ok() && n_g < m.len() {
            v.fail("gratings.nominal_nm", &format!("{n_g} gratings cannot resolve {} measurands", m.len()));
        }
        let per_grating = |v: &mut Checker, key: &str, len: usize, empty_ok: bool| {
            if len != n_g && !(empty_ok && len == 0) {
                let also = if empty_ok { " (or none)" } else { "" };
                v.fail(
                    key,
                    &format!("{len} entries; one per grating ({n_g}, the length of gratings.nominal_nm){also}"),
                );
            }
        };
        let g = &self.gratings;
        per_grating(&mut v, "gratings.gauge", g.gauge.len(), false);
        for (i, row) in g.gauge.iter().enumerate() {
            if row.len() != m.len() {
                v.fail(
                    &format!("gratings.gauge[{i}]"),
                    &format!("{} entries; one per measurand ({}: {})", row.len(), m.len(), {
                        let names: Vec<String> = m.iter().map(|x| x.column()).collect();
                        names.join(", ")
                    }),
                );
            }
        }
        for (name, arr) in [
            ("c_tt", &g.c_tt),
            ("c_te", &g.c_te),
            ("c_tp", &g.c_tp),
            ("c_ee", &g.c_ee),
            ("c_pp", &g.c_pp),
            ("c_ep", &g.c_ep),
        ] {
            per_grating(&mut v, &format!("gratings.{name}"), arr.len(), true);
            let needs: &[Measurand] = match name {
                "c_tt" => &[Measurand::T],
                "c_te" => &[Measurand::T, Measurand::STRAIN],
                "c_tp" => &[Measurand::T, Measurand::P],
                "c_ee" => &[Measurand::STRAIN],
                "c_pp" => &[Measurand::P],
                _ => &[Measurand::STRAIN, Measurand::P],
            };
            if arr.iter().any(|&c| c != 0.0) {
                if let Some(x) = needs.iter().find(|x| !m.contains(x)) {
                    v.fail(
                        &format!("gratings.{name}"),
                        &format!("a cross-term on `{x}`, which is not among the measurands"),
                    );
                }
            }
        }
        per_grating(&mut v, "scan.ripple_phase_rad", self.scan.ripple_phase_rad.len(), false);
        per_grating(&mut v, "gratings.thermal_lag_s", g.thermal_lag_s.len(), true);
        per_grating(&mut v, "ageing.creep_fraction", self.ageing.creep_fraction.len(), true);
        per_grating(&mut v, "ageing.drift_pm_per_day", self.ageing.drift_pm_per_day.len(), true);
        per_grating(&mut v, "drift.channel_gain", self.drift.channel_gain.len(), false);
        let a = &self.ambient;
        v.range("ambient.lag_tau_s", a.lag_tau_s, 0.0, 1e8);
        v.range("ambient.offset_c", a.offset_c, -50.0, 50.0);
        v.nonneg("ambient.noise_sigma_c", a.noise_sigma_c, 50.0);
        v.nonneg("ambient.resolution_c", a.resolution_c, 10.0);
        for (i, nm) in g.nominal_nm.iter().enumerate() {
            v.range(&format!("gratings.nominal_nm[{i}]"), *nm, 400.0, 2500.0);
        }
        for (i, row) in g.gauge.iter().enumerate() {
            for (j, k) in row.iter().enumerate() {
                v.range(&format!("gratings.gauge[{i}][{j}]"), *k, -1e3, 1e3);
            }
        }
        v.nonneg("gratings.dispersion", g.dispersion, 0.5);
        for (name, arr) in [
            ("c_tt", &g.c_tt),
            ("c_te", &g.c_te),
            ("c_tp", &g.c_tp),
            ("c_ee", &g.c_ee),
            ("c_pp", &g.c_pp),
            ("c_ep", &g.c_ep),
        ] {
            for (i, c) in arr.iter().enumerate() {
                v.range(&format!("gratings.{name}[{i}]"), *c, -10.0, 10.0);
            }
        }
        v.range("gratings.ref_t_c", g.ref_t_c, -100.0, 300.0);
        v.range("gratings.ref_strain_ue", g.ref_strain_ue, -1e4, 1e4);
        v.range("gratings.ref_p_kpa", g.ref_p_kpa, 0.0, 1e5);
        for (i, tau) in g.thermal_lag_s.iter().enumerate() {
            v.range(&format!("gratings.thermal_lag_s[{i}]"), *tau, 0.0, 1e8);
        }
        let ag = &self.ageing;
        for (i, f) in ag.creep_fraction.iter().enumerate() {
            v.range(&format!("ageing.creep_fraction[{i}]"), *f, 0.0, 0.5);
        }
        v.range("ageing.creep_tau_s", ag.creep_tau_s, 1e-3, 1e10);
        for (i, r) in ag.drift_pm_per_day.iter().enumerate() {
            v.range(&format!("ageing.drift_pm_per_day[{i}]"), *r, -100.0, 100.0);
        }
        v.range("ageing.ageing_tau_days", ag.ageing_tau_days, 1e-3, 1e6);
        if v.ok() {
            let k = nalgebra::DMatrix::from_fn(n_g, m.len(), |i, j| g.gauge[i][j]);
            let svd = k.svd(false, false);
            let (mx, mn) = (svd.singular_values.max(), svd.singular_values.min());
            if !(mn > 0.0 && mx / mn < 1e6) {
                v.fail("gratings.gauge", "gauge matrix is singular or too ill-conditioned to invert");
            }
        }
        let h = &self.hysteresis;
        v.range("hysteresis.beta", h.beta, 0.0, 2.0);
        v.range("hysteresis.gamma", h.gamma, -1.0, 1.0);
        v.range("hysteresis.rho", h.rho, -1.0, 1.0);
        v.nonneg("hysteresis.play_half_width_pm", h.play_half_width_pm, 1e3);
        let bw = &h.bouc_wen;
        v.range("hysteresis.bouc_wen.a", bw.a, 1e-6, 10.0);
        v.range("hysteresis.bouc_wen.beta", bw.beta, 1e-9, 1e3);
        v.range("hysteresis.bouc_wen.gamma", bw.gamma, -bw.beta.abs(), bw.beta.abs());
        v.range("hysteresis.bouc_wen.n", bw.n, 1.0, 10.0);
        let pr = &h.preisach;
        v.nonneg("hysteresis.preisach.loop_width_pm", pr.loop_width_pm, 1e3);
        v.range("hysteresis.preisach.lo_pm", pr.lo_pm, -1e5, 1e5);
        v.range("hysteresis.preisach.hi_pm", pr.hi_pm, -1e5, 1e5);
        if v.ok() && pr.hi_pm <= pr.lo_pm {
            v.fail("hysteresis.preisach.hi_pm", "must be above hysteresis.preisach.lo_pm");
        }
        if !(2..=200).contains(&pr.cells) {
            v.fail("hysteresis.preisach.cells", &format!("{} is out of range [2, 200]", pr.cells));
        }
        v.range("hysteresis.preisach.sigma_pm", pr.sigma_pm, 1e-6, 1e5);
        let sc = &self.scan;
        v.nonneg("scan.ripple_amp_pm", sc.ripple_amp_pm, 1e3);
        v.range("scan.ripple_period_nm", sc.ripple_period_nm, 1e-3, 1e3);
        for (i, ph) in sc.ripple_phase_rad.iter().enumerate() {
            v.finite(&format!("scan.ripple_phase_rad[{i}]"), *ph);
        }
        v.range("scan.bow_pm", sc.bow_pm, -1e3, 1e3);
        v.range("scan.bow_half_span_nm", sc.bow_half_span_nm, 1e-3, 1e3);
        v.range("scan.bow_centre_nm", sc.bow_centre_nm, 400.0, 2500.0);
        let d = &self.drift;
        v.nonneg("drift.sigma_pm", d.sigma_pm, 100.0);
        for (i, gn) in d.channel_gain.iter().enumerate() {
            v.range(&format!("drift.channel_gain[{i}]"), *gn, -10.0, 10.0);
        }
        let e = &self.electronics;
        v.range("electronics.lin_pm_per_c", e.lin_pm_per_c, -100.0, 100.0);
        v.range("electronics.quad_pm_per_c2", e.quad_pm_per_c2, -10.0, 10.0);
        v.range("electronics.ref_c", e.ref_c, -100.0, 300.0);
        let n = &self.noise;
        v.nonneg("noise.pink_sigma_pm", n.pink_sigma_pm, 1e3);
        v.nonneg("noise.white_sigma_pm", n.white_sigma_pm, 1e3);
        if !(1..=40).contains(&n.pink_octaves) {
            v.fail("noise.pink_octaves", "must be in 1..=40");
        }
        let pc = &self.pace;
        v.range("pace.factor", pc.factor, 1e-3, 1e3);
        if let Some(o) = pc.only {
            if !m.contains(&o) {
                let names: Vec<String> = m.iter().map(|x| x.column()).collect();
                v.fail("pace.only", &format!("`{o}` is not among the measurands ({})", names.join(", ")));
            }
        }
        if self.name.is_empty() || self.name.len() > MAX_NAME_LEN {
            v.fail("name", "must be 1 to 24 characters");
        }
        v.result()
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

/// Longest scenario name (the model blob's provenance holds 24 bytes).
pub const MAX_NAME_LEN: usize = 24;

/// `x` in few characters: `4`, `0.25`, `0.333`.
fn short_number(x: f64) -> String {
    if x.is_finite() && x == x.round() && x.abs() < 1e9 {
        return format!("{}", x as i64);
    }
    let s = format!("{x:.3}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
    // Below the third decimal the fixed form would read 0.
    if x != 0.0 && s.parse::<f64>() == Ok(0.0) {
        format!("{x:e}")
    } else {
        s.to_string()
    }
}

/// `name` without its `@` suffixes for which `drop` holds (`paper@x4@steps` without the pace
/// is `paper@steps`).
fn without_segments(name: &str, drop: impl Fn(&str) -> bool) -> String {
    let mut parts = name.split('@');
    let mut out = parts.next().unwrap_or("").to_string();
    for seg in parts.filter(|seg| !drop(seg)) {
        out.push('@');
        out.push_str(seg);
    }
    out
}

/// `name` + `suffix` in at most [`MAX_NAME_LEN`] bytes: the base name (before any earlier
/// `@` suffix) is shortened first, down to one character, so that the suffixes stay readable;
/// only then is the end cut.
fn with_suffix(name: &str, suffix: &str) -> String {
    let (base, earlier) = name.split_at(name.find('@').unwrap_or(name.len()));
    let tail = format!("{earlier}{suffix}");
    let mut keep = MAX_NAME_LEN.saturating_sub(tail.len()).max(1).min(base.len());
    while !base.is_char_boundary(keep) {
        keep -= 1;
    }
    let mut out = format!("{}{tail}", &base[..keep]);
    let mut end = out.len().min(MAX_NAME_LEN);
    while !out.is_char_boundary(end) {
        end -= 1;
    }
    out.truncate(end);
    out
}

/// The measurands the simulator has trajectories for.
pub const SIMULATED: [Measurand; 4] =
    [Measurand::T, Measurand::STRAIN, Measurand { kind: Kind::Strain, index: 2 }, Measurand::P];

/// The checks of one strain trajectory (`strain` or `strain2`), its keys under `table`.
fn validate_strain(v: &mut Checker, table: &str, s: &Strain) {
    let key = |field: &str| format!("{table}.{field}");
    v.range(&key("level_lo_ue"), s.level_lo_ue, -1e4, 1e4);
    v.range(&key("level_hi_ue"), s.level_hi_ue, -1e4, 1e4);
    if s.level_hi_ue < s.level_lo_ue {
        v.fail(&key("level_hi_ue"), &format!("must be >= {}", key("level_lo_ue")));
    }
    v.range(&key("hold_s"), s.hold_s, 1e-3, 1e8);
    v.range(&key("ramp_s"), s.ramp_s, 0.0, 1e8);
    if s.ramp_s > s.hold_s {
        v.fail(&key("ramp_s"), &format!("must not exceed {}", key("hold_s")));
    }
    v.nonneg(&key("sine1_amp_ue"), s.sine1_amp_ue, 1e4);
    v.range(&key("sine1_period_s"), s.sine1_period_s, 1e-3, 1e9);
    v.nonneg(&key("sine2_amp_ue"), s.sine2_amp_ue, 1e4);
    v.range(&key("sine2_period_s"), s.sine2_period_s, 1e-3, 1e9);
    v.nonneg(&key("ar_sigma_ue"), s.ar_sigma_ue, 1e4);
    v.range(&key("ar_tau_s"), s.ar_tau_s, 1e-3, 1e8);
}

#[derive(Default)]
struct Checker {
    first: Option<(String, String)>,
}

impl Checker {
    fn ok(&self) -> bool {
        self.first.is_none()
    }
    fn fail(&mut self, key: &str, msg: &str) {
        if self.first.is_none() {
            self.first = Some((key.to_string(), msg.to_string()));
        }
    }
    fn finite(&mut self, key: &str, x: f64) {
        if !x.is_finite() {
            self.fail(key, "must be a finite number");
        }
    }
    fn range(&mut self, key: &str, x: f64, lo: f64, hi: f64) {
        if !(x.is_finite() && x >= lo && x <= hi) {
            self.fail(key, &format!("{x} is out of range [{lo}, {hi}]"));
        }
    }
    fn nonneg(&mut self, key: &str, x: f64, hi: f64) {
        self.range(key, x, 0.0, hi)
    }
    fn result(self) -> Result<(), (String, String)> {
        match self.first {
            None => Ok(()),
            Some(e) => Err(e),
        }
    }
}

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
