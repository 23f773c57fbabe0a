//! Reading `metrics.json` back into a [`Metrics`].
//!
//! The study types only serialise, and serde_json writes a NaN (e.g. the CV figures of a
//! model evaluated from blobs) as `null`; so this module mirrors the JSON layout with
//! deserialisable types whose numbers accept `null` as NaN, and converts. A field added to
//! [`Metrics`] makes the conversion below fail to compile, so the mirror cannot drift silently.

use std::path::Path;

use serde::Deserialize;

use crate::error::TrainerError;
use crate::eval::metrics::RecalStudy;
use crate::eval::metrics::{AblationRow, BudgetRow, DriftSweep, Metrics, SelectionSummary, Table2};
use crate::eval::parity::ParityReport;
use crate::eval::score::{ChannelMetrics, ModelEval};
use crate::fit::select::CvRow;
use crate::fit::{Config, VarModel};

/// A number that may have been written as `null` (NaN).
#[derive(Clone, Copy, Debug)]
struct F(f64);

impl<'de> Deserialize<'de> for F {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(F(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN)))
    }
}

fn a3(v: Vec<F>) -> Vec<f64> {
    v.into_iter().map(|x| x.0).collect()
}

#[derive(Deserialize)]
struct ChannelDe {
    rmse: F,
    mae: F,
    r2: F,
    bias: F,
    max_abs: F,
    coverage: F,
    mean_band: F,
    hysteresis_index: F,
    n: usize,
}

impl From<ChannelDe> for ChannelMetrics {
    fn from(c: ChannelDe) -> Self {
        ChannelMetrics {
            rmse: c.rmse.0,
            mae: c.mae.0,
            r2: c.r2.0,
            bias: c.bias.0,
            max_abs: c.max_abs.0,
            coverage: c.coverage.0,
            mean_band: c.mean_band.0,
            hysteresis_index: c.hysteresis_index.0,
            n: c.n,
        }
    }
}

fn channels(v: Vec<ChannelDe>) -> Vec<ChannelMetrics> {
    v.into_iter().map(ChannelMetrics::from).collect()
}

#[derive(Deserialize)]
struct ModelEvalDe {
    channels: Vec<ChannelDe>,
    /// Three counts in metrics files written before the implausible flag.
    flag_counts: Vec<usize>,
    flagged_fraction: F,
}

impl From<ModelEvalDe> for ModelEval {
    fn from(m: ModelEvalDe) -> Self {
        let mut flag_counts = [0; 5];
        for (o, n) in flag_counts.iter_mut().zip(m.flag_counts) {
            *o = n;
        }
        ModelEval { channels: channels(m.channels), flag_counts, flagged_fraction: m.flagged_fraction.0 }
    }
}

#[derive(Deserialize)]
struct Table2De {
    model_p: ModelEvalDe,
    model_h: ModelEvalDe,
    gain_pct: Vec<F>,
    oracle_floor: Option<Vec<F>>,
    h_over_floor: Option<Vec<F>>,
}

#[derive(Deserialize)]
struct DriftDe {
    factors: Vec<F>,
    sigma_d_pm: Vec<F>,
    rmse_p: Vec<Vec<F>>,
    rmse_h: Vec<Vec<F>>,
    slope_p: Vec<F>,
    slope_h: Vec<F>,
    intercept_p: Vec<F>,
    intercept_h: Vec<F>,
}

#[derive(Deserialize)]
struct ConfigDe {
    feature_set: fbg_shared::FeatureSet,
    dead_band_pm: F,
    k: usize,
    sigma_mult: F,
    alpha_rel: F,
    cross_terms: bool,
}

impl From<ConfigDe> for Config {
    fn from(c: ConfigDe) -> Self {
        Config {
            feature_set: c.feature_set,
            dead_band_pm: c.dead_band_pm.0,
            k: c.k,
            sigma_mult: c.sigma_mult.0,
            alpha_rel: c.alpha_rel.0,
            cross_terms: c.cross_terms,
        }
    }
}

#[derive(Deserialize)]
struct AblationDe {
    name: String,
    note: String,
    channels: Vec<ChannelDe>,
    config: Option<ConfigDe>,
}

#[derive(Deserialize)]
struct BudgetDe {
    effect_off: String,
    rmse_p: Vec<F>,
    rmse_h: Vec<F>,
    oracle_floor: Vec<F>,
    #[serde(default)]
    not_fitted: Option<String>,
}

#[derive(Deserialize)]
struct ParityDe {
    samples: usize,
    max_abs_diff: Vec<F>,
    max_diff_over_rmse: Vec<F>,
    max_band_rel_diff: Vec<F>,
    flag_mismatches: usize,
    leverage_band_gap: F,
    leverage_max: F,
}

#[derive(Deserialize)]
struct RecalDe {
    batch_hours: F,
    batch_samples: usize,
    seed_old: u64,
    seed_new: u64,
    h_old: Vec<F>,
    h_short: Vec<F>,
    h_full: Vec<F>,
    p_old: Vec<F>,
    p_short: Vec<F>,
    p_full: Vec<F>,
    recovered_fraction_h: Vec<F>,
}

#[derive(Deserialize)]
struct VarModelDe {
    a: F,
    b: F,
    k95: F,
    /// Absent from metrics written before the slope was shrunk.
    #[serde(default)]
    b_fitted: Option<F>,
    #[serde(default)]
    b_se: Option<F>,
    /// Absent from metrics written before the band knew its floor and clock.
    #[serde(default)]
    a_floor: Option<F>,
    #[serde(default)]
    lead_max_s: Option<F>,
    #[serde(default)]
    cv_coverage: Option<F>,
}

impl From<VarModelDe> for VarModel {
    fn from(v: VarModelDe) -> Self {
        VarModel {
            a: v.a.0,
            b: v.b.0,
            k95: v.k95.0,
            b_fitted: v.b_fitted.map_or(v.b.0, |x| x.0),
            b_se: v.b_se.map_or(0.0, |x| x.0),
            a_floor: v.a_floor.map_or(f64::NAN, |x| x.0),
            lead_max_s: v.lead_max_s.map_or(f64::NAN, |x| x.0),
            cv_coverage: v.cv_coverage.map_or(f64::NAN, |x| x.0),
        }
    }
}

#[derive(Deserialize)]
struct CvRowDe {
    config: ConfigDe,
    cv_rmse: Vec<F>,
    score: F,
}

#[derive(Deserialize)]
struct SelectionDe {
    chosen: ConfigDe,
    cv_rmse_p: Vec<F>,
    cv_rmse_h: Vec<F>,
    var_model_p: Vec<VarModelDe>,
    var_model_h: Vec<VarModelDe>,
    #[serde(default)]
    folds: Vec<(usize, usize)>,
    #[serde(default)]
    grid_points: usize,
    #[serde(default)]
    top: Vec<CvRowDe>,
}

#[derive(Deserialize)]
struct MetricsDe {
    trainer_version: String,
    scenario: String,
    seed: u64,
    samples: usize,
    cal_samples: usize,
    holdout_samples: usize,
    channels: Vec<String>,
    units: Vec<String>,
    /// Absent from metrics written before warnings were recorded.
    #[serde(default)]
    warnings: Vec<crate::warning::Warning>,
    selection: SelectionDe,
    table2: Table2De,
    drift_sweep: Option<DriftDe>,
    ablation: Option<Vec<AblationDe>>,
    error_budget: Option<Vec<BudgetDe>>,
    parity: Option<ParityDe>,
    #[serde(default)]
    recalibration: Option<Vec<RecalDe>>,
    /// Absent from metrics written before static fidelity.
    #[serde(default)]
    static_fidelity: Option<crate::eval::metrics::StaticFidelity>,
    #[serde(default)]
    pace: Option<crate::eval::pace::PaceStudy>,
    #[serde(default)]
    timings_s: Vec<(String, F)>,
}

impl From<MetricsDe> for Metrics {
    fn from(m: MetricsDe) -> Self {
        let s = m.selection;
        let t = m.table2;
        Metrics {
            trainer_version: m.trainer_version,
            scenario: m.scenario,
            seed: m.seed,
            samples: m.samples,
            cal_samples: m.cal_samples,
            holdout_samples: m.holdout_samples,
            channels: m.channels,
            units: m.units,
            warnings: m.warnings,
            selection: SelectionSummary {
                chosen: s.chosen.into(),
                cv_rmse_p: a3(s.cv_rmse_p),
                cv_rmse_h: a3(s.cv_rmse_h),
                var_model_p: s.var_model_p.into_iter().map(VarModel::from).collect(),
                var_model_h: s.var_model_h.into_iter().map(VarModel::from).collect(),
                folds: s.folds,
                grid_points: s.grid_points,
                top: s
                    .top
                    .into_iter()
                    .map(|r| CvRow { config: r.config.into(), cv_rmse: a3(r.cv_rmse), score: r.score.0 })
                    .collect(),
            },
            table2: Table2 {
                model_p: t.model_p.into(),
                model_h: t.model_h.into(),
                gain_pct: a3(t.gain_pct),
                oracle_floor: t.oracle_floor.map(a3),
                h_over_floor: t.h_over_floor.map(a3),
            },
            drift_sweep: m.drift_sweep.map(|d| DriftSweep {
                factors: d.factors.into_iter().map(|x| x.0).collect(),
                sigma_d_pm: d.sigma_d_pm.into_iter().map(|x| x.0).collect(),
                rmse_p: d.rmse_p.into_iter().map(a3).collect(),
                rmse_h: d.rmse_h.into_iter().map(a3).collect(),
                slope_p: a3(d.slope_p),
                slope_h: a3(d.slope_h),
                intercept_p: a3(d.intercept_p),
                intercept_h: a3(d.intercept_h),
            }),
            ablation: m.ablation.map(|rows| {
                rows.into_iter()
                    .map(|r| AblationRow {
                        name: r.name,
                        note: r.note,
                        channels: channels(r.channels),
                        config: r.config.map(Config::from),
                    })
                    .collect()
            }),
            error_budget: m.error_budget.map(|rows| {
                rows.into_iter()
                    .map(|r| BudgetRow {
                        effect_off: r.effect_off,
                        rmse_p: a3(r.rmse_p),
                        rmse_h: a3(r.rmse_h),
                        oracle_floor: a3(r.oracle_floor),
                        not_fitted: r.not_fitted,
                    })
                    .collect()
            }),
            parity: m.parity.map(|p| ParityReport {
                samples: p.samples,
                max_abs_diff: a3(p.max_abs_diff),
                max_diff_over_rmse: a3(p.max_diff_over_rmse),
                max_band_rel_diff: a3(p.max_band_rel_diff),
                flag_mismatches: p.flag_mismatches,
                leverage_band_gap: p.leverage_band_gap.0,
                leverage_max: p.leverage_max.0,
            }),
            recalibration: m.recalibration.map(|rows| {
                rows.into_iter()
                    .map(|r| RecalStudy {
                        batch_hours: r.batch_hours.0,
                        batch_samples: r.batch_samples,
                        seed_old: r.seed_old,
                        seed_new: r.seed_new,
                        h_old: a3(r.h_old),
                        h_short: a3(r.h_short),
                        h_full: a3(r.h_full),
                        p_old: a3(r.p_old),
                        p_short: a3(r.p_short),
                        p_full: a3(r.p_full),
                        recovered_fraction_h: a3(r.recovered_fraction_h),
                    })
                    .collect()
            }),
            static_fidelity: m.static_fidelity,
            pace: m.pace,
            timings_s: m.timings_s.into_iter().map(|(k, v)| (k, v.0)).collect(),
        }
    }
}

/// Parse `metrics.json` text.
pub fn metrics_from_str(text: &str, name: &str) -> Result<Metrics, TrainerError> {
    let de: MetricsDe = serde_json::from_str(text).map_err(|e| TrainerError::Model {
        path: name.to_string(),
        message: format!("not a metrics.json this trainer understands: {e}"),
    })?;
    Ok(de.into())
}

/// Read `metrics.json`.
pub fn read_metrics(path: &Path) -> Result<Metrics, TrainerError> {
    let text = std::fs::read_to_string(path).map_err(|e| TrainerError::io(path, e))?;
    metrics_from_str(&text, &path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_reads_as_nan() {
        let v: Vec<F> = serde_json::from_str("[1.5, null, -2]").unwrap();
        assert_eq!(v[0].0, 1.5);
        assert!(v[1].0.is_nan());
        assert_eq!(v[2].0, -2.0);
    }
}
