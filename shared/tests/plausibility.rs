//! Implausible models: the decoder refuses numbers no fit can produce, and
//! at run time an estimate outside its output's envelope, or an absurd band, is a fault.

use fbg_shared::blob::{self, decode, decode_split, encode_unchecked};
use fbg_shared::field::{BAND_LIMIT_OF_MAX, OUTPUT_MARGIN_OF_BAND, OUTPUT_MARGIN_OF_RANGE};
use fbg_shared::layout::{Dims, Output, Quantity, MAX_MEMORY};
use fbg_shared::{Compensator, Error, Estimate, Flags, ModelParams, Sample, StreamClock};
use fbg_testkit::installation::{golden_samples, samples, synthetic_params, without_memory, MAX_K};

type P32 = ModelParams<f32, MAX_K>;

/// The synthetic installation's model (K = 32, with or without memory) in f32.
fn installation(memory: bool) -> P32 {
    let p = synthetic_params(32, 5).unwrap();
    let p = if memory { p } else { without_memory(p) };
    p.convert().unwrap()
}

/// `p` in a blob with a valid CRC, whatever its numbers.
fn blob_of(p: &P32) -> Vec<u8> {
    let mut buf = vec![0u8; blob::max_len(MAX_K)];
    let n = encode_unchecked(p, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

fn run<F: fbg_shared::Real>(p: &P32, ss: &[Sample<F>]) -> Vec<Estimate<F>> {
    let mut c = Compensator::<F, MAX_K>::new(p).unwrap();
    ss.iter().map(|s| c.step(s)).collect()
}

fn to64(s: &Sample<f32>) -> Sample<f64> {
    s.cast()
}

/// Every way the issue's blob cases reach a model is refused, naming the field: both
/// decoders, a device's in-place reload (which keeps its old model) and the encoder.
fn assert_refused(p: &P32, field: &'static str) {
    let want = Error::BadParameter { field };
    let bytes = blob_of(p);
    assert_eq!(blob::stored_crc(&bytes), blob::computed_crc(&bytes), "the CRC holds");
    assert_eq!(decode::<MAX_K>(&bytes).unwrap_err(), want, "{field}");
    let mut head = ModelParams::<f32, 0>::empty();
    assert_eq!(decode_split::<MAX_K, MAX_MEMORY>(&bytes, &mut head).map(|_| ()).unwrap_err(), want, "{field}");
    let mut head = ModelParams::<f32, 0, 0>::empty();
    assert_eq!(decode_split::<MAX_K, 0>(&bytes, &mut head).map(|_| ()).unwrap_err(), want, "{field} (Γ in the blob)");
    let good = installation(true);
    let mut dev = Compensator::<f32, MAX_K>::new(&good).unwrap();
    let s = samples(1, 3)[0];
    let before = dev.clone().step(&s);
    assert_eq!(dev.reload_blob(&bytes).unwrap_err(), want, "{field}");
    assert_eq!(dev.step(&s), before, "the old model keeps serving");
    assert_eq!(blob::encode(p, &mut vec![0u8; blob::max_len(MAX_K)]).unwrap_err(), want, "{field}");
}

#[test]
fn the_issues_blobs_are_refused_by_the_decoder() {
    // A T intercept of 3.4e38 °C.
    let mut p = installation(true);
    p.stage1[0][4] = f32::MAX;
    assert_refused(&p, "stage1");
    let mut p = installation(true);
    p.poly[0][0] = f32::MAX;
    assert_refused(&p, "poly");
    // A variance component of 3.4e38: each of them.
    let mut p = installation(true);
    p.centres[5].v[2] = f32::MAX;
    assert_refused(&p, "centres.v");
    let mut p = installation(true);
    p.resid_var[1] = f32::MAX;
    assert_refused(&p, "resid_var");
    let mut p = installation(true);
    p.var_inv_g[0] = f32::MAX;
    assert_refused(&p, "var_inv_g");
    // An output index of 200 (`strain200_ue`).
    let mut p = installation(true);
    let outs = [
        Output::first(Quantity::Temperature),
        Output { quantity: Quantity::Strain, index: 200 },
        Output::first(Quantity::Pressure),
    ];
    p.dims = Dims::new(3, true, &outs).unwrap();
    assert_eq!(p.dims.outputs()[1].column().as_str(), "strain200_ue");
    assert_refused(&p, "dims.outputs");
}

#[test]
fn a_sound_model_is_never_implausible_on_its_installation() {
    // The fixtures' models (xtask: K = 0…64, seeds 1 and 7, with and without memory) among them.
    for (k, seed, memory) in
        [(32, 5, false), (32, 5, true), (32, 1, true), (0, 7, false), (16, 7, true), (64, 1, false)]
    {
        let p = synthetic_params(k, seed).unwrap();
        let p: P32 = if memory { p } else { without_memory(p) }.convert().unwrap();
        let ss = samples(3000, 9);
        for e in run(&p, &ss) {
            assert!(e.flags.is_ok(), "{:?}", e.flags);
        }
        // The golden samples: the flags the fixtures pinned (out of envelope, weak support, a
        // NaN) and no new one, so the golden vectors do not change.
        let gs = golden_samples(600, 11);
        for (e, e64) in run(&p, &gs).iter().zip(run(&p, &gs.iter().map(to64).collect::<Vec<_>>())) {
            assert!(!e.flags.contains(Flags::IMPLAUSIBLE), "{:?}", e.flags);
            assert!(!e64.flags.contains(Flags::IMPLAUSIBLE), "{:?}", e64.flags);
        }
    }
}

/// A model with every number in range that reads the wrong thing: its T and p rows swapped (a
/// mislabelled channel), or its T offset by 500 °C (a wrong zero). Every estimate is outside
/// T's calibration envelope: flagged implausible, a fault, its band widened.
#[test]
fn a_plausible_but_wrong_model_is_flagged_at_run_time() {
    let good = installation(true);
    let ss = samples(500, 4);
    let ok = run(&good, &ss);
    let mut swapped = good.clone();
    swapped.poly.swap(0, 2);
    let mut offset = good.clone();
    offset.poly[0][0] += 500.0;
    for wrong in [swapped, offset] {
        assert_eq!(wrong.validate(), Ok(()), "every number is plausible");
        let back = decode::<MAX_K>(&blob_of(&wrong)).unwrap();
        let (lo, hi, _) = back.field.plausible(0);
        let f = wrong.hyper.flagged_band_factor;
        for (e, o) in run(&back, &ss).iter().zip(ok.iter()) {
            assert!(e.values[0] < lo || e.values[0] > hi, "{} in {lo}..{hi}", e.values[0]);
            assert_eq!(e.flags, Flags::IMPLAUSIBLE);
            assert!(e.flags.is_fault());
            for i in 0..3 {
                assert_eq!(e.band95[i], o.band95[i] * f, "output {i}");
            }
        }
        // In f64 too (the host's `compensate`).
        let host: ModelParams<f64, MAX_K> = back.convert().unwrap();
        let mut c = Compensator::<f64, MAX_K>::new(&host).unwrap();
        assert!(ss.iter().all(|s| c.step(&to64(s)).flags == Flags::IMPLAUSIBLE));
    }
}

#[test]
fn the_envelope_margins_are_as_stated() {
    let p = installation(false);
    let fc = &p.field;
    let (lo, hi, lim) = fc.plausible(0);
    let m = OUTPUT_MARGIN_OF_RANGE * (fc.output_hi[0] - fc.output_lo[0]) + OUTPUT_MARGIN_OF_BAND * fc.band_max[0];
    assert_eq!((lo, hi, lim), (fc.output_lo[0] - m, fc.output_hi[0] + m, BAND_LIMIT_OF_MAX * fc.band_max[0]));
    // T at the edges: inside, then just outside (T's poly row moves every estimate by the
    // same offset; the core's intercept is its first term).
    let s = samples(1, 1)[0];
    let t = run(&p, &[s])[0].values[0];
    for (target, flagged) in [(hi - 0.01, false), (lo + 0.01, false), (hi + 0.01, true), (lo - 0.01, true)] {
        let mut q = p.clone();
        q.poly[0][0] += target - t;
        let e = run(&q, &[s])[0];
        assert!((e.values[0] - target).abs() < 1e-3, "{} vs {target}", e.values[0]);
        assert_eq!(e.flags.contains(Flags::IMPLAUSIBLE), flagged, "T = {}", e.values[0]);
    }
    // A context that is not known (band_max 0, as in a model built by hand) is not checked.
    let mut q = p.clone();
    q.field.band_max[0] = 0.0;
    q.poly[0][0] += 1e4;
    assert_eq!(q.field.plausible(0), (f32::NEG_INFINITY, f32::INFINITY, f32::INFINITY));
    assert!(run(&q, &[s])[0].flags.is_ok());
}

#[test]
fn an_absurd_or_non_finite_band_is_flagged() {
    let good = installation(false);
    let s = samples(1, 2)[0];
    let ok = run(&good, &[s])[0];
    assert!(ok.flags.is_ok());
    // A residual variance within the decoder's bound but a band 100 times the largest the
    // calibration validated: the values are unchanged, the flag says the band is absurd.
    let mut p = good.clone();
    let lim = BAND_LIMIT_OF_MAX * p.field.band_max[1];
    p.resid_var[1] = (lim / p.band_k[1]).powi(2) * 1.01;
    let e = run(&p, &[s])[0];
    assert_eq!(e.values, ok.values);
    assert_eq!(e.flags, Flags::IMPLAUSIBLE);
    assert!(e.band95[1] >= lim * p.hyper.flagged_band_factor);
    // Below the limit (with the sample's leverage): no flag.
    p.resid_var[1] = (lim / p.band_k[1]).powi(2) * 0.5;
    assert!(run(&p, &[s])[0].flags.is_ok());
    // A band that grows without bound reaches infinity in f32 at an absurd lead: flagged, not
    // passed on as a normal estimate.
    let mut p = good.clone();
    p.resid_var_growth[2] = 1e12;
    let mut c = Compensator::<f32, MAX_K>::new(&p).unwrap();
    c.set_clock(StreamClock::Calibration);
    let mut far = s;
    far.t_s = 1e30;
    let e = c.step(&far);
    assert!(e.band95[2].is_infinite());
    assert!(e.flags.contains(Flags::IMPLAUSIBLE) && e.flags.is_fault(), "{:?}", e.flags);
}

#[test]
fn the_committed_blobs_decode_and_are_plausible() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    for path in [
        "shared/tests/golden/tiny_v7.fbgm",
        "firmware/model/default.fbgm",
        "shared/fuzz/corpus/decode/seed-k0.fbgm",
        "shared/fuzz/corpus/decode/seed-k32.fbgm",
        "shared/fuzz/corpus/decode/seed-k8-long-provenance.fbgm",
        "shared/fuzz/corpus/decode/seed-tiny-k2.fbgm",
    ] {
        let bytes = std::fs::read(format!("{dir}/{path}")).unwrap();
        let p = decode::<MAX_K>(&bytes).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert_eq!(p.validate(), Ok(()), "{path}");
    }
}
