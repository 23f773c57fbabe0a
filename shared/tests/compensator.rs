//! Host tests of the compensator's behaviour: flags, band widening, the latches, feature
//! sets, reloads, and f32/f64 agreement.

use crate::common;

use common::{bits, dl3, params, ramp, run, sample, stream, K};
use fbg_shared::layout::{pad, Z95};
use fbg_shared::{Compensator, FeatureSet, Flags, ModelParams, Sample};
use fbg_testkit::models::{encode_vec, long_provenance, model, short_provenance};
use fbg_testkit::Rng;
use proptest::prelude::*;

// ---------------------------------------------------------------------------------------------
// Non-finite input

#[test]
fn non_finite_input_is_flagged_and_leaves_the_latches() {
    for fs in FeatureSet::ALL {
        for n in [0, 3, K] {
            let mut c = Compensator::<f32, K>::new(&params(n, 7, fs)).unwrap();
            run(&mut c, &stream(7, 50));
            let mut dl_bad = Vec::new();
            for g in 0..3 {
                for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    let mut dl = [1.0, 2.0, 3.0];
                    dl[g] = v;
                    dl_bad.push(sample(dl, 20.0, 1.0));
                }
            }
            for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                dl_bad.push(sample([1.0, 2.0, 3.0], v, 1.0));
            }
            dl_bad.push(sample([f32::NAN; 3], f32::NAN, f32::NAN));
            for s in dl_bad {
                let before = c.clone();
                let latch = c.state().latch_values();
                let e = c.step(&s);
                assert_eq!(e.flags, Flags::NON_FINITE, "{fs:?} n={n} {s:?}");
                assert!(e.values().iter().all(|v| v.is_nan()));
                assert!(e.band().iter().all(|&b| b == f32::INFINITY));
                assert_eq!(c.state().latch_values(), latch);
                // The whole stream state (anchors too) is untouched: the next finite sample
                // gives exactly what it would have given without the bad one.
                let next = sample([4.0, -30.0, 12.0], 21.0, 2.0);
                let mut b = before;
                assert_eq!(bits(&c.clone().step(&next)), bits(&b.step(&next)));
            }
        }
    }
}

#[test]
fn time_is_screened_only_when_used() {
    let s_nan_t = sample([5.0, -5.0, 10.0], 22.0, f32::NAN);
    let s_inf_t = sample([5.0, -5.0, 10.0], 22.0, f32::INFINITY);
    for fs in FeatureSet::ALL {
        let p = params(K, 8, fs);
        let mut c = Compensator::<f32, K>::new(&p).unwrap();
        run(&mut c, &stream(8, 30));
        for s in [s_nan_t, s_inf_t] {
            let e = c.clone().step(&s);
            if fs.uses_time() {
                assert_eq!(e.flags, Flags::NON_FINITE, "{fs:?}");
            } else {
                // HysteresisAware ignores t altogether: same as any finite t.
                assert!(!e.flags.contains(Flags::NON_FINITE), "{fs:?}");
                let finite_t = sample(dl3(&s), s.t_amb_c, 123.0);
                assert_eq!(bits(&e), bits(&c.clone().step(&finite_t)));
                assert!(e.values().iter().all(|v| v.is_finite()));
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Envelope and support flags, band widening

#[test]
fn out_of_envelope_is_flagged_and_widens_the_band() {
    for fs in FeatureSet::ALL {
        for n in [0, K] {
            let mut wide = params(n, 9, fs);
            wide.hyper.weak_support = 0.0; // isolate the envelope flag
            wide.hyper.flagged_band_factor = 3.0;
            wide.envelope_lo = [-1e6; 9];
            wide.envelope_hi = [1e6; 9];
            let mut narrow = wide.clone();
            narrow.envelope_lo = pad(&[-10.0, -10.0, -10.0, 10.0]);
            narrow.envelope_hi = pad(&[10.0, 10.0, 10.0, 30.0]);
            let inside = sample([0.0, 0.0, 0.0], 20.0, 5.0);
            let mut outside = Vec::new();
            for i in 0..4 {
                for (v, bound) in [(-10.5f32, -10.0f32), (10.5, 10.0)] {
                    let mut s = inside;
                    if i < 3 {
                        s.dl_pm[i] = v;
                        outside.push((s, true));
                        s.dl_pm[i] = bound; // on the bound is inside
                        outside.push((s, false));
                    } else {
                        s.t_amb_c = v + 20.0;
                        outside.push((s, true));
                        s.t_amb_c = bound + 20.0;
                        outside.push((s, false));
                    }
                }
            }
            for (s, out) in outside {
                let a = Compensator::<f32, K>::new(&wide).unwrap().step(&s);
                let b = Compensator::<f32, K>::new(&narrow).unwrap().step(&s);
                assert_eq!(a.flags, Flags::OK, "{fs:?} n={n} {s:?}");
                assert_eq!(a.values.map(f32::to_bits), b.values.map(f32::to_bits));
                if out {
                    assert_eq!(b.flags, Flags::OUT_OF_ENVELOPE, "{fs:?} n={n} {s:?}");
                    for i in 0..3 {
                        assert_eq!(b.band95[i], a.band95[i] * 3.0);
                    }
                } else {
                    assert_eq!(bits(&a), bits(&b));
                }
            }
        }
    }
}

#[test]
fn far_sample_has_weak_support_and_a_wide_band() {
    for fs in FeatureSet::ALL {
        let mut p = params(K, 10, fs);
        p.envelope_lo = [-1e6; 9];
        p.envelope_hi = [1e6; 9];
        // No output envelope either (its estimates are far outside the random model's): this
        // is about support.
        p.field.band_max = [0.0; 4];
        let factor = p.hyper.flagged_band_factor;
        let far = sample([5000.0, -5000.0, 5000.0], 20.0, 0.0);
        let e = Compensator::<f32, K>::new(&p).unwrap().step(&far);
        assert_eq!(e.flags, Flags::WEAK_SUPPORT, "{fs:?}");
        // No support: leverage ≈ 0, so the band is the bare residual band times the factor.
        for i in 0..3 {
            let want = (Z95 * f64::from(p.resid_var[i]).sqrt()) as f32 * factor;
            assert!((e.band95[i] - want).abs() <= 1e-5 * want, "{} vs {want}", e.band95[i]);
        }
        // A sample on a centre is supported.
        let mut q = p.clone();
        let x = [10.0f32, -5.0, 3.0, 25.0, 100.0];
        let mu = &mut q.centres[0].mu;
        for (d, &xd) in x.iter().enumerate() {
            if fs.active()[d] {
                mu[d] = (xd - q.z_mean[d]) / q.z_std[d];
            }
        }
        for m in mu.iter_mut().skip(5) {
            *m = 0.0; // latches are 0 on the first sample
        }
        let e = Compensator::<f32, K>::new(&q).unwrap().step(&sample([x[0], x[1], x[2]], x[3], x[4]));
        assert_eq!(e.flags, Flags::OK, "{fs:?}");
    }
}

/// The step decides weak support from ‖ψ‖² where it can and from max ψ near the threshold; the
/// flag must equal `max_j ψ_j < weak_support` exactly, also at thresholds placed on (and one ulp
/// around) the maxima that occur.
#[test]
fn weak_support_flag_is_exactly_max_psi_below_the_threshold() {
    for fs in FeatureSet::ALL {
        for seed in 20..24 {
            let p = params(K, seed, fs);
            let ss = stream(seed, 200);
            let mut maxima = Vec::new();
            let mut c = Compensator::<f32, K>::new(&p).unwrap();
            for s in &ss {
                let mut m = 0.0f32;
                c.step_with(s, |_, psi| m = m.max(psi));
                maxima.push(m);
            }
            let mut sorted = maxima.clone();
            sorted.sort_by(f32::total_cmp);
            let mut thresholds = Vec::new();
            for q in [0, 10, 50, 100, 150, 199] {
                let m = sorted[q];
                thresholds.extend([m, f32::from_bits(m.to_bits() + 1), f32::from_bits(m.to_bits().saturating_sub(1))]);
            }
            for w in thresholds.into_iter().filter(|w| (0.0..=1.0).contains(w)) {
                let mut q = p.clone();
                q.hyper.weak_support = w;
                let mut c = Compensator::<f32, K>::new(&q).unwrap();
                for (s, &m) in ss.iter().zip(&maxima) {
                    let e = c.step(s);
                    assert_eq!(
                        e.flags.contains(Flags::WEAK_SUPPORT),
                        m < w,
                        "{fs:?} seed {seed}: max ψ {m}, threshold {w}"
                    );
                }
            }
        }
    }
}

#[test]
fn pure_polynomial_never_has_weak_support() {
    for fs in FeatureSet::ALL {
        let mut p = params(0, 11, fs);
        p.hyper.weak_support = 1.0;
        let mut c = Compensator::<f32, K>::new(&p).unwrap();
        assert_eq!(c.n_centres(), 0);
        let mut r = Rng(11);
        for _ in 0..2000 {
            let s =
                sample([r.f32(-1e4, 1e4), r.f32(-1e4, 1e4), r.f32(-1e4, 1e4)], r.f32(-100.0, 100.0), r.f32(0.0, 1e6));
            let e = c.step(&s);
            assert!(!e.flags.contains(Flags::WEAK_SUPPORT));
        }
        // In-envelope samples are plain OK, and the band is the bare residual band.
        for s in stream(11, 200) {
            let e = c.step(&s);
            assert_eq!(e.flags, Flags::OK);
            for i in 0..3 {
                let want = (Z95 * f64::from(p.resid_var[i]).sqrt()) as f32;
                assert!((e.band95[i] - want).abs() <= 1e-6 * want);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Precision, stream state, feature sets

#[test]
fn f32_and_f64_agree() {
    let mut worst = 0.0f64;
    for fs in FeatureSet::ALL {
        for seed in 0..6 {
            let p: ModelParams<f32, 32> = model(if seed == 0 { 0 } else { 32 }, seed, fs, long_provenance());
            let mut a = Compensator::<f32, 32>::new(&p).unwrap();
            let mut b = Compensator::<f64, 32>::new(&p).unwrap();
            for s in stream(seed + 100, 500) {
                let s64 = s.cast::<f64>();
                let (x, y) = (a.step(&s), b.step(&s64));
                assert_eq!(x.flags, y.flags);
                assert_eq!(a.state().latch_values().map(f64::from), b.state().latch_values());
                for i in 0..3 {
                    // Relative to the output's scale (outputs are O(1..100) here).
                    let scale = 1.0 + y.values[i].abs();
                    let dv = (f64::from(x.values[i]) - y.values[i]).abs() / scale;
                    let db = (f64::from(x.band95[i]) - y.band95[i]).abs() / y.band95[i];
                    worst = worst.max(dv);
                    assert!(dv < 1e-4, "{fs:?} seed {seed}: {} vs {}", x.values[i], y.values[i]);
                    assert!(db < 1e-4, "{fs:?} seed {seed}: band {} vs {}", x.band95[i], y.band95[i]);
                }
            }
        }
    }
    eprintln!("worst relative f32/f64 difference: {worst:.2e}");
}

#[test]
fn reset_forgets_the_latches() {
    let p = params(K, 12, FeatureSet::HysteresisAware);
    let fresh = Compensator::<f32, K>::new(&p).unwrap();
    let mut c = fresh.clone();
    assert_eq!(c.state().latch_values()[..3], [0.0; 3]);
    run(&mut c, &ramp(true, 10));
    assert_eq!(c.state().latch_values()[..3], [1.0; 3]);
    run(&mut c, &ramp(false, 10));
    assert_eq!(c.state().latch_values()[..3], [-1.0; 3]);
    c.reset();
    assert_eq!(c.state().latch_values()[..3], [0.0; 3]);
    // After reset the compensator behaves exactly like a fresh one.
    let mut f = fresh.clone();
    for s in stream(12, 100) {
        assert_eq!(bits(&c.step(&s)), bits(&f.step(&s)));
    }
}

#[test]
fn paper_ignores_latches_and_uses_time() {
    let p = params(K, 13, FeatureSet::Paper);
    let fresh = Compensator::<f32, K>::new(&p).unwrap();
    let (mut up, mut down) = (fresh.clone(), fresh.clone());
    run(&mut up, &ramp(true, 10));
    run(&mut down, &ramp(false, 10));
    assert_eq!(up.state().latch_values()[..3], [1.0; 3]);
    assert_eq!(down.state().latch_values()[..3], [-1.0; 3]);
    let s = sample([3.0, -4.0, 5.0], 18.0, 250.0);
    assert_eq!(bits(&up.step(&s)), bits(&down.step(&s)), "latches must not matter");
    // Time does.
    let later = sample(dl3(&s), s.t_amb_c, 900.0);
    let (x, y) = (fresh.clone().step(&s), fresh.clone().step(&later));
    assert_ne!(x.values, y.values, "time must matter");
}

#[test]
fn hysteresis_aware_uses_latches_and_ignores_time() {
    for fs in [FeatureSet::HysteresisAware, FeatureSet::HysteresisAwareTime] {
        let p = params(K, 14, fs);
        let fresh = Compensator::<f32, K>::new(&p).unwrap();
        let (mut up, mut down) = (fresh.clone(), fresh.clone());
        run(&mut up, &ramp(true, 10));
        run(&mut down, &ramp(false, 10));
        // A sample inside the dead band of both anchors' retreat keeps each latch.
        let s = sample([40.0, 40.0, 40.0], 18.0, 250.0);
        let (a, b) = (up.clone().step(&s), down.clone().step(&s));
        assert_ne!(a.values, b.values, "{fs:?}: latches must matter");
        let later = sample(dl3(&s), s.t_amb_c, 900.0);
        let (x, y) = (up.clone().step(&s), up.clone().step(&later));
        if fs.uses_time() {
            assert_ne!(x.values, y.values);
        } else {
            assert_eq!(bits(&x), bits(&y), "time must not matter");
            let nan_t = sample(dl3(&s), s.t_amb_c, f32::NAN);
            assert_eq!(bits(&up.clone().step(&nan_t)), bits(&x), "a NaN t is ignored");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Any finite sample: no panic, and a non-finite estimate is always flagged.
    #[test]
    fn finite_samples_give_flagged_or_finite_estimates(
        seed in any::<u64>(),
        n in 0..=K,
        fs in 0usize..3,
        raw in prop::collection::vec((prop::num::f32::NORMAL | prop::num::f32::ZERO, -60.0f32..60.0, 0u8..2), 5),
    ) {
        let p = params(n, seed, FeatureSet::ALL[fs]);
        let mut c = Compensator::<f32, K>::new(&p).unwrap();
        run(&mut c, &stream(seed, 20));
        // Each input either arbitrary finite or inside the calibration range.
        let v: Vec<f32> = raw.iter().map(|&(any, tame, pick)| if pick == 0 { any } else { tame }).collect();
        let s = sample([v[0], v[1], v[2]], v[3] / 2.0 + 20.0, v[4].abs());
        let e = c.step(&s);
        // Finite inputs raise NON_FINITE only when the result overflowed, and then say so.
        if e.flags.contains(Flags::NON_FINITE) {
            prop_assert!(e.values().iter().all(|v| v.is_nan()) && e.band().iter().all(|b| b.is_infinite()));
        }
        if e.values().iter().chain(e.band().iter()).any(|x| !x.is_finite()) {
            prop_assert!(!e.flags.is_ok(), "{:?} -> {:?}", s, e);
        }
        prop_assert!(e.band().iter().all(|&b| b >= 0.0));
    }
}

#[test]
fn a_model_whose_folded_coefficients_overflow_is_refused() {
    let mut p = model::<4>(4, 9, FeatureSet::HysteresisAware, short_provenance());
    p.guess_std = [1e-39, 1.0, 1.0, 0.0]; // subnormal: 1/σ overflows f32
    assert!(p.validate().is_ok(), "every stored number is finite");
    let e = Compensator::<f32, 4>::new(&p).unwrap_err();
    assert!(matches!(e, fbg_shared::Error::BadParameter { .. }), "{e:?}");
}

#[test]
fn an_overflowing_result_is_flagged_non_finite() {
    let mut p = model::<4>(4, 9, FeatureSet::HysteresisAware, short_provenance());
    // The largest coefficient a blob may carry (3e38 is refused), on the T² term of the
    // strain output, and shifts no grating can give: T² overflows f32.
    p.poly[1][4] = fbg_shared::model::bounds::COEF_MAX as f32;
    let mut c = Compensator::<f32, 4>::new(&p).unwrap();
    let e = c.step(&Sample::new([3e18, 3e18, 3e18], 20.0, 0.0));
    assert!(e.flags.contains(Flags::NON_FINITE), "{:?}", e.flags);
    assert!(e.values().iter().all(|v| v.is_nan()) && e.band().iter().all(|b| b.is_infinite()));
}

#[test]
fn an_unfitted_output_reads_nan_with_an_infinite_band_and_no_flag() {
    let mut p = model::<4>(4, 9, FeatureSet::HysteresisAware, short_provenance());
    p.fitted = [true, false, true, false];
    let mut c = Compensator::<f32, 4>::new(&p).unwrap();
    let e = c.step(&Sample::new([1.0, 2.0, 3.0], 20.0, 0.0));
    assert!(e.values[1].is_nan() && e.band95[1].is_infinite());
    assert!(e.values[0].is_finite() && e.values[2].is_finite());
    assert!(!e.flags.contains(Flags::NON_FINITE), "{:?}", e.flags);
    p.fitted = [false; 4];
    assert_eq!(p.validate(), Err(fbg_shared::Error::BadParameter { field: "fitted" }));
}

#[test]
fn a_refused_reload_keeps_the_old_model_and_its_stream_state() {
    let good = model::<4>(4, 9, FeatureSet::HysteresisAware, short_provenance());
    let mut c = Compensator::<f32, 4>::new(&good).unwrap();
    let mut twin = c.clone();
    for k in 0..30 {
        let s = Sample::new([k as f32, -(k as f32), 0.5 * k as f32], 20.0, k as f32);
        c.step(&s);
        twin.step(&s);
    }
    let mut bad = good.clone();
    bad.guess_std = [1e-39, 1.0, 1.0, 0.0]; // valid numbers, overflowing fold
    assert!(c.reload(&bad).is_err());
    let mut worse = good.clone();
    worse.hyper.sigma = -1.0;
    assert!(c.reload(&worse).is_err());
    // Same answers as a twin that never saw the refused updates.
    for k in 0..20 {
        let s = Sample::new([3.0 * k as f32, 1.0, -2.0], 21.0, 100.0 + k as f32);
        assert_eq!(bits(&c.step(&s)), bits(&twin.step(&s)), "sample {k}");
    }
    // A good reload takes effect and restarts the stream state.
    let other = model::<4>(3, 10, FeatureSet::HysteresisAware, short_provenance());
    c.reload(&other).unwrap();
    assert_eq!(c.n_centres(), 3);
    assert_eq!(c.state().latch_values()[..3], [0.0f32; 3]);
}

#[test]
fn decode_into_matches_decode() {
    let p = model::<8>(8, 4, FeatureSet::HysteresisAwareTime, long_provenance());
    let bytes = encode_vec(&p).unwrap();
    let mut slot = ModelParams::<f32, 8>::default();
    fbg_shared::blob::decode_into(&bytes, &mut slot).unwrap();
    assert_eq!(slot, p);
    assert_eq!(fbg_shared::blob::decode::<8>(&bytes).unwrap(), p);
    // A refused blob reports the error; the slot is then not to be used, but the caller's
    // live model was never touched.
    let mut cut = bytes.clone();
    cut.truncate(bytes.len() - 9);
    assert!(fbg_shared::blob::decode_into(&cut, &mut slot).is_err());
}
