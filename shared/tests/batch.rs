//! `step_batch` against `step`: the batch path (the stream state moved sample after sample, the
//! RBF pass run over several samples at once) gives bit for bit what the device-faithful step
//! gives sample after sample, flags and band included, in both precisions, for every feature
//! set, with and without memory terms, through the gate's refusals, the fade at rest, weak
//! support, samples outside the envelope and non-finite ones, whatever the batches' lengths.

use fbg_shared::layout::pad;
use fbg_shared::{Compensator, Estimate, Flags, ModelParams, Pending, Real, Sample, TrustSpec};
use fbg_testkit::installation::{samples, synthetic_params, MAX_K};
use fbg_testkit::models::{any_model, dims, model_dims, random_samples, short_provenance};

/// An estimate as bits (values, band, flags), so that NaN compares equal to itself.
fn bits<F: Real>(e: &Estimate<F>) -> (Vec<u64>, Vec<u64>, Flags, u8) {
    let b = |v: &[F]| v.iter().map(|x| x.to_f64().to_bits()).collect::<Vec<u64>>();
    (b(&e.values), b(&e.band95), e.flags, e.outputs)
}

/// Step after step, then the same stream in batches of `sizes` (cycled), from fresh
/// compensators: every estimate and the final state equal; returns the flags seen.
fn same<F: Real, G: Real, const K: usize>(p: &ModelParams<G, K>, s: &[Sample<f32>], sizes: &[usize]) -> Flags {
    let s: Vec<Sample<F>> = s.iter().map(|x| x.cast()).collect();
    let mut one = Compensator::<F, K>::new(p).unwrap();
    let want: Vec<Estimate<F>> = s.iter().map(|x| one.step(x)).collect();
    let mut seen = Flags::OK;
    for e in &want {
        seen.insert(e.flags);
    }
    let mut batch = Compensator::<F, K>::new(p).unwrap();
    let mut got = vec![Estimate::<F>::default(); s.len()];
    let (mut at, mut k) = (0, 0);
    while at < s.len() {
        let n = sizes[k % sizes.len()].min(s.len() - at);
        // An output slice longer than the samples: only the samples' part is written.
        let extra = usize::from(k % 2 == 1 && at + n < s.len());
        let done = batch.step_batch(&s[at..at + n], &mut got[at..at + n + extra]);
        assert_eq!(done, n);
        at += n;
        k += 1;
    }
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(bits(g), bits(w), "sample {i} (batches {sizes:?})");
    }
    assert_eq!(batch.state(), one.state(), "final state (batches {sizes:?})");

    // In two parts: each batch begun in order, then its estimates ended in pieces of another
    // length, the last piece first (no state is read).
    let mut two = Compensator::<F, K>::new(p).unwrap();
    let mut pending = vec![Pending::<F>::default(); s.len()];
    let mut got = vec![Estimate::<F>::default(); s.len()];
    let (mut at, mut k) = (0, 0);
    while at < s.len() {
        let n = sizes[k % sizes.len()].min(s.len() - at);
        assert_eq!(two.begin_batch(&s[at..at + n], &mut pending[at..at + n]), n);
        let piece = 1 + (k * 5) % 11;
        let starts: Vec<usize> = (at..at + n).step_by(piece).collect();
        for &a in starts.iter().rev() {
            let b = (a + piece).min(at + n);
            assert_eq!(two.end_batch(&s[a..b], &pending[a..b], &mut got[a..b]), b - a);
        }
        at += n;
        k += 1;
    }
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(bits(g), bits(w), "sample {i} in two parts (batches {sizes:?})");
    }
    assert_eq!(two.state(), one.state(), "final state in two parts (batches {sizes:?})");

    // An output shorter than the samples: only the samples it holds move the state.
    let cut = s.len() * 2 / 3 + 1;
    let mut short = Compensator::<F, K>::new(p).unwrap();
    let mut part = Compensator::<F, K>::new(p).unwrap();
    let mut out = vec![Estimate::<F>::default(); cut];
    assert_eq!(short.step_batch(&s, &mut out), cut);
    for x in &s[..cut] {
        let _ = part.step(x);
    }
    assert_eq!(short.state(), part.state());
    assert_eq!(bits(&out[cut - 1]), bits(&want[cut - 1]));
    seen
}

const SIZES: [&[usize]; 4] = [&[usize::MAX], &[1], &[8, 3, 13], &[7, 64, 1, 9]];

#[test]
fn batches_are_the_step_bit_for_bit_on_random_models() {
    let mut seen = Flags::OK;
    for seed in 0..18u64 {
        let p = any_model::<16>(1 + (seed as usize * 5) % 16, seed, seed % 2 == 0);
        let s = random_samples(&p.dims, 300, seed);
        for sizes in SIZES {
            seen.insert(same::<f64, f32, 16>(&p, &s, sizes));
            seen.insert(same::<f32, f32, 16>(&p, &s, sizes));
        }
    }
    assert!(seen.contains(Flags::WEAK_SUPPORT), "no weak support seen: {seen}");
}

#[test]
fn batches_are_the_step_bit_for_bit_in_every_shape() {
    // Other grating and output counts than the paper's (the step's general loop bounds), with
    // the test kit's edge samples: far outside the envelope, a NaN shift, an infinite time.
    let mut seen = Flags::OK;
    for (i, (g, ambient, m)) in
        [(1, true, 1), (2, false, 2), (4, true, 3), (5, true, 4), (8, false, 3), (3, true, 2)].into_iter().enumerate()
    {
        let seed = 40 + i as u64;
        let d = dims(g, ambient, m).unwrap();
        let p = model_dims::<16>(d, 11, seed, fbg_shared::FeatureSet::ALL[i % 3], short_provenance());
        let s = random_samples(&p.dims, 200, seed);
        for sizes in SIZES {
            seen.insert(same::<f64, f32, 16>(&p, &s, sizes));
            seen.insert(same::<f32, f32, 16>(&p, &s, sizes));
        }
    }
    assert!(seen.contains(Flags::NON_FINITE.union(Flags::OUT_OF_ENVELOPE)), "{seen}");
}

/// The largest |Δx|/Δt of each envelope input over `s` (what the trainer's trust spec
/// measures).
fn rates(s: &[Sample<f32>]) -> [f64; 9] {
    let mut r = [0.0f64; 9];
    for w in s.windows(2) {
        let dt = f64::from(w[1].t_s - w[0].t_s);
        for (g, rg) in r.iter_mut().enumerate().take(3) {
            *rg = rg.max(f64::from(w[1].dl_pm[g] - w[0].dl_pm[g]).abs() / dt);
        }
        r[3] = r[3].max(f64::from(w[1].t_amb_c - w[0].t_amb_c).abs() / dt);
    }
    r
}

#[test]
fn batches_are_the_step_bit_for_bit_through_the_gate_and_the_fade() {
    // The synthetic installation with every memory slot, a gate from its own clean stream and
    // a quiet time of 2 h; the stream gets glitches (refused by the gate), a lasting jump (let
    // in once time allows) and a long rest (the fade to Model-P).
    let mut p = synthetic_params(16, 11).unwrap();
    let clean = samples(1500, 3);
    let r = rates(&clean);
    let mut t = TrustSpec::off();
    t.rate_max[..4].copy_from_slice(&r[..4]);
    t.quiet_max_s = pad(&[2.0 * 3600.0; 3]);
    for o in 0..3 {
        t.fallback_var[o] = 4.0 * p.band_k[o] * p.band_k[o] * p.resid_var[o];
    }
    p.trust = t;
    p.validate().unwrap();
    let mut s = clean.clone();
    s[300].t_amb_c = 85.0;
    s[301].dl_pm[0] = f32::NAN;
    s[420].dl_pm[2] += 500.0;
    for x in s.iter_mut().skip(700).take(200) {
        x.dl_pm[1] += if clean[700].dl_pm[1] > 0.0 { -90.0 } else { 90.0 };
    }
    // At rest from sample 1000: every input held, the clock running on.
    let rest = s[1000];
    for x in s.iter_mut().skip(1000) {
        let t_s = x.t_s;
        *x = rest;
        x.t_s = t_s;
    }
    let mut seen = Flags::OK;
    for sizes in SIZES {
        seen.insert(same::<f64, f64, MAX_K>(&p, &s, sizes));
        seen.insert(same::<f32, f64, MAX_K>(&p, &s, sizes));
    }
    let want = Flags::FALLBACK.union(Flags::OUT_OF_ENVELOPE).union(Flags::NON_FINITE);
    assert!(seen.contains(want), "the stream shows {seen}, not every case of {want}");
    // Both kinds of fallback: refused by the gate (with out-of-envelope) and faded at rest.
    let mut c = Compensator::<f64, MAX_K>::new(&p).unwrap();
    let est: Vec<Estimate<f64>> = s.iter().map(|x| c.step(&x.cast())).collect();
    assert!(est[1400].flags.contains(Flags::FALLBACK) && !est[1400].flags.contains(Flags::OUT_OF_ENVELOPE));
    assert!(est[300].flags.contains(Flags::FALLBACK.union(Flags::OUT_OF_ENVELOPE)));
}
