//! The built-in scenarios.

use serde::{Deserialize, Serialize};

use super::{Ageing, Gratings, HysteresisModel, ScenarioConfig, Strain};
use crate::data::measurand::{Kind, Measurand};

/// Built-in presets; [`Preset::description`] says what each simulates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// DESIGN §3 defaults.
    Paper,
    /// More drift and play, and a hold-out beyond the calibration range.
    Harsh,
    /// One temperature grating.
    #[serde(rename = "temperature-1")]
    Temperature1,
    /// A strain grating and its temperature reference.
    #[serde(rename = "strain-pair")]
    StrainPair,
    /// Eight gratings on one fibre, four measurands.
    #[serde(rename = "array-8")]
    Array8,
    /// The `paper` installation as a field deployment sees it.
    Field,
}

impl Preset {
    /// The preset's configuration.
    pub fn config(self) -> ScenarioConfig {
        match self {
            Preset::Paper => ScenarioConfig::default(),
            Preset::Harsh => harsh(),
            Preset::Temperature1 => temperature_1(),
            Preset::StrainPair => strain_pair(),
            Preset::Array8 => array_8(),
            Preset::Field => field(),
        }
    }

    /// The name on the command line (`--preset`), also the name of its configuration.
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

    /// What the preset simulates, in one paragraph (`simulate --help` lists it).
    pub fn description(self) -> &'static str {
        match self {
            Preset::Paper => {
                "DESIGN §3 defaults: three gratings (strain, temperature reference, pressure diaphragm), outputs T, ε, p"
            }
            Preset::Harsh => {
                "Drift σ×4, play 8 pm, a ±15 °C seasonal swing so the hold-out leaves the calibration range"
            }
            Preset::Temperature1 => "One temperature grating (10 pm/°C), output T",
            Preset::StrainPair => {
                "A strain grating (1.2 pm/µε, 10 pm/°C) and a strain-free temperature-reference grating beside it, \
                 outputs T and ε"
            }
            Preset::Array8 => {
                "Eight gratings on one fibre: an axial and a transverse (Poisson) strain grating and a temperature \
                 reference at each of two locations, a pressure diaphragm and its temperature reference; outputs T, \
                 ε, ε2, p"
            }
            Preset::Field => {
                "The `paper` installation as a field deployment sees it: Bouc–Wen hysteresis of a piezo-tuned \
                 filter instead of Eq. 9 + play; package thermal lags of 5 / 10 / 15 min (the strain grating bonded \
                 to the surface follows fastest, the reference loose in its tube slower, the diaphragm inside its \
                 housing slowest); 2 % adhesive creep of the bonded strain grating over 2 days; Bragg-wavelength \
                 ageing of 0.2 pm/day on every grating (saturating over 60 days); a digital ambient thermometer \
                 with 0.0625 °C steps (a DS18B20 at 12 bits); logger timestamps jittered by 2 s; about two \
                 recording gaps a day of 10 min on average (link drop-outs, reboots)"
            }
        }
    }

    /// Every preset, in the order `--help` lists them.
    pub const ALL: [Preset; 6] =
        [Preset::Paper, Preset::Harsh, Preset::Temperature1, Preset::StrainPair, Preset::Array8, Preset::Field];
}

/// By its name ([`Preset::name`]); the error lists the names.
impl std::str::FromStr for Preset {
    type Err = String;
    fn from_str(name: &str) -> Result<Self, Self::Err> {
        Preset::ALL.into_iter().find(|p| p.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
            format!("unknown preset `{name}` ({})", names.join(", "))
        })
    }
}

/// `harsh`: the `paper` installation with more drift and play, its hold-out above the calibration range.
fn harsh() -> ScenarioConfig {
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

/// `temperature-1`: one temperature grating.
fn temperature_1() -> ScenarioConfig {
    let mut c =
        ScenarioConfig { name: "temperature-1".into(), measurands: vec![Measurand::T], ..ScenarioConfig::default() };
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

/// `strain-pair`: a bonded strain grating and a loose temperature reference beside it.
fn strain_pair() -> ScenarioConfig {
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

/// `array-8`: eight gratings on one fibre, two strain locations and a pressure port.
fn array_8() -> ScenarioConfig {
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

/// `field`: the `paper` installation with the effects of a field deployment.
fn field() -> ScenarioConfig {
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
