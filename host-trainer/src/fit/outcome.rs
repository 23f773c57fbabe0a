//! What a fit tells its user: the hyper-parameters and memory terms it chose ([`Chosen`]) and
//! its warnings as data (`train_warnings`): Model-H worse than Model-P in the fit's own
//! cross-validation, static gains that disagree, no ambient thermometer for a temperature
//! output, reference outliers left out. `train` prints them, `--json` and `coefficients.json`
//! carry them.

use serde::Serialize;

use fbg_shared::layout::{Dims, Quantity};

use super::grid::Config;
use super::host::HostParams;
use super::select::Selection;
use super::static_fidelity::{StaticAudit, STATIC_GAIN_TOLERANCE};
use crate::data::outliers::{self, Outlier};
use crate::data::{Kind, Measurand};
use crate::warning::Warning;

/// The memory terms one output uses.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MemoryUse {
    /// The output's channel (`T`, `strain`, `p2`, …).
    pub output: String,
    /// Its groups by name (`ambient-high-pass`, `stop`, `drift-observer`, …); empty: none.
    pub groups: Vec<&'static str>,
    /// The ridge penalty λ per sample on its standardised memory terms (absent without terms).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda: Option<f64>,
}

/// What cross-validation chose, with the values the final fit derived from it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Chosen {
    /// The grid point: feature set, dead band, K, σ multiple, α per sample, cross terms.
    #[serde(flatten)]
    pub config: Config,
    /// The RBF width σ itself (standardised input units): `sigma_mult` × the median
    /// nearest-neighbour distance of the centres.
    pub sigma: f64,
    /// The ridge penalty α of the RBF weights: `alpha_rel` × the calibration rows.
    pub alpha: f64,
    /// Per output, the memory terms of the core.
    pub memory: Vec<MemoryUse>,
}

impl Chosen {
    /// The choice behind Model-H `model_h`, selected as `selection` says.
    pub fn of(selection: &Selection, model_h: &HostParams) -> Chosen {
        let memory = model_h
            .dims
            .outputs()
            .iter()
            .enumerate()
            .map(|(o, out)| {
                let groups = selection.memory.names(o);
                let lambda = (!groups.is_empty()).then(|| selection.memory.lambda.get(o).copied().unwrap_or(0.0));
                MemoryUse { output: out.channel().as_str().to_string(), groups, lambda }
            })
            .collect();
        Chosen { config: selection.chosen, sigma: model_h.hyper.sigma, alpha: model_h.hyper.alpha, memory }
    }

    /// One line: "hysteresis-aware features, K = 8, σ = 4×NN (2.31), α = 1e-6·n (0.00144),
    /// dead band 4 pm; memory terms: T ambient-high-pass + drift-observer (λ = 1e-5), strain
    /// none, p stop (λ = 1e-6)".
    pub fn text(&self) -> String {
        let c = &self.config;
        let memory: Vec<String> = self
            .memory
            .iter()
            .map(|m| match m.lambda {
                Some(l) if !m.groups.is_empty() => format!("{} {} (λ = {l:e})", m.output, m.groups.join(" + ")),
                _ => format!("{} none", m.output),
            })
            .collect();
        format!(
            "{} features, K = {}, σ = {}×NN ({:.3}), α = {:e}·n ({:.3e}), dead band {} pm{}; memory terms: {}",
            c.feature_set.name(),
            c.k,
            c.sigma_mult,
            self.sigma,
            c.alpha_rel,
            self.alpha,
            c.dead_band_pm,
            if c.cross_terms { "" } else { ", no cross terms" },
            memory.join(", ")
        )
    }
}

/// The unit suffix of a figure's name for a measurand: `c`, `ue`, `kpa` (from `T_C`,
/// `strain_ue`, `p_kPa`).
fn unit_suffix(m: Measurand) -> String {
    let col = m.column();
    col.split_once('_').map(|(_, u)| u.to_lowercase()).unwrap_or_default()
}

/// Decimals a figure of `m` is printed with.
fn digits(m: Measurand) -> usize {
    if m.kind == Kind::Temperature {
        3
    } else {
        2
    }
}

/// The warnings of a fit of `dims`: per output where Model-H's cross-validated RMSE is above
/// Model-P's (`model_h_worse_cv`) and where the two static gains disagree by more than
/// [`STATIC_GAIN_TOLERANCE`] (`static_gain_disagreement`); a temperature output without the
/// ambient thermometer (`no_ambient_thermometer`); per reference column, the calibration rows
/// left out for outliers in it (`reference_outliers_skipped`, `skipped` as [`super::trained::Trained`]
/// keeps them).
pub(crate) fn train_warnings(
    dims: &Dims,
    selection: &Selection,
    audit: &StaticAudit,
    skipped: &[Outlier],
) -> Vec<Warning> {
    let outs = Measurand::of_dims(dims);
    let channel = |c: usize| dims.outputs().get(c).map(|o| o.channel().as_str().to_string()).unwrap_or_default();
    let mut w = Vec::new();
    // Reference outliers first: they explain anything odd below.
    let mut columns: Vec<&str> = skipped.iter().map(|o| o.column.as_str()).collect();
    columns.sort_unstable();
    columns.dedup();
    for col in columns {
        let cells: Vec<Outlier> = skipped.iter().filter(|o| o.column == col).cloned().collect();
        let Some(first) = cells.first() else { continue };
        let largest = cells.iter().map(|o| o.z.abs()).fold(0.0, f64::max);
        let n = cells.len();
        let mut warning = Warning::new(
            "reference_outliers_skipped",
            if n == 1 {
                format!(
                    "left out 1 calibration row with a reference outlier in {col} (line {}: {})",
                    first.line,
                    first.describe()
                )
            } else {
                format!(
                    "left out {n} calibration rows with reference outliers in {col} (lines {}; the first: {})",
                    outliers::first_lines(&cells),
                    first.describe()
                )
            },
        )
        .with("rows", n as f64)
        .with("first_line", first.line as f64)
        .with("largest_abs_z", largest);
        if let Some(c) = outs.iter().position(|m| m.column() == col) {
            warning = warning.on_channel(channel(c));
        }
        w.push(warning);
    }
    for (c, m) in outs.iter().enumerate() {
        let (h, p) = (selection.cv_rmse_h.get(c).copied(), selection.cv_rmse_p.get(c).copied());
        let (Some(h), Some(p)) = (h, p) else { continue };
        if h > p {
            let (u, dg) = (unit_suffix(*m), digits(*m));
            w.push(
                Warning::new(
                    "model_h_worse_cv",
                    format!(
                        "in cross-validation Model-H is worse than Model-P on {} ({h:.dg$} against {p:.dg$} {}); check the hold-out with `evaluate` and consider Model-P for that channel",
                        channel(c),
                        m.unit()
                    ),
                )
                .on_channel(channel(c))
                .with(format!("cv_rmse_h_{u}"), h)
                .with(format!("cv_rmse_p_{u}"), p)
                .with("ratio", h / p),
            );
        }
    }
    for (c, h, p) in audit.disagreements() {
        let diff = 100.0 * (h / p - 1.0);
        let tol = 100.0 * STATIC_GAIN_TOLERANCE;
        w.push(
            Warning::new(
                "static_gain_disagreement",
                format!(
                    "Model-H's static gain on {} is {h:.4}, Model-P's {p:.4} ({diff:+.1} %, more than {tol} %): its memory terms or residual carry part of the measurand, so it will read wrong at a pace other than the calibration's; use Model-P for that channel or recalibrate on a record with holds",
                    channel(c)
                ),
            )
            .on_channel(channel(c))
            .with("gain_h", h)
            .with("gain_p", p)
            .with("difference_pct", diff)
            .with("tolerance_pct", tol),
        );
    }
    if let Some(c) = dims.position(Quantity::Temperature).filter(|_| !dims.ambient()) {
        // The band is calibrated on drift the batch shows; without a thermometer a common-mode
        // drift of the interrogator reads as a temperature change and keeps growing after
        // calibration.
        w.push(
            Warning::new(
                "no_ambient_thermometer",
                "no ambient thermometer: the temperature output cannot tell interrogator drift from a temperature change (no drift observer), so its error can grow after calibration faster than its 95 % band; check T against a reference regularly or recalibrate",
            )
            .on_channel(channel(c)),
        );
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::memory_core::MemoryChoice;
    use crate::fit::static_fidelity::{Contributions, StaticGain};
    use fbg_shared::layout::FeatureSet;

    fn selection(cv_p: Vec<f64>, cv_h: Vec<f64>) -> Selection {
        Selection {
            chosen: Config {
                feature_set: FeatureSet::HysteresisAware,
                dead_band_pm: 2.0,
                k: 8,
                sigma_mult: 1.0,
                alpha_rel: 1e-5,
                cross_terms: true,
            },
            memory: MemoryChoice::none(),
            memory_rows: vec![],
            rows: vec![],
            cv_rmse_p: cv_p,
            cv_rmse_h: cv_h,
            var_model_p: vec![],
            var_model_h: vec![],
            drift_rate_pm2_per_s: None,
            stated_drift_pm_per_sqrt_day: None,
            stated_drift_gains: None,
            folds: vec![],
            n_cal: 300,
            cv_stride: 1,
        }
    }

    #[test]
    fn every_train_warning_names_its_channel_and_carries_its_numbers() {
        let dims = Dims::new(2, false, &[Measurand::T.output(), Measurand::STRAIN.output()]).unwrap();
        let g = |gain: Vec<f64>| StaticGain { offset: vec![0.0; 2], rows: vec![1; 2], gain };
        let audit = StaticAudit {
            model_p: g(vec![1.0, 1.0]),
            model_h: g(vec![1.0, 0.95]),
            contributions: Contributions { memory: vec![], rbf: vec![] },
        };
        let cell = Outlier {
            row: 100,
            line: 102,
            column: "T_C".into(),
            unit: "°C",
            value: 1e6,
            median: 21.5,
            scale: 0.1,
            z: 1e7,
        };
        let w = train_warnings(&dims, &selection(vec![0.25, 3.0], vec![0.31, 2.0]), &audit, &[cell]);
        let codes: Vec<(&str, Option<&str>)> = w.iter().map(|w| (w.code.as_str(), w.channel.as_deref())).collect();
        assert_eq!(
            codes,
            [
                ("reference_outliers_skipped", Some("T")),
                ("model_h_worse_cv", Some("T")),
                ("static_gain_disagreement", Some("strain")),
                ("no_ambient_thermometer", Some("T")),
            ]
        );
        assert!(w[0].message.contains("line 102") && w[0].message.contains("1000000 °C"), "{}", w[0]);
        assert_eq!(w[0].numbers["rows"], 1.0);
        assert_eq!(w[1].numbers["cv_rmse_h_c"], 0.31);
        assert_eq!(w[1].numbers["cv_rmse_p_c"], 0.25);
        assert!(w[1].message.contains("Model-H is worse than Model-P on T"), "{}", w[1]);
        assert_eq!(w[2].numbers["gain_h"], 0.95);
        // The serde form other commands read back from coefficients.json.
        let v = serde_json::to_value(&w[1]).unwrap();
        assert_eq!(v["code"], "model_h_worse_cv");
        assert_eq!(v["channel"], "T");
        let back: Warning = serde_json::from_value(v).unwrap();
        assert_eq!(back, w[1]);
        // Model-H ahead everywhere, gains agreeing, a thermometer, nothing left out: silence.
        let dims = Dims::new(2, true, &[Measurand::T.output(), Measurand::STRAIN.output()]).unwrap();
        let audit = StaticAudit { model_h: g(vec![1.0, 1.0]), ..audit };
        assert!(train_warnings(&dims, &selection(vec![0.25, 3.0], vec![0.2, 2.0]), &audit, &[]).is_empty());
    }

    #[test]
    fn the_choice_reads_as_one_line_with_memory_groups_and_lambda() {
        let sel = selection(vec![0.25], vec![0.2]);
        let c = Chosen {
            config: sel.chosen,
            sigma: 2.5,
            alpha: 0.003,
            memory: vec![
                MemoryUse {
                    output: "T".into(),
                    groups: vec!["ambient-high-pass", "drift-observer"],
                    lambda: Some(1e-5),
                },
                MemoryUse { output: "strain".into(), groups: vec![], lambda: None },
            ],
        };
        let t = c.text();
        assert!(
            t.starts_with("hysteresis-aware features, K = 8, σ = 1×NN (2.500), α = 1e-5·n (3.000e-3), dead band 2 pm"),
            "{t}"
        );
        assert!(t.ends_with("memory terms: T ambient-high-pass + drift-observer (λ = 1e-5), strain none"), "{t}");
        let v = serde_json::to_value(&c).unwrap();
        assert_eq!(v["k"], 8);
        assert_eq!(v["memory"][0]["lambda"], 1e-5);
        assert!(v["memory"][1].get("lambda").is_none());
    }
}
