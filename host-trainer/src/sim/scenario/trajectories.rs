//! What the installation goes through: the measurands' trajectories and the ambient
//! temperature (with the thermometer that reads it).

use serde::{Deserialize, Serialize};

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
