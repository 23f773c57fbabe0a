//! Host tests of the compensator's behaviour: flags, band widening, stream state, feature
//! sets, and f32/f64 agreement.

// A test crate: clippy.toml allows the panicking shorthand in #[test] functions, not in
// the helpers around them.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use fbg_shared::layout::{pad, Z95};
use fbg_shared::{Compensator, Estimate, FeatureSet, Flags, ModelParams, Sample};
use fbg_testkit::models::{encode_vec, long_provenance, model, short_provenance};
use fbg_testkit::Rng;
use proptest::prelude::*;

const K: usize = 8;

fn sample(dl: [f32; 3], t_amb_c: f32, t_s: f32) -> Sample<f32> {
    Sample::new(dl, t_amb_c, t_s)
}

/// The first three shifts of a paper sample.
fn dl3<F: Copy>(s: &Sample<F>) -> [F; 3] {
    [s.dl_pm[0], s.dl_pm[1], s.dl_pm[2]]
}

/// A random walk inside the calibration range (±50 pm, 0..40 °C), t = 0, 1, 2, ... s.
fn stream(seed: u64, n: usize) -> Vec<Sample<f32>> {
    let mut r = Rng(seed);
    let mut dl = [0.0f64; 3];
    (0..n)
        .map(|k| {
            for d in dl.iter_mut() {
                *d = (*d + r.uniform(-6.0, 6.0)).clamp(-50.0, 50.0);
            }
            sample([dl[0] as f32, dl[1] as f32, dl[2] as f32], r.f32(0.0, 40.0), k as f32)
        })
        .collect()
}

/// Rising (or falling) by 10 pm per sample on every grating: latches end at ±1.
fn ramp(up: bool, n: usize) -> Vec<Sample<f32>> {
    let s = if up { 10.0 } else { -10.0 };
    (0..n).map(|k| sample([s * k as f32 - 20.0 * s.signum(); 3], 20.0, k as f32)).collect()
}

fn bits(e: &Estimate<f32>) -> ([u32; 4], [u32; 4], Flags) {
    (e.values.map(f32::to_bits), e.band95.map(f32::to_bits), e.flags)
}

fn run(c: &mut Compensator<f32, K>, ss: &[Sample<f32>]) {
    for s in ss {
        c.step(s);
    }
}

fn params(n: usize, seed: u64, fs: FeatureSet) -> ModelParams<f32, K> {
    model(n, seed, fs, short_provenance())
}

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
                let latch = c.latch_values();
                let e = c.step(&s);
                assert_eq!(e.flags, Flags::NON_FINITE, "{fs:?} n={n} {s:?}");
                assert!(e.values().iter().all(|v| v.is_nan()));
                assert!(e.band().iter().all(|&b| b == f32::INFINITY));
                assert_eq!(c.latch_values(), latch);
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
                assert_eq!(a.latch_values().map(f64::from), b.latch_values());
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
    assert_eq!(c.latch_values()[..3], [0.0; 3]);
    run(&mut c, &ramp(true, 10));
    assert_eq!(c.latch_values()[..3], [1.0; 3]);
    run(&mut c, &ramp(false, 10));
    assert_eq!(c.latch_values()[..3], [-1.0; 3]);
    c.reset();
    assert_eq!(c.latch_values()[..3], [0.0; 3]);
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
    assert_eq!(up.latch_values()[..3], [1.0; 3]);
    assert_eq!(down.latch_values()[..3], [-1.0; 3]);
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
    assert_eq!(c.latch_values()[..3], [0.0f32; 3]);
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

// ---------------------------------------------------------------------------------------------
// The trainer's entry points: core and activations, stream checkpoints

#[test]
fn core_and_activations_are_what_step_computes() {
    for fs in FeatureSet::ALL {
        let mut p = params(K, 21, fs);
        // With zero residual weights a step's values are the polynomial core's.
        for c in p.centres.iter_mut() {
            c.w = [0.0; 4];
        }
        let mut a = Compensator::<f32, K>::new(&p).unwrap();
        let mut b = a.clone();
        let mut ss = stream(21, 300);
        ss[40].dl_pm[1] = f32::NAN;
        for s in &ss {
            let mut psi_step = [0.0f32; K];
            let e = a.step_with(s, |j, v| psi_step[j] = v);
            let mut psi = [-1.0f32; K];
            match b.core_and_activations(s, &mut psi) {
                Some(v) => {
                    assert_eq!(v.map(f32::to_bits), e.values.map(f32::to_bits), "{fs:?}");
                    assert_eq!(psi.map(f32::to_bits), psi_step.map(f32::to_bits), "{fs:?}");
                }
                None => {
                    assert!(e.flags.contains(Flags::NON_FINITE));
                    assert_eq!(psi, [-1.0; K], "psi untouched");
                }
            }
            assert_eq!(a.latch_values(), b.latch_values());
        }
    }
}

#[test]
fn a_stream_resumed_from_its_state_answers_as_the_whole_stream() {
    let p = params(K, 22, FeatureSet::HysteresisAware);
    let ss = stream(22, 400);
    let mut whole = Compensator::<f32, K>::new(&p).unwrap();
    let mut state = None;
    let mut expected = Vec::new();
    for (i, s) in ss.iter().enumerate() {
        if i == 250 {
            state = Some(whole.stream_state());
        }
        expected.push(bits(&whole.step(s)));
    }
    // Another compensator of the same model resumes at sample 250.
    let mut resumed = Compensator::<f32, K>::new(&p).unwrap();
    assert!(resumed.same_stream(&whole));
    resumed.set_stream_state(state.unwrap());
    for (s, want) in ss[250..].iter().zip(&expected[250..]) {
        assert_eq!(&bits(&resumed.step(s)), want);
    }
    // A model with another dead band moves its latches differently.
    let mut q = p.clone();
    q.hyper.dead_band_pm *= 2.0;
    assert!(!Compensator::<f32, K>::new(&q).unwrap().same_stream(&whole));
}

// ---------------------------------------------------------------------------------------------
// Memory terms: ŷ = Bφ + Γm + Wψ

use fbg_shared::layout::paper::N_MEMORY;
use fbg_shared::layout::{Dims, MAX_MEMORY};
use fbg_shared::{Error, MemoryBank, MemorySpec};
use fbg_testkit::models::{full_memory_spec, memory_model, some_memory_spec};

fn memory_params(n: usize, seed: u64, fs: FeatureSet) -> ModelParams<f32, K> {
    memory_model(n, seed, fs, short_provenance(), some_memory_spec())
}

fn to64(s: &Sample<f32>) -> Sample<f64> {
    s.cast::<f64>()
}

/// [`stream`] on an irregular clock: Δt from {1, 2, 5, 30} s, with a repeated time stamp and a
/// 1000-s gap now and then.
fn irregular(seed: u64, n: usize) -> Vec<Sample<f32>> {
    let mut r = Rng(seed ^ 0xC10C);
    let mut t = 0.0f32;
    let mut ss = stream(seed, n);
    for (k, s) in ss.iter_mut().enumerate() {
        t += match k % 97 {
            40 => 0.0,
            80 => 1000.0,
            _ => [1.0, 2.0, 5.0, 30.0][(r.next_u64() % 4) as usize],
        };
        s.t_s = t;
    }
    ss
}

#[test]
fn step_adds_gamma_times_the_memory_vector() {
    let mut largest = 0.0f64;
    for fs in FeatureSet::ALL {
        for (n, seed) in [(0, 31), (K, 32)] {
            let p = memory_params(n, seed, fs);
            let mut no_gamma = p.clone();
            no_gamma.gamma = [[0.0; MAX_MEMORY]; 4];
            let mut with = Compensator::<f64, K>::new(&p).unwrap();
            let mut without = Compensator::<f64, K>::new(&no_gamma).unwrap();
            assert!(with.has_memory() && without.has_memory());
            let mut bank = MemoryBank::<f64>::new(&p.memory, &Dims::PAPER);
            for s in irregular(seed, 600).iter().map(to64) {
                let (y, y0) = (with.step(&s), without.step(&s));
                let m = bank.update(&s.dl_pm, s.t_amb_c, s.t_s);
                assert_eq!(y.flags, y0.flags);
                for i in 0..3 {
                    let gm: f64 = (0..N_MEMORY).map(|k| f64::from(p.gamma[i][k]) * m[k]).sum();
                    largest = largest.max(gm.abs());
                    let want = y0.values[i] + gm;
                    assert!(
                        (y.values[i] - want).abs() <= 1e-12 * (1.0 + want.abs()),
                        "{fs:?} n={n} t={} output {i}: {} vs {want}",
                        s.t_s,
                        y.values[i]
                    );
                    // The band does not depend on the memory terms.
                    assert_eq!(y.band95[i], y0.band95[i]);
                }
            }
        }
    }
    // The memory terms did move the outputs.
    assert!(largest > 1.0, "largest |Γm| {largest}");
}

#[test]
fn core_and_activations_include_the_memory_terms() {
    for fs in FeatureSet::ALL {
        let mut p = memory_params(K, 33, fs);
        for c in p.centres.iter_mut() {
            c.w = [0.0; 4];
        }
        let mut a = Compensator::<f32, K>::new(&p).unwrap();
        let mut b = a.clone();
        let mut ss = irregular(33, 300);
        ss[50].t_s = f32::NAN;
        for s in &ss {
            let mut psi = [0.0f32; K];
            let e = a.step(s);
            match b.core_and_activations(s, &mut psi) {
                Some(v) => assert_eq!(v.map(f32::to_bits), e.values.map(f32::to_bits), "{fs:?}"),
                None => assert!(e.flags.contains(Flags::NON_FINITE)),
            }
            assert_eq!(a.stream_state(), b.stream_state());
        }
    }
}

/// `activations` given the latches after a sample is `core_and_activations`' ψ bit for bit,
/// for the paper's shape (the step's specialised path) and every feature set, and leaves the
/// stream alone.
fn activations_from_latches<F: fbg_shared::Real>() {
    for fs in FeatureSet::ALL {
        let p = memory_params(K, 37, fs);
        let mut live = Compensator::<F, K>::new(&p).unwrap();
        let side = live.clone();
        let mut ss: Vec<Sample<F>> = irregular(37, 300).iter().map(|s| s.cast::<F>()).collect();
        ss[40].t_s = F::from_f64(f64::NAN);
        ss[41].dl_pm[1] = F::from_f64(f64::INFINITY);
        for s in &ss {
            let (mut want, mut got) = ([F::ZERO; K], [F::ZERO; K]);
            let accepted = live.core_and_activations(s, &mut want).is_some();
            let before = side.stream_state();
            assert_eq!(side.activations(s, &live.latch_values(), &mut got), accepted, "{fs:?}");
            assert_eq!(side.stream_state(), before);
            if accepted {
                assert_eq!(got.map(|v| v.to_f64().to_bits()), want.map(|v| v.to_f64().to_bits()), "{fs:?}");
            }
        }
    }
}

#[test]
fn activations_from_the_latches_are_core_and_activations_psi() {
    activations_from_latches::<f32>();
    activations_from_latches::<f64>();
}

#[test]
fn advance_moves_the_memory_as_step_does() {
    let p = memory_params(K, 34, FeatureSet::HysteresisAware);
    let mut a = Compensator::<f32, K>::new(&p).unwrap();
    let mut b = a.clone();
    let ss = irregular(34, 400);
    for s in &ss[..300] {
        a.step(s);
        b.advance(s);
        assert_eq!(a.stream_state(), b.stream_state());
    }
    for s in &ss[300..] {
        assert_eq!(bits(&a.step(s)), bits(&b.step(s)));
    }
}

fn memory_resume<F: fbg_shared::Real>() {
    for fs in FeatureSet::ALL {
        let p = memory_model::<K>(K, 35, fs, short_provenance(), full_memory_spec());
        let ss: Vec<Sample<F>> = irregular(35, 1000).iter().map(|s| s.cast::<F>()).collect();
        let key =
            |e: &Estimate<F>| (e.values.map(|v| v.to_f64().to_bits()), e.band95.map(|v| v.to_f64().to_bits()), e.flags);
        let mut whole = Compensator::<F, K>::new(&p).unwrap();
        let mut state = None;
        let mut expected = Vec::new();
        for (i, s) in ss.iter().enumerate() {
            if i == 500 {
                state = Some(whole.stream_state());
            }
            expected.push(key(&whole.step(s)));
        }
        // A fresh compensator, and one that has compensated another stream: both resume.
        let mut used = Compensator::<F, K>::new(&p).unwrap();
        for s in ss.iter().rev().take(50) {
            used.step(s);
        }
        for mut resumed in [Compensator::<F, K>::new(&p).unwrap(), used] {
            assert!(resumed.same_stream(&whole));
            resumed.set_stream_state(state.unwrap());
            for (i, s) in ss.iter().enumerate().skip(500) {
                assert_eq!(key(&resumed.step(s)), expected[i], "{fs:?} sample {i}");
            }
        }
    }
}

#[test]
fn a_stream_with_memory_resumed_from_its_state_answers_as_the_whole_stream() {
    memory_resume::<f32>();
    memory_resume::<f64>();
}

#[test]
fn same_stream_compares_the_memory_operators() {
    let p = memory_params(K, 36, FeatureSet::HysteresisAware);
    let c = Compensator::<f32, K>::new(&p).unwrap();
    // Γ, B and the centres do not move the stream state.
    let mut q = p.clone();
    q.gamma[0][MEM_FIRST_ACTIVE] *= 2.0;
    q.poly[1][3] += 1.0;
    q.centres.truncate(3);
    assert!(Compensator::<f32, K>::new(&q).unwrap().same_stream(&c));
    // The memory spec does.
    let changes: [fn(&mut MemorySpec<f32>); 5] = [
        |s| s.grating_tau_s[1] *= 2.0,
        |s| s.ambient_tau_s[2] = 0.0,
        |s| s.play_half_width_pm[0] = 3.0,
        |s| s.observer_lag_s = 45.0,
        |s| s.observer_row[3] = 0.5,
    ];
    for (i, f) in changes.into_iter().enumerate() {
        let mut q = p.clone();
        f(&mut q.memory);
        for (row, src) in q.gamma.iter_mut().zip(p.gamma.iter()) {
            for (k, g) in row.iter_mut().enumerate() {
                *g = if q.memory.term_active(&Dims::PAPER, k) { src[k] } else { 0.0 };
            }
        }
        assert!(!Compensator::<f32, K>::new(&q).unwrap().same_stream(&c), "change {i}");
    }
    // No memory against memory (same dead band and feature set).
    let mut off = p.clone();
    off.memory = MemorySpec::off();
    off.gamma = [[0.0; MAX_MEMORY]; 4];
    assert!(!Compensator::<f32, K>::new(&off).unwrap().same_stream(&c));
}

/// The first used grating high-pass of [`some_memory_spec`] (τ slot 1, grating 0).
const MEM_FIRST_ACTIVE: usize = 3;

#[test]
fn validate_refuses_bad_memory_parameters() {
    let good = memory_params(4, 37, FeatureSet::HysteresisAware);
    assert!(good.memory.term_active(&Dims::PAPER, MEM_FIRST_ACTIVE));
    assert_eq!(good.validate(), Ok(()));
    type Edit = fn(&mut ModelParams<f32, K>);
    let cases: [(&str, Edit); 7] = [
        ("gamma", |p| p.gamma[1][0] = 0.5), // τ slot 0 is unused
        ("gamma", |p| p.gamma[2][fbg_shared::layout::paper::MEM_OBSERVER - 1] = -1e-30), // play slot 2 unused
        ("gamma", |p| {
            // An observer with its lag removed is unused, so its Γ must go too.
            p.memory.observer_lag_s = 0.0;
        }),
        ("gamma", |p| p.gamma[0][MEM_FIRST_ACTIVE] = f32::NAN),
        ("memory.grating_tau_s", |p| p.memory.grating_tau_s[1] = -20.0),
        ("memory.ambient_tau_s", |p| p.memory.ambient_tau_s[0] = -1.0),
        ("memory.observer_smooth_s", |p| p.memory.observer_smooth_s = 0.0),
    ];
    for (field, f) in cases {
        let mut p = good.clone();
        f(&mut p);
        assert_eq!(p.validate(), Err(Error::BadParameter { field }), "{field}");
        assert_eq!(Compensator::<f32, K>::new(&p).err(), Some(Error::BadParameter { field }), "{field}");
        let mut c = Compensator::<f32, K>::new(&good).unwrap();
        assert_eq!(c.reload(&p), Err(Error::BadParameter { field }), "{field}");
    }
    // An observer that is switched on has a Γ; one on an unused slot of a model without memory
    // is refused the same way.
    let mut p = params(4, 37, FeatureSet::Paper);
    p.gamma[0][fbg_shared::layout::paper::MEM_OBSERVER] = 1.0;
    assert_eq!(p.validate(), Err(Error::BadParameter { field: "gamma" }));
}

#[test]
fn a_non_finite_time_is_refused_by_a_memory_model_and_leaves_its_state() {
    // HysteresisAware without memory ignores t (see `time_is_screened_only_when_used`); with
    // memory terms it reads t, so a non-finite t is NON_FINITE.
    for n in [0, K] {
        let p = memory_params(n, 38, FeatureSet::HysteresisAware);
        let mut c = Compensator::<f32, K>::new(&p).unwrap();
        let ss = irregular(38, 200);
        run(&mut c, &ss[..150]);
        for bad in [
            sample([5.0, -5.0, 10.0], 22.0, f32::NAN),
            sample([5.0, -5.0, 10.0], 22.0, f32::INFINITY),
            sample([5.0, -5.0, 10.0], 22.0, f32::NEG_INFINITY),
            sample([5.0, f32::NAN, 10.0], 22.0, 1e6),
            sample([5.0, -5.0, 10.0], f32::INFINITY, 1e6),
        ] {
            let before = c.stream_state();
            let twin = c.clone();
            let e = c.step(&bad);
            assert_eq!(e.flags, Flags::NON_FINITE, "{bad:?}");
            assert!(e.values().iter().all(|v| v.is_nan()) && e.band().iter().all(|b| b.is_infinite()));
            assert_eq!(c.stream_state(), before, "{bad:?}");
            let mut psi = [0.0f32; K];
            assert_eq!(c.core_and_activations(&bad, &mut psi), None);
            c.advance(&bad);
            assert_eq!(c.stream_state(), before, "{bad:?}");
            // The rest of the stream is exactly what it would have been without the bad sample.
            let (mut x, mut y) = (c.clone(), twin);
            for s in &ss[150..] {
                assert_eq!(bits(&x.step(s)), bits(&y.step(s)));
            }
        }
    }
}

#[test]
fn reload_and_reset_forget_the_memory() {
    let p = memory_params(K, 39, FeatureSet::HysteresisAware);
    let fresh = Compensator::<f32, K>::new(&p).unwrap();
    let ss = irregular(39, 400);
    for how in 0..3 {
        let mut c = fresh.clone();
        run(&mut c, &ss[..250]);
        assert_ne!(c.stream_state(), fresh.stream_state());
        match how {
            0 => c.reload(&p).unwrap(),
            1 => c.reset(),
            _ => {
                // Reloading another model with memory, then this one again.
                c.reload(&memory_model::<K>(3, 40, FeatureSet::Paper, short_provenance(), full_memory_spec())).unwrap();
                run(&mut c, &ss[..20]);
                c.reload(&p).unwrap();
            }
        }
        assert_eq!(c.stream_state(), fresh.stream_state(), "case {how}");
        let mut f = fresh.clone();
        for s in &ss[250..] {
            assert_eq!(bits(&c.step(s)), bits(&f.step(s)), "case {how}");
        }
    }
    // A refused reload keeps the model and the memory state.
    let mut c = fresh.clone();
    run(&mut c, &ss[..250]);
    let mut twin = c.clone();
    let mut bad = p.clone();
    bad.memory.grating_tau_s[4] = f32::NAN;
    assert!(c.reload(&bad).is_err());
    assert_eq!(c.stream_state(), twin.stream_state());
    for s in &ss[250..] {
        assert_eq!(bits(&c.step(s)), bits(&twin.step(s)));
    }
}

#[test]
fn f32_and_f64_agree_with_memory() {
    let mut worst = 0.0f64;
    for fs in FeatureSet::ALL {
        for seed in 0..3 {
            let p = memory_model::<32>(32, seed, fs, long_provenance(), some_memory_spec());
            let mut a = Compensator::<f32, 32>::new(&p).unwrap();
            let mut b = Compensator::<f64, 32>::new(&p).unwrap();
            for s in irregular(seed + 200, 800) {
                let (x, y) = (a.step(&s), b.step(&to64(&s)));
                assert_eq!(x.flags, y.flags);
                for i in 0..3 {
                    let dv = (f64::from(x.values[i]) - y.values[i]).abs() / (1.0 + y.values[i].abs());
                    worst = worst.max(dv);
                    assert!(dv < 1e-4, "{fs:?} seed {seed}: {} vs {}", x.values[i], y.values[i]);
                }
            }
        }
    }
    eprintln!("worst relative f32/f64 difference with memory: {worst:.2e}");
}

/// Loading from a blob with the centres read one at a time (`reload_blob`, what the device
/// does) gives the very compensator `reload` of the decoded model gives: bit for bit the same
/// answers, for the paper shape and other dims with their memory banks; a refused blob leaves
/// the loaded model serving.
#[test]
fn reload_blob_answers_bit_for_bit_like_reload_of_the_decoded_model() {
    const C: usize = 16;
    use fbg_testkit::models::{dims, full_memory_spec_for, memory_model_dims, random_samples};
    for (g, amb, m, k, seed) in [(3, true, 3, 8, 7u64), (2, false, 2, 8, 22), (8, true, 4, 16, 84)] {
        let d = dims(g, amb, m).unwrap();
        let p: ModelParams<f32, C> =
            memory_model_dims(d, k, seed, FeatureSet::HysteresisAware, short_provenance(), full_memory_spec_for(&d));
        let blob = encode_vec(&p).unwrap();
        let mut a = Compensator::<f32, C>::new(&fbg_shared::blob::decode::<C>(&blob).unwrap()).unwrap();
        let mut b = Compensator::<f32, C>::unloaded();
        b.reload_blob(&blob).unwrap();
        assert_eq!(b.n_centres(), k);
        let samples = random_samples(&d, 200, seed);
        for s in &samples {
            assert_eq!(format!("{:?}", a.step(s)), format!("{:?}", b.step(s)));
        }
        // Refused (one flipped payload bit; more centres than the capacity): nothing changes.
        let mut bad = blob.clone();
        bad[30] ^= 1;
        assert!(b.reload_blob(&bad).is_err());
        let big: ModelParams<f32, 64> =
            memory_model_dims(d, C + 1, seed, FeatureSet::Paper, short_provenance(), full_memory_spec_for(&d));
        let e = b.reload_blob(&encode_vec(&big).unwrap()).unwrap_err();
        assert!(matches!(e, fbg_shared::Error::WrongDims { field: "centres", .. }), "{e:?}");
        for s in &samples {
            assert_eq!(format!("{:?}", a.step(s)), format!("{:?}", b.step(s)));
        }
    }
}
