//! Host tests of the memory terms in the compensator: ŷ = Bφ + Γm + Wψ, their validation,
//! reloads and resets, f32/f64 agreement, and loading from a blob.

use crate::common;

use common::{bits, irregular, memory_params, params, run, sample, to64, K};
use fbg_shared::layout::paper::N_MEMORY;
use fbg_shared::layout::{Dims, MAX_MEMORY};
use fbg_shared::{Compensator, Error, FeatureSet, Flags, MemoryBank, ModelParams};
use fbg_testkit::models::{
    encode_vec, full_memory_spec, long_provenance, memory_model, short_provenance, some_memory_spec,
};

/// The first used grating high-pass of [`some_memory_spec`] (τ slot 1, grating 0).
const MEM_FIRST_ACTIVE: usize = 3;

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
            let before = *c.state();
            let twin = c.clone();
            let e = c.step(&bad);
            assert_eq!(e.flags, Flags::NON_FINITE, "{bad:?}");
            assert!(e.values().iter().all(|v| v.is_nan()) && e.band().iter().all(|b| b.is_infinite()));
            assert_eq!(*c.state(), before, "{bad:?}");
            // The trainer's entry points refuse it too, leaving the state.
            let mut state = before;
            let mut psi = [0.0f32; K];
            assert_eq!(c.model().core_and_activations(&mut state, &bad, &mut psi), None);
            c.model().advance(&mut state, &bad);
            assert_eq!(state, before, "{bad:?}");
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
        assert_ne!(*c.state(), *fresh.state());
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
        assert_eq!(*c.state(), *fresh.state(), "case {how}");
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
    assert_eq!(*c.state(), *twin.state());
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
