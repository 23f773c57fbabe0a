//! Reading `metrics.json` back into a [`Metrics`].
//!
//! `fbg_report` reads the study types (numbers written as `null`, NaN, read back as NaN); what
//! it leaves to the trainer, the selection (its configurations, band models and grid rows), is
//! mirrored here with deserialisable types whose numbers accept `null` and whose keys an older
//! file lacks get the values the trainer gave them then. A field added to [`SelectionSummary`],
//! [`Config`] or [`VarModel`] makes the conversion below fail to compile, so the mirror cannot
//! drift silently.

use std::path::Path;

use serde::Deserialize;

use crate::error::TrainerError;
use crate::eval::metrics::{AblationRow, Metrics, SelectionSummary};
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
    /// Absent from metrics written before the band read the errors' random walk.
    #[serde(default)]
    random_walk_rate: Option<F>,
    /// Absent from metrics written before the band added the stated walk as a walk.
    #[serde(default)]
    stated_walk_rate: Option<F>,
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
            random_walk_rate: v.random_walk_rate.map_or(f64::NAN, |x| x.0),
            stated_walk_rate: v.stated_walk_rate.map_or(f64::NAN, |x| x.0),
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
    /// Absent from metrics written before the band read the drift's walk; null when not read.
    #[serde(default)]
    drift_rate_pm2_per_s: Option<F>,
    #[serde(default)]
    folds: Vec<(usize, usize)>,
    #[serde(default)]
    grid_points: usize,
    #[serde(default)]
    top: Vec<CvRowDe>,
}

impl From<SelectionDe> for SelectionSummary {
    fn from(s: SelectionDe) -> Self {
        SelectionSummary {
            chosen: s.chosen.into(),
            cv_rmse_p: a3(s.cv_rmse_p),
            cv_rmse_h: a3(s.cv_rmse_h),
            var_model_p: s.var_model_p.into_iter().map(VarModel::from).collect(),
            var_model_h: s.var_model_h.into_iter().map(VarModel::from).collect(),
            drift_rate_pm2_per_s: s.drift_rate_pm2_per_s.map(|x| x.0).filter(|x| x.is_finite()),
            folds: s.folds,
            grid_points: s.grid_points,
            top: s
                .top
                .into_iter()
                .map(|r| CvRow { config: r.config.into(), cv_rmse: a3(r.cv_rmse), score: r.score.0 })
                .collect(),
        }
    }
}

/// The file as read: `fbg_report`'s types with the mirrors above for the trainer's own.
type MetricsDe = fbg_report::Metrics<SelectionDe, ConfigDe>;

/// The trainer's types in place of the mirrors.
fn metrics(m: MetricsDe) -> Metrics {
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
        selection: m.selection.into(),
        table2: m.table2,
        drift_sweep: m.drift_sweep,
        ablation: m.ablation.map(|rows| {
            rows.into_iter()
                .map(|r| AblationRow {
                    name: r.name,
                    note: r.note,
                    channels: r.channels,
                    config: r.config.map(Config::from),
                })
                .collect()
        }),
        error_budget: m.error_budget,
        parity: m.parity,
        recalibration: m.recalibration,
        static_fidelity: m.static_fidelity,
        pace: m.pace,
        timings_s: m.timings_s,
    }
}

/// Parse `metrics.json` text.
pub fn metrics_from_str(text: &str, name: &str) -> Result<Metrics, TrainerError> {
    let de: MetricsDe = serde_json::from_str(text).map_err(|e| TrainerError::Model {
        path: name.to_string(),
        message: format!("not a metrics.json this trainer understands: {e}"),
    })?;
    Ok(metrics(de))
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
