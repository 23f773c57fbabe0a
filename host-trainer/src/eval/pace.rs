//! The pace study (DESIGN §4 static fidelity, §5): the calibration's installation run at other
//! paces and through a steps record, compensated by the models calibrated at its own pace.
//!
//! Cross-validation inside one calibration batch cannot see a model that is right only at the
//! batch's pace: every fold has the same pace. This study can. The same scenario and seed (the
//! same installation: dispersed gauge matrix, drift and noise realisations) is simulated with
//! every measurand trajectory ×¼ (four times slower), ×4 and ×8 faster — all measurands at
//! once, and each alone — and as a steps record (each measurand held at levels across its
//! range, each level approached from below and from above), a rest record (×0.02), a steps
//! record of day-long holds and a plateau record (every measurand resting 4–16 h at random
//! levels, [`crate::sim::plateaus`]). Each record's hold-out is scored
//! with both models; on the steps record the settled slope (mean reading over the settled half
//! of each hold against the held level) is the static gain, which must be 1.

use crate::data::{Dataset, Measurand};
use crate::error::TrainerError;
use crate::eval::score::evaluate_holdout;
use crate::fit::static_fidelity::{settled_slope, HeldLevel};
use crate::fit::HostParams;
use crate::sim::scenario::ScenarioConfig;
use crate::sim::{simulate, steps};

/// Pace factors of the study (speed multipliers: ¼ is four times slower).
pub const PACES: [f64; 3] = [0.25, 4.0, 8.0];

/// The rest record's pace: every measurand fifty times slower, a structure nearly at rest.
pub const REST_PACE: f64 = 0.02;

/// The long-hold record's hold per level \[s\]: a steps record whose levels are held a day.
pub const LONG_HOLD_S: f64 = 86_400.0;

pub use fbg_report::{PaceRow, PaceStudy};

/// Score both models on `d`'s hold-out.
fn score(
    label: String,
    factor: f64,
    only: Option<String>,
    p: &HostParams,
    h: &HostParams,
    d: &Dataset,
) -> Result<PaceRow, TrainerError> {
    let (ep, _) = evaluate_holdout(p, d)?;
    let (eh, _) = evaluate_holdout(h, d)?;
    Ok(PaceRow {
        label,
        factor,
        only,
        samples: d.holdout_indices().len(),
        rmse_p: ep.channels.iter().map(|c| c.rmse).collect(),
        rmse_h: eh.channels.iter().map(|c| c.rmse).collect(),
        coverage_p: ep.channels.iter().map(|c| c.coverage).collect(),
        coverage_h: eh.channels.iter().map(|c| c.coverage).collect(),
        slope_p: vec![],
        slope_h: vec![],
        holds: 0,
    })
}

/// The holds of a steps record as levels of the models' outputs (holds of a measurand the
/// models do not output are left out).
pub fn held_levels(d: &Dataset, outputs: &[Measurand]) -> Vec<HeldLevel> {
    steps::holds(d)
        .into_iter()
        .filter_map(|h| {
            let m = d.refs.get(h.measurand)?.measurand;
            let output = outputs.iter().position(|o| *o == m)?;
            Some(HeldLevel { output, level: h.level, rows: h.rows })
        })
        .collect()
}

/// Run the study for the installation `cfg` (its native pace) with `seed`, compensated by
/// `model_p` and `model_h` (calibrated on that installation at its own pace); the glitch study
/// runs on `native`, the record at the native pace the caller already holds.
pub fn pace_study(
    cfg: &ScenarioConfig,
    seed: u64,
    model_p: &HostParams,
    model_h: &HostParams,
    native: &Dataset,
) -> Result<PaceStudy, TrainerError> {
    let mut records: Vec<(String, f64, Option<Measurand>)> = Vec::new();
    for &f in &PACES {
        records.push((format!("×{f}"), f, None));
    }
    if cfg.measurands.len() > 1 {
        for &m in &cfg.measurands {
            for &f in &PACES {
                records.push((format!("×{f} ({})", m.column()), f, Some(m)));
            }
        }
    }
    let mut rows = crate::fit::par_map(&records, |(label, f, only)| {
        let sim = simulate(&cfg.paced(*f, *only), seed);
        score(label.clone(), *f, only.map(|m| m.column().to_string()), model_p, model_h, &sim.data)
    })
    .into_iter()
    .collect::<Result<Vec<_>, _>>()?;
    let mut long = cfg.steps();
    long.steps.hold_s = LONG_HOLD_S;
    long.name.push_str("-long-hold");
    for (label, c) in [("steps", cfg.steps()), ("long-hold", long)] {
        let st = simulate(&c, seed);
        let mut row = score(label.into(), 1.0, None, model_p, model_h, &st.data)?;
        let holds = held_levels(&st.data, &Measurand::of_dims(&model_h.dims));
        row.slope_p = settled_slope(model_p, &st.data, &holds)?.gain;
        row.slope_h = settled_slope(model_h, &st.data, &holds)?.gain;
        row.holds = holds.len();
        rows.push(row);
        if label == "steps" {
            let rest = simulate(&cfg.paced(REST_PACE, None), seed);
            rows.push(score("rest".into(), REST_PACE, None, model_p, model_h, &rest.data)?);
        }
    }
    let plateaus = simulate(&cfg.plateaus(), seed);
    rows.push(score("plateaus".into(), 1.0, None, model_p, model_h, &plateaus.data)?);
    let glitch = crate::eval::glitch::glitch_study(model_h, native)?;
    Ok(PaceStudy { scenario: cfg.name.clone(), seed, rows, glitch })
}
