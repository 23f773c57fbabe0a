//! The sensing chain: the gratings (their physics and ageing) and the interrogator (its
//! hysteresis, scan nonlinearity, drift, electronics and noise).

use serde::{Deserialize, Serialize};

use crate::data::measurand::Measurand;

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

impl Gratings {
    /// The cross-terms, each with its key in the configuration and the measurands it is on.
    pub(crate) fn cross_terms(&self) -> [(&'static str, &[f64], &'static [Measurand]); 6] {
        [
            ("c_tt", &self.c_tt, &[Measurand::T]),
            ("c_te", &self.c_te, &[Measurand::T, Measurand::STRAIN]),
            ("c_tp", &self.c_tp, &[Measurand::T, Measurand::P]),
            ("c_ee", &self.c_ee, &[Measurand::STRAIN]),
            ("c_pp", &self.c_pp, &[Measurand::P]),
            ("c_ep", &self.c_ep, &[Measurand::STRAIN, Measurand::P]),
        ]
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
