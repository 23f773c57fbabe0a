//! Across crates: train on the `paper` preset, export the blob, decode it as
//! the device does (capacity K = 32, f32), stream the whole record through `step`, and compare
//! with the trainer's f64 predictions on the same (f32) inputs: max difference ≤ 1 % of
//! Model-H's hold-out RMSE per channel, identical flags.

use fbg_shared::{blob, Compensator, Sample};
use fbg_trainer::data::Split;
use fbg_trainer::eval::score::evaluate_holdout;
use fbg_trainer::export::blob_bytes;
use fbg_trainer::fit::{train, HostCompensator, Origin, TrainOptions};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;

/// The device's centre capacity (firmware default).
const DEVICE_K: usize = 32;

#[test]
fn device_f32_path_matches_trainer_f64_within_one_percent_of_rmse() {
    let s = simulate(&Preset::Paper.config(), 7);
    let t = train(&s.data, &TrainOptions::default(), &Origin { scenario: "paper".into(), seed: 7 }).unwrap();
    let (eh, _) = evaluate_holdout(&t.model_h, &s.data).unwrap();

    let bytes = blob_bytes(&t.model_h).unwrap();
    assert!(bytes.len() <= 4096, "blob is {} bytes (target ≤ 4 KiB)", bytes.len());
    let params = blob::decode::<DEVICE_K>(&bytes).expect("the device accepts the exported blob");
    let mut device = Compensator::<f32, DEVICE_K>::new(&params).unwrap();
    let mut host = HostCompensator::new(&t.model_h).unwrap();

    let mut max_diff = [0.0f64; 3];
    let mut flags_differ = 0;
    let mut flagged = 0;
    let mut n = 0;
    for i in 0..s.data.len() {
        let x: Sample<f32> = s.data.sample(i).cast();
        let a = device.step(&x);
        let b = host.step(&x.cast());
        if s.data.split[i] != Split::Holdout {
            continue;
        }
        n += 1;
        if a.flags != b.flags {
            flags_differ += 1;
        }
        if !b.flags.is_ok() {
            flagged += 1;
        }
        for (c, worst) in max_diff.iter_mut().enumerate() {
            *worst = worst.max((f64::from(a.values[c]) - b.values[c]).abs());
            let rel = (f64::from(a.band95[c]) - b.band95[c]).abs() / b.band95[c];
            assert!(rel < 1e-3, "sample {i} channel {c}: band {} vs {}", a.band95[c], b.band95[c]);
        }
    }
    assert_eq!(n, 10_080);
    assert_eq!(flags_differ, 0, "flags must be identical ({flagged} flagged samples)");
    for (c, worst) in max_diff.iter().enumerate() {
        let limit = 0.01 * eh.channels[c].rmse;
        assert!(*worst <= limit, "channel {c}: max |f32 − f64| = {worst} > 1 % of RMSE ({limit})");
    }
}

#[test]
fn a_model_with_more_centres_than_the_device_holds_is_refused_by_name() {
    let mut c = Preset::Paper.config();
    c.clock.days = 3.0;
    let s = simulate(&c, 1);
    let cfg = fbg_trainer::fit::Config {
        feature_set: fbg_shared::FeatureSet::HysteresisAware,
        dead_band_pm: 4.0,
        k: 48,
        sigma_mult: 2.0,
        alpha_rel: 1e-4,
        cross_terms: true,
    };
    let t = train(&s.data, &TrainOptions::fixed(&cfg), &Origin::default()).unwrap();
    let bytes = blob_bytes(&t.model_h).unwrap();
    assert_eq!(
        blob::decode::<DEVICE_K>(&bytes).unwrap_err(),
        fbg_shared::Error::WrongDims { field: "centres", found: 48, expected: DEVICE_K as u16 }
    );
}
