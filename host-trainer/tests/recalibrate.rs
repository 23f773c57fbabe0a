//! Field recalibration: on a changed installation a short batch recovers most of a
//! full recalibration's gain for strain, and a batch with no evidence of change leaves the model
//! alone.

use fbg_trainer::eval::score::evaluate_holdout;
use fbg_trainer::eval::studies::recalibration;
use fbg_trainer::fit::recalibrate::{first_hours, recalibrate, CoreUpdate};
use fbg_trainer::fit::{train, Config, Origin, TrainOptions};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;

fn cfg() -> Config {
    Config {
        feature_set: fbg_shared::FeatureSet::HysteresisAware,
        dead_band_pm: 4.0,
        k: 32,
        sigma_mult: 2.0,
        alpha_rel: 1e-5,
        cross_terms: true,
    }
}

#[test]
fn a_day_of_data_recovers_most_of_a_full_recalibration_for_strain() {
    let scen = Preset::Paper.config();
    let old = train(&simulate(&scen, 7).data, &TrainOptions::fixed(&cfg()), &Origin::default()).unwrap();
    let r = recalibration(&scen, &old.model_h, &old.model_p, 7, 8, 24.0, &cfg()).unwrap();
    // The changed installation hurts the old model's strain (new dispersion and drift) ...
    assert!(r.h_old[1] > 1.5 * r.h_full[1], "{:?} vs {:?}", r.h_old, r.h_full);
    // ... and 24 h of new data recover most of what a full recalibration would.
    assert!(r.recovered_fraction_h[1] > 0.8, "{:?}", r.recovered_fraction_h);
    assert!(r.h_short[1] < r.h_old[1]);
}

#[test]
fn recalibrating_on_the_same_installation_changes_little() {
    let s = simulate(&Preset::Paper.config(), 7);
    let old = train(&s.data, &TrainOptions::fixed(&cfg()), &Origin::default()).unwrap();
    let batch = first_hours(&s.data, 24.0);
    let (new, what) = recalibrate(&old.model_h, &s.data, &batch).unwrap();
    let (before, _) = evaluate_holdout(&old.model_h, &s.data).unwrap();
    let (after, _) = evaluate_holdout(&new, &s.data).unwrap();
    for c in 0..3 {
        assert!(
            after.channels[c].rmse < 1.15 * before.channels[c].rmse,
            "channel {c}: {} -> {}",
            before.channels[c].rmse,
            after.channels[c].rmse
        );
        let (_, gain) = what.offset_gain[c];
        assert!((gain - 1.0).abs() < 0.1, "channel {c}: gain {gain}");
    }
    // The band never narrows.
    for c in 0..3 {
        assert!(new.resid_var[c] >= old.model_h.resid_var[c]);
    }
    assert_eq!(what.n_batch, batch.len());
    let _ = CoreUpdate::Keep;
}

#[test]
fn a_tiny_batch_is_refused() {
    let s = simulate(&Preset::Paper.config(), 7);
    let old = train(&s.data, &TrainOptions::fixed(&cfg()), &Origin::default()).unwrap();
    let e = recalibrate(&old.model_h, &s.data, &[0, 1, 2, 3, 4]).unwrap_err().to_string();
    assert!(e.contains("at least 20"), "{e}");
}
