//! What an evaluation finds worth a warning, as data ([`Warning`]): the one list that
//! `metrics.json` carries (`warnings`), `evaluate` and `demo` print and the report opens with.
//!
//! From the metrics of a model pair ([`evaluation`]): Model-H worse than Model-P on a channel of
//! the hold-out, a 95 % band that held the truth on less than [`BAND_WARN_BELOW`] of it, the
//! two models' static gains disagreeing by more than
//! [`crate::fit::static_fidelity::STATIC_GAIN_TOLERANCE`], a temperature output without an
//! ambient thermometer. Beside them, the warnings `train` recorded in the model's
//! `coefficients.json` ([`from_coefficients`]), merged by [`merge`].

use std::path::Path;

use fbg_shared::layout::{Dims, Quantity};

use crate::eval::metrics::Metrics;
use crate::fit::static_fidelity::STATIC_GAIN_TOLERANCE;
use crate::warning::Warning;

/// Hold-out coverage of the 95 % band below which `evaluate` warns: well below the sampling
/// spread of an honest band over a week of autocorrelated errors.
pub const BAND_WARN_BELOW: f64 = 0.90;

/// Share of the hold-out outside the calibration envelope from which a worse Model-H is put
/// down to extrapolation (the residual has no data there) rather than to the model.
pub(crate) const ENVELOPE_EXPLAINS_FROM: f64 = 0.10;

/// The suffix that names a figure's unit in [`Warning::numbers`] (`c`, `ue`, `kpa`), as the
/// dataset's column names do (`T_C`, `strain_ue`, `p_kPa`).
fn unit_tag(unit: &str) -> String {
    match unit {
        "°C" => "c".into(),
        "µε" => "ue".into(),
        "kPa" => "kpa".into(),
        other => other.to_lowercase(),
    }
}

/// Decimals that suit a unit (°C: 3, µε and kPa: 2), as in the tables.
fn digits(unit: &str) -> usize {
    if unit == "°C" {
        3
    } else {
        2
    }
}

/// The warnings the metrics `m` of a model pair with dimensions `dims` give, in a stable order:
/// per channel, Model-H worse on the hold-out; per model and channel, a band that covered too
/// little; per channel, a static-gain disagreement; then the missing thermometer.
pub fn evaluation(m: &Metrics, dims: &Dims) -> Vec<Warning> {
    let mut out = Vec::new();
    let t = &m.table2;
    let nch = m.channels.len().min(t.model_h.channels.len()).min(t.model_p.channels.len()).min(t.gain_pct.len());
    let scored = t.model_h.channels.iter().map(|c| c.n).max().unwrap_or(0).max(1) as f64;
    let outside = t.model_h.flag_counts[1] as f64 / scored;
    for c in (0..nch).filter(|&c| t.gain_pct[c] < 0.0) {
        let g = t.gain_pct[c];
        let (ch, unit) = (&m.channels[c], &m.units[c]);
        let (h, p) = (t.model_h.channels[c].rmse, t.model_p.channels[c].rmse);
        let dg = digits(unit);
        let why = if outside >= ENVELOPE_EXPLAINS_FROM {
            format!(
                "{:.0} % of the hold-out lies outside the calibration envelope, where the residual has no data: calibrate over the range the sensor will see, or use Model-P for {ch}",
                100.0 * outside
            )
        } else {
            format!("use Model-P for {ch}, or recalibrate on recent data")
        };
        let tag = unit_tag(unit);
        out.push(
            Warning::new(
                "model_h_worse_holdout",
                format!("Model-H is worse than Model-P on {ch} of the hold-out (RMSE {h:.dg$} vs {p:.dg$} {unit}, {g:+.1} %); {why}"),
            )
            .on_channel(ch.as_str())
            .with(format!("rmse_h_{tag}"), h)
            .with(format!("rmse_p_{tag}"), p)
            .with("gain_pct", g)
            .with("outside_envelope_pct", 100.0 * outside),
        );
    }
    for (code, name, e) in
        [("model_h_band_coverage_low", "Model-H", &t.model_h), ("model_p_band_coverage_low", "Model-P", &t.model_p)]
    {
        for (c, ch) in e.channels.iter().enumerate().take(nch).filter(|(_, ch)| ch.coverage < BAND_WARN_BELOW) {
            out.push(
                Warning::new(
                    code,
                    format!(
                        "{name}'s 95 % band covered less than {:.0} % of the hold-out on {} ({:.1} %): the error grew beyond what the calibration batch showed (drift, or conditions the batch did not contain); do not rely on that band, recalibrate on recent data",
                        100.0 * BAND_WARN_BELOW,
                        m.channels[c],
                        100.0 * ch.coverage
                    ),
                )
                .on_channel(m.channels[c].as_str())
                .with("coverage_pct", 100.0 * ch.coverage)
                .with("nominal_pct", 95.0)
                .with("warn_below_pct", 100.0 * BAND_WARN_BELOW),
            );
        }
    }
    if let Some(sf) = &m.static_fidelity {
        for (c, (&h, &p)) in sf.gain_h.iter().zip(&sf.gain_p).enumerate().take(nch) {
            if !(h.is_finite() && p.is_finite() && (h / p - 1.0).abs() > STATIC_GAIN_TOLERANCE) {
                continue;
            }
            let ch = &m.channels[c];
            out.push(
                Warning::new(
                    "static_gain_disagreement",
                    format!(
                        "Model-H's static gain on {ch} is {h:.4}, Model-P's {p:.4} ({:+.1} %, more than {} %): its memory terms or residual carry part of the measurand, so it will read wrong at a pace other than the calibration's; use Model-P for that channel or recalibrate on a record with holds",
                        100.0 * (h / p - 1.0),
                        100.0 * STATIC_GAIN_TOLERANCE
                    ),
                )
                .on_channel(ch.as_str())
                .with("gain_h", h)
                .with("gain_p", p)
                .with("difference_pct", 100.0 * (h / p - 1.0))
                .with("tolerance_pct", 100.0 * STATIC_GAIN_TOLERANCE),
            );
        }
    }
    if let Some(t) = dims.position(Quantity::Temperature).filter(|_| !dims.ambient()) {
        out.push(
            Warning::new(
                "no_ambient_thermometer",
                "no ambient thermometer: the temperature output cannot tell interrogator drift from a temperature change (no drift observer), so its error can grow after calibration faster than its 95 % band; check T against a reference regularly or recalibrate",
            )
            .on_channel(dims.outputs()[t].channel().as_str()),
        );
    }
    out
}

/// The warnings `train` recorded in a model's `coefficients.json` (its `warnings` array of
/// [`Warning`]s): none when the file or the key is absent (a model trained before they were
/// recorded); one warning saying so when the file cannot be read or an entry is not a warning.
pub fn from_coefficients(path: &Path) -> Vec<Warning> {
    let unread = |why: String| {
        vec![Warning::new(
            "train_warnings_unread",
            format!("{}: {why}, so the warnings `train` recorded there are not included", path.display()),
        )]
    };
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Vec::new(),
        Err(e) => return unread(format!("cannot be read ({e})")),
    };
    let v: serde_json::Value = match serde_json::from_str(&text) {
        Ok(v) => v,
        Err(e) => return unread(format!("is not JSON ({e})")),
    };
    match v.get("warnings") {
        None | Some(serde_json::Value::Null) => Vec::new(),
        Some(w) => serde_json::from_value(w.clone())
            .unwrap_or_else(|e| unread(format!("has a `warnings` entry that is not a list of warnings ({e})"))),
    }
}

/// One list: `train`'s warnings first (what was known when the model was made), then the
/// evaluation's; a train warning with the same code and channel as one of the evaluation's is
/// dropped, the evaluation's being the one measured on the data at hand.
pub fn merge(train: Vec<Warning>, evaluation: Vec<Warning>) -> Vec<Warning> {
    let mut out: Vec<Warning> =
        train.into_iter().filter(|w| !evaluation.iter().any(|e| e.code == w.code && e.channel == w.channel)).collect();
    out.extend(evaluation);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn train_warnings_are_read_when_present_and_absent_ones_are_none() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.coefficients.json");
        assert!(from_coefficients(&p).is_empty());
        std::fs::write(&p, r#"{"format": "x"}"#).unwrap();
        assert!(from_coefficients(&p).is_empty());
        let w = Warning::new("model_h_worse_cv", "Model-H is worse on T").on_channel("T").with("cv_rmse_h_c", 0.3);
        std::fs::write(&p, serde_json::json!({"warnings": [w]}).to_string()).unwrap();
        assert_eq!(from_coefficients(&p), [w]);
        std::fs::write(&p, r#"{"warnings": [1, 2]}"#).unwrap();
        assert_eq!(from_coefficients(&p)[0].code, "train_warnings_unread");
        std::fs::write(&p, "{").unwrap();
        assert_eq!(from_coefficients(&p)[0].code, "train_warnings_unread");
    }

    #[test]
    fn merge_keeps_the_evaluations_copy_of_a_repeated_warning() {
        let a = Warning::new("static_gain_disagreement", "train's").on_channel("T");
        let b = Warning::new("outlier_rows_skipped", "3 rows");
        let c = Warning::new("static_gain_disagreement", "evaluate's").on_channel("T");
        let d = Warning::new("static_gain_disagreement", "evaluate's").on_channel("p");
        let m = merge(vec![a, b.clone()], vec![c.clone(), d.clone()]);
        assert_eq!(m, [b, c, d]);
    }
}
