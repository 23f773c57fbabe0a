//! Static fidelity. The models' settled readings have slope 1 against the truth on a
//! steps record for every output shape, and the pace study runs on a short record.

use crate::common;

use fbg_trainer::eval::pace::{held_levels, pace_study, PACES};
use fbg_trainer::fit::static_fidelity::settled_slope;
use fbg_trainer::fit::{train, Origin};
use fbg_trainer::sim::scenario::{Preset, ScenarioConfig};
use fbg_trainer::sim::simulate;

/// `preset` over `days` (the first half calibrates), with a steps record of 6-hour visits.
fn short(preset: Preset, days: f64) -> ScenarioConfig {
    let mut c = preset.config();
    c.clock.days = days;
    c.steps.hold_s = 6.0 * 3600.0;
    c
}

/// Settled slopes (Model-P, Model-H) on the steps record of `cfg` with `seed`.
fn slopes(cfg: &ScenarioConfig, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let s = simulate(cfg, seed);
    let t = train(&s.data, &common::small_grid(), &Origin::default()).unwrap();
    let st = simulate(&cfg.steps(), seed);
    let outputs = fbg_trainer::data::Measurand::of_dims(&t.model_h.dims);
    let holds = held_levels(&st.data, &outputs);
    assert_eq!(holds.len(), 10 * outputs.len(), "5 levels × 2 approaches per output");
    let p = settled_slope(&t.model_p, &st.data, &holds).unwrap().gain;
    let h = settled_slope(&t.model_h, &st.data, &holds).unwrap().gain;
    eprintln!("{} seed {seed}: P {p:?} H {h:?}", cfg.name);
    (p, h)
}

/// Largest |slope − 1| accepted after a 3-day calibration. A calibration that short sees three
/// diurnal cycles and three days of drift, so its static gain is itself uncertain by a few per
/// cent (measured on seeds 3 and 11, where the tolerance was chosen, and checked on seed 19:
/// within 3.1 %); the 1 % target is for the 7-day calibration and is `cargo xtask bench`'s. A
/// memory term carrying the measurand, as the joint fit's did (settled gain about 0.35 on the
/// paper's pressure), fails by far.
const SHORT_CAL_SLOPE_TOLERANCE: f64 = 0.05;

#[test]
fn settled_slope_is_one_for_every_output_shape() {
    for preset in [Preset::Temperature1, Preset::StrainPair, Preset::Paper, Preset::Array8] {
        for seed in [3, 11, 19] {
            let (p, h) = slopes(&short(preset, 6.0), seed);
            assert_eq!(p.len(), preset.config().measurands.len());
            for (c, (&sp, &sh)) in p.iter().zip(&h).enumerate() {
                let name = preset.name();
                assert!(
                    (sp - 1.0).abs() < SHORT_CAL_SLOPE_TOLERANCE,
                    "{name} seed {seed} output {c}: Model-P slope {sp}"
                );
                assert!(
                    (sh - 1.0).abs() < SHORT_CAL_SLOPE_TOLERANCE,
                    "{name} seed {seed} output {c}: Model-H slope {sh}"
                );
            }
        }
    }
}

#[test]
fn pace_study_on_a_short_record() {
    let cfg = short(Preset::Paper, 6.0);
    let s = simulate(&cfg, 5);
    let t = train(&s.data, &common::small_grid(), &Origin::default()).unwrap();
    let study = pace_study(&cfg, 5, &t.model_p, &t.model_h, &s.data).unwrap();
    // All measurands at each pace, each measurand alone at each pace, then the steps, rest
    // and long-hold records, the plateau record; a glitch of each kind in each input.
    assert_eq!(study.rows.len(), PACES.len() * (1 + 3) + 4);
    assert_eq!(study.rows.last().map(|r| r.label.as_str()), Some("plateaus"));
    assert_eq!(study.glitch.len(), 4 * 4);
    let steps = study.steps().unwrap();
    assert_eq!(steps.label, "steps");
    assert_eq!(steps.holds, 30);
    for r in &study.rows {
        eprintln!(
            "{}: P {:?} H {:?} cov {:?} slopes {:?} {:?}",
            r.label, r.rmse_p, r.rmse_h, r.coverage_h, r.slope_p, r.slope_h
        );
        assert!(r.samples > 0 && r.rmse_p.iter().chain(&r.rmse_h).all(|v| v.is_finite() && *v > 0.0), "{r:?}");
    }
}
