//! The `.fbgm` codec: round trips (any dims), exact lengths, the golden v4 blob (and the v1, v3 and
//! v2 ones refused by name), over-capacity dims refused naming both, typed errors for every kind of damage, and "never panics" on arbitrary bytes.

// A test crate: clippy.toml allows the panicking shorthand in #[test] functions, not in
// the helpers around them.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use crc::{Crc, CRC_32_ISCSI};
use fbg_shared::blob::{
    self, decode, decode_split, encode, max_len, max_len_for, Header, CRC_LEN, FORMAT_VERSION, HEADER_LEN,
};
use fbg_shared::layout::paper::{MEM_AMBIENT, MEM_OBSERVER, MEM_STOP, N_MEMORY};
use fbg_shared::layout::{pad, pad2, Dims, Output, Quantity, MAX_GRATINGS, MAX_MEMORY, MAX_OUTPUTS};
use fbg_shared::{
    Centre, Compensator, Error, FeatureSet, FieldContext, Hyper, MemorySpec, ModelParams, Provenance, Sample,
    ZeroSource,
};
use fbg_testkit::models::{
    any_model, encode_vec, full_memory_spec, long_provenance, memory_model, model, short_provenance,
};
use fbg_testkit::Rng;
use proptest::prelude::*;

const ISCSI: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

/// Recompute the CRC trailer of a (modified) blob in place.
fn fix_crc(b: &mut [u8]) {
    let n = b.len() - CRC_LEN;
    let crc = ISCSI.checksum(&b[..n]);
    b[n..].copy_from_slice(&crc.to_le_bytes());
}

/// A blob with a valid CRC for *any* params (no validation).
fn encode_unchecked<const K: usize>(p: &ModelParams<f32, K>) -> Vec<u8> {
    let mut body = vec![0u8; max_len(K)];
    let n = blob::encode_unchecked(p, &mut body).expect("fits");
    body.truncate(n);
    body
}

fn min_len(centres: usize) -> usize {
    blob::min_len(&Dims::PAPER, centres)
}

/// Offset of the provenance in a blob (it is the last field of the payload).
fn provenance_offset<const K: usize>(blob: &[u8], p: &ModelParams<f32, K>) -> usize {
    let mut buf = [0u8; 128];
    let n = postcard::to_slice(&p.provenance, &mut buf).expect("fits").len();
    // The field context follows the provenance: λ_ref (8 bytes) and its source (1) per
    // grating, tolerance and lead (4 each), the end of calibration (1 or 9), 3 f32 per output.
    let f = &p.field;
    let field = 9 * p.dims.gratings() + 8 + if f.cal_end_unix_s.is_some() { 9 } else { 1 } + 12 * p.dims.n_outputs();
    blob.len() - CRC_LEN - field - n
}

/// Offset of the first f32 of the memory spec: header, output kinds (3 × 2), hyper (1 + 7 × 4),
/// stage 1 (15), guess mean and std (3 + 3), B (30).
const MEMORY_OFFSET: usize = HEADER_LEN + 6 + 1 + 7 * 4 + 4 * 51;
/// Offset of Γ: after the memory spec's 6 + 4 + 3 + 2 + 5 f32.
const GAMMA_OFFSET: usize = MEMORY_OFFSET + 4 * 20;
/// Offset of the centre-count varint: after Γ (3 × 32 f32) and the z scalers (8 + 8 f32).
const CENTRES_OFFSET: usize = GAMMA_OFFSET + 4 * (3 * 32 + 16);

fn samples(seed: u64, n: usize) -> Vec<Sample<f32>> {
    let mut r = Rng(seed);
    let mut dl = [0.0f64; 3];
    (0..n)
        .map(|k| {
            for d in dl.iter_mut() {
                *d = (*d + r.uniform(-6.0, 6.0)).clamp(-50.0, 50.0);
            }
            Sample::new([dl[0] as f32, dl[1] as f32, dl[2] as f32], r.f32(0.0, 40.0), k as f32)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Round trips and lengths

fn round_trip<const K: usize>(n: usize, seed: u64) {
    let p: ModelParams<f32, K> = any_model(n, seed, seed.is_multiple_of(2));
    let b = encode_vec(&p).unwrap();
    let q = decode::<K>(&b).expect("round trip");
    assert_eq!(p, q);
    // Bit-identical parameters give bit-identical inference.
    let mut a = Compensator::<f32, K>::new(&p).expect("loads");
    let mut c = Compensator::<f32, K>::new(&q).expect("loads");
    for s in samples(seed, 200) {
        let (x, y) = (a.step(&s), c.step(&s));
        assert_eq!(x.flags, y.flags);
        for i in 0..3 {
            assert_eq!(x.values[i].to_bits(), y.values[i].to_bits());
            assert_eq!(x.band95[i].to_bits(), y.band95[i].to_bits());
        }
    }
    // The blob does not depend on the writer's capacity: it loads into any K >= n.
    let big = decode::<80>(&b).expect("larger capacity");
    assert_eq!(big.centres.as_slice(), p.centres.as_slice());
}

#[test]
fn round_trip_several_capacities() {
    for seed in 0..4 {
        round_trip::<0>(0, seed);
        round_trip::<1>(1, seed);
        round_trip::<2>(1, seed);
        round_trip::<8>(8, seed);
        round_trip::<8>(3, seed);
        round_trip::<32>(32, seed);
        round_trip::<64>(64, seed);
        round_trip::<64>(17, seed);
    }
}

fn lengths<const K: usize>() {
    let short: ModelParams<f32, K> = model(K, 1, FeatureSet::HysteresisAware, short_provenance());
    let long: ModelParams<f32, K> = model(K, 2, FeatureSet::HysteresisAwareTime, long_provenance());
    assert_eq!(encode_vec(&short).unwrap().len(), min_len(K), "min_len({K})");
    assert_eq!(encode_vec(&long).unwrap().len(), max_len_for(&Dims::PAPER, K), "max_len({K})");
    // max_len is exact: one byte less does not do.
    let mut buf = vec![0u8; max_len_for(&Dims::PAPER, K) - 1];
    assert_eq!(encode(&long, &mut buf), Err(Error::BufferTooSmall));
}

#[test]
fn min_len_and_max_len_are_exact() {
    lengths::<0>();
    lengths::<1>();
    lengths::<8>();
    lengths::<32>();
    lengths::<64>();
    // Two-byte centre-count varint.
    lengths::<127>();
    lengths::<128>();
    lengths::<200>();
    // Version 1 was 416 bytes; version 2 added 2 header bytes and 116 f32 (memory spec 20,
    // Γ 96); version 3 adds 2 header bytes and the output kinds (3 × 2 bytes); version 4 the
    // field context (3 × 9 bytes of λ_ref and source, 4 + 1 + 4, 3 × 3 f32).
    assert_eq!(min_len(0), 416 + 2 + 4 * 116 + 2 + 6 + 27 + 9 + 36);
    assert_eq!(min_len(0), 962);
    assert_eq!(min_len(32), 962 + 60 * 32);
    // No overflow on absurd inputs.
    assert_eq!(min_len(usize::MAX), usize::MAX);
    assert_eq!(max_len(usize::MAX), usize::MAX);
    // The capacity's longest (8 gratings, ambient, 4 outputs) bounds every dims.
    let big: ModelParams<f32, 8> = fbg_testkit::models::model_dims(
        fbg_testkit::models::dims(MAX_GRATINGS, true, MAX_OUTPUTS).unwrap(),
        8,
        3,
        FeatureSet::HysteresisAwareTime,
        long_provenance(),
    );
    assert_eq!(encode_vec(&big).unwrap().len(), max_len(8));
}

#[test]
fn encode_into_every_short_buffer_fails_cleanly() {
    let p: ModelParams<f32, 3> = model(3, 9, FeatureSet::Paper, long_provenance());
    let b = encode_vec(&p).unwrap();
    let mut buf = vec![0u8; b.len()];
    for n in 0..b.len() {
        assert_eq!(encode(&p, &mut buf[..n]), Err(Error::BufferTooSmall), "buffer of {n}");
    }
    assert_eq!(encode(&p, &mut buf), Ok(b.len()));
    assert_eq!(buf, b);
}

#[test]
fn encode_refuses_invalid_params() {
    let mut p: ModelParams<f32, 2> = model(2, 3, FeatureSet::Paper, short_provenance());
    p.hyper.sigma = f32::NAN;
    let mut buf = vec![0u8; max_len_for(&Dims::PAPER, 2)];
    assert_eq!(encode(&p, &mut buf), Err(Error::BadParameter { field: "hyper.sigma" }));
}

// ---------------------------------------------------------------------------------------------
// Golden blob

/// The tiny model pinned by `tests/golden/tiny_v3.fbgm`: K = 2, exact binary numbers, memory
/// terms on: one grating τ, one ambient τ, one play, the drift observer, and Γ on some of them.
fn tiny() -> ModelParams<f32, 2> {
    let mut centres = heapless::Vec::new();
    centres
        .push(Centre {
            mu: pad(&[0.5, -0.5, 1.0, 0.0, 0.0, 1.0, -1.0, 0.0]),
            w: pad(&[1.0, -2.0, 0.25]),
            v: [0.5, 0.0, 0.0, 0.0],
        })
        .unwrap();
    centres
        .push(Centre {
            mu: pad(&[-1.0, 0.5, 0.0, 2.0, 0.0, -1.0, 1.0, 1.0]),
            w: pad(&[-0.5, 4.0, 0.0]),
            v: [0.0, 0.5, 0.0, 0.0],
        })
        .unwrap();
    let mut gamma = [[0.0f32; MAX_MEMORY]; MAX_OUTPUTS];
    gamma[0][0] = 0.25; // T per pm of grating 1's 600-s high-pass
    gamma[0][MEM_OBSERVER] = -1.0; // T per °C of observed drift
    gamma[1][MEM_STOP + 1] = 2.0; // ε per pm of grating 2's stop term
    gamma[2][MEM_AMBIENT + 1] = -0.5; // p per °C of the 3600-s ambient high-pass
    ModelParams {
        dims: Dims::PAPER,
        hyper: Hyper {
            feature_set: FeatureSet::HysteresisAware,
            sigma_mult: 1.5,
            sigma: 0.5,
            alpha: 0.125,
            dead_band_pm: 2.0,
            weak_support: 0.0625,
            envelope_margin: 0.25,
            flagged_band_factor: 2.0,
        },
        stage1: pad2(&[[0.5, 0.0, 0.0, 1.0, -2.0], [0.0, 0.25, 0.0, 0.0, 0.0], [0.0, 0.0, -0.5, 0.0, 1.0]]),
        guess_mean: pad(&[1.0, 0.0, -2.0]),
        guess_std: pad(&[2.0, 4.0, 0.5]),
        poly: pad2(&[
            [0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0, 0.0, -0.25, 0.0, 0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.125, 0.0],
        ]),
        memory: MemorySpec {
            grating_tau_s: [600.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ambient_tau_s: [0.0, 3600.0, 0.0, 0.0],
            play_half_width_pm: [4.0, 0.0, 0.0],
            observer_lag_s: 512.0,
            observer_smooth_s: 2048.0,
            observer_row: pad(&[0.125, -0.25, 0.0625, 0.5, -8.0]),
        },
        gamma,
        z_mean: pad(&[0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 0.0]),
        z_std: pad(&[32.0, 32.0, 32.0, 8.0, 1.0, 1.0, 1.0, 1.0]),
        centres,
        var_inv_g: [1.0, 0.5, 0.0, 0.0],
        var_inv_g_tail: 0.0,
        resid_var: pad(&[0.25, 1.0, 4.0]),
        resid_var_growth: pad(&[0.5, 0.0, 2.0]),
        t_cal_end_s: 1024.0,
        band_k: pad(&[1.96, 2.0, 2.5]),
        envelope_lo: pad(&[-64.0, -64.0, -64.0, -8.0]),
        envelope_hi: pad(&[64.0, 64.0, 64.0, 48.0]),
        fitted: pad(&[true; 3]),
        provenance: Provenance {
            seed: 42,
            scenario: heapless::String::try_from("golden").unwrap(),
            trainer_version: heapless::String::try_from("0.1.0").unwrap(),
            date_yyyymmdd: 20240101,
            n_cal: 1000,
        },
        field: FieldContext {
            lambda_ref_nm: pad(&[1535.0, 1545.0, 1555.0]),
            lambda_ref_source: pad(&[ZeroSource::Map, ZeroSource::FirstReading, ZeroSource::Map]),
            lambda_ref_tol_pm: 0.5,
            cal_end_unix_s: Some(1_704_067_200.0 + 1024.0),
            lead_max_s: 4096.0,
            output_lo: pad(&[-10.0, -500.0, 0.0]),
            output_hi: pad(&[40.0, 500.0, 300.0]),
            band_max: pad(&[1.0, 8.0, 4.0]),
        },
    }
}

/// GOLDEN: the exact bytes of format version 4.
///
/// A change here is a format change → bump `FORMAT_VERSION` and keep decoding v4 or reject it
/// by name (`Error::UnsupportedVersion { found: 4, .. }`). Never regenerate this file to make
/// the test pass. (It was written once by the encoder when version 4 was introduced, with
/// `FBG_WRITE_GOLDEN=1 cargo test -p fbg-shared --test blob golden`.)
const GOLDEN_V4: &[u8] = include_bytes!("golden/tiny_v4.fbgm");

/// The version-3 golden blob (no field context), kept as an "old version refused" fixture.
const GOLDEN_V3: &[u8] = include_bytes!("golden/tiny_v3.fbgm");

/// The version-2 golden blob (fixed paper layout), kept as an "old version refused" fixture.
const GOLDEN_V2: &[u8] = include_bytes!("golden/tiny_v2.fbgm");

/// The version-1 golden blob (no memory terms), kept as the "old version refused" fixture.
const GOLDEN_V1: &[u8] = include_bytes!("golden/tiny_v1.fbgm");

#[test]
fn golden_v4_bytes_are_pinned() {
    let b = encode_vec(&tiny()).unwrap();
    if std::env::var_os("FBG_WRITE_GOLDEN").is_some() && GOLDEN_V4.is_empty() {
        std::fs::write(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/tiny_v4.fbgm"), &b).unwrap();
    }
    // Shortest 2-centre blob plus "golden" (6), "0.1.0" (5), date varint 4 bytes (+3),
    // n_cal varint 2 bytes (+1), and a known end of calibration (+8).
    assert_eq!(b.len(), min_len(2) + 6 + 5 + 3 + 1 + 8);
    assert_eq!(b.len(), 1105);
    assert_eq!(
        &b[..HEADER_LEN],
        &[b'F', b'B', b'G', b'M', 4, 0, 3, 0, 1, 0, 3, 0, 10, 0, 32, 0, 2, 0],
        "magic, version 4, dims 3 gratings / ambient / 3 measurands / 10 poly / 32 memory, 2 centres (u16 LE)"
    );
    // Payload: the output kinds (T, ε, p: codes 0, 1, 2, index 1 each), feature set tag 1
    // (HysteresisAware), then sigma_mult 1.5f32 LE.
    assert_eq!(&b[HEADER_LEN..HEADER_LEN + 6], &[0, 1, 1, 1, 2, 1]);
    assert_eq!(&b[HEADER_LEN + 6..HEADER_LEN + 11], &[1, 0x00, 0x00, 0xC0, 0x3F]);
    // Memory spec after B: grating τ 600 s (0x44160000), five unused slots, ...
    assert_eq!(&b[MEMORY_OFFSET..MEMORY_OFFSET + 8], &[0x00, 0x00, 0x16, 0x44, 0, 0, 0, 0]);
    // ... ambient τ slot 1 = 3600 s (0x45610000), play r = 4 pm (0x40800000), observer lag
    // 512 s (0x44000000) and smoothing 2048 s (0x45000000), row ending with −8 (0xC1000000).
    let f = |k: usize| &b[MEMORY_OFFSET + 4 * k..MEMORY_OFFSET + 4 * k + 4];
    assert_eq!(f(7), &[0x00, 0x00, 0x61, 0x45]);
    assert_eq!(f(10), &[0x00, 0x00, 0x80, 0x40]);
    assert_eq!(f(13), &[0x00, 0x00, 0x00, 0x44]);
    assert_eq!(f(14), &[0x00, 0x00, 0x00, 0x45]);
    assert_eq!(f(19), &[0x00, 0x00, 0x00, 0xC1]);
    // Γ row-major (output major, term minor): Γ[0][0] = 0.25, Γ[0][31] = −1, Γ[1][23] = 2.
    let g = |i: usize, k: usize| &b[GAMMA_OFFSET + 4 * (N_MEMORY * i + k)..GAMMA_OFFSET + 4 * (N_MEMORY * i + k) + 4];
    assert_eq!(g(0, 0), &[0x00, 0x00, 0x80, 0x3E]);
    assert_eq!(g(0, MEM_OBSERVER), &[0x00, 0x00, 0x80, 0xBF]);
    assert_eq!(g(1, MEM_STOP + 1), &[0x00, 0x00, 0x00, 0x40]);
    assert_eq!(g(2, MEM_AMBIENT + 1), &[0x00, 0x00, 0x00, 0xBF]);
    // Centre count varint.
    assert_eq!(b[CENTRES_OFFSET], 2);
    // Apart from the version, the v4 payload starts with the v3 payload byte for byte (which
    // apart from the output kinds is the v2 payload), and the field context follows it: λ_ref
    // 1535 nm (f64 LE 0x4097FC0000000000) of grating 1, ..., the three source codes 1, 2, 1.
    let v3_end = GOLDEN_V3.len() - CRC_LEN;
    assert_eq!(&b[HEADER_LEN..v3_end], &GOLDEN_V3[HEADER_LEN..v3_end]);
    assert_eq!(&GOLDEN_V3[HEADER_LEN + 6..v3_end], &GOLDEN_V2[16..GOLDEN_V2.len() - CRC_LEN]);
    assert_eq!(&b[v3_end..v3_end + 8], &1535.0f64.to_le_bytes());
    assert_eq!(&b[v3_end + 24..v3_end + 27], &[1, 2, 1]);
    // Trailer: CRC-32C over everything before it, little-endian.
    let n = b.len() - CRC_LEN;
    assert_eq!(b[n..], ISCSI.checksum(&b[..n]).to_le_bytes());
    assert!(b == GOLDEN_V4, "encoder output differs from the v4 golden blob: format change?");
    assert_eq!(decode::<2>(GOLDEN_V4), Ok(tiny()));
    assert_eq!(decode::<32>(GOLDEN_V4).map(|p| p.provenance), Ok(tiny().provenance));
    // It loads, with its memory terms.
    let c = Compensator::<f32, 2>::new(&decode::<2>(GOLDEN_V4).unwrap()).unwrap();
    assert!(c.has_memory());
}

#[test]
fn golden_blob_is_v4() {
    assert_eq!(FORMAT_VERSION, 4, "a new format version needs its own golden blob");
    assert_eq!(Header::parse(GOLDEN_V4).map(|h| h.version), Ok(4));
}

#[test]
fn older_golden_blobs_are_refused_naming_both_versions() {
    // The old fixtures are what versions 1 and 2 wrote.
    assert_eq!(&GOLDEN_V1[..6], &[b'F', b'B', b'G', b'M', 1, 0]);
    assert_eq!(GOLDEN_V1.len(), 551, "the v1 tiny model: 536-byte minimum + 15 of provenance");
    assert_eq!(&GOLDEN_V2[..6], &[b'F', b'B', b'G', b'M', 2, 0]);
    assert_eq!(GOLDEN_V2.len(), 1017);
    assert_eq!(&GOLDEN_V3[..6], &[b'F', b'B', b'G', b'M', 3, 0]);
    assert_eq!(GOLDEN_V3.len(), 1025);
    for (old, v) in [(GOLDEN_V1, 1u16), (GOLDEN_V2, 2), (GOLDEN_V3, 3)] {
        let want = Error::UnsupportedVersion { found: v, supported: 4 };
        assert_eq!(decode::<2>(old), Err(want));
        assert_eq!(decode::<32>(old).err(), Some(want));
        assert_eq!(decode::<0>(old).err(), Some(want));
        assert_eq!(Header::parse(old), Err(want));
        let mut slot = ModelParams::<f32, 2>::empty();
        assert_eq!(blob::decode_into(old, &mut slot), Err(want));
        // Cut or damaged, it is still refused for its version first.
        assert_eq!(decode::<2>(&old[..20]), Err(want));
        let mut m = old.to_vec();
        m[100] ^= 0xFF;
        assert_eq!(decode::<2>(&m), Err(want));
        // The message names both versions.
        let msg = want.to_string();
        assert!(msg.contains(&format!("version {v}")) && msg.contains("version 4"), "{msg}");
    }
}

#[test]
fn over_capacity_dims_are_refused_naming_both() {
    // 9 gratings or 5 measurands in the header (CRC valid): the capacity is named with them.
    for (off, v, field, cap) in [(6, 9u16, "gratings", MAX_GRATINGS), (10, 5, "measurands", MAX_OUTPUTS)] {
        let mut m = GOLDEN_V4.to_vec();
        m[off..off + 2].copy_from_slice(&v.to_le_bytes());
        fix_crc(&mut m);
        let want = Error::OverCapacity { field, found: v, capacity: cap as u16 };
        assert_eq!(decode::<2>(&m), Err(want));
        assert_eq!(Header::parse(&m), Err(want));
        let msg = want.to_string();
        assert!(msg.contains(&v.to_string()) && msg.contains(&cap.to_string()), "{msg}");
    }
}

fn dims_round_trip<const K: usize>(g: usize, ambient: bool, m: usize, n: usize, seed: u64) {
    use fbg_testkit::models::{dims, full_memory_spec_for, memory_model_dims, random_samples};
    let d = dims(g, ambient, m).unwrap();
    let fs = FeatureSet::ALL[(seed % 3) as usize];
    let p: ModelParams<f32, K> = memory_model_dims(d, n, seed, fs, long_provenance(), full_memory_spec_for(&d));
    let b = encode_vec(&p).unwrap();
    assert_eq!(b.len(), max_len_for(&d, n));
    let h = Header::parse(&b).unwrap();
    assert_eq!((h.gratings, h.ambient, h.measurands), (g as u16, u16::from(ambient), m as u16));
    assert_eq!((usize::from(h.poly_terms), usize::from(h.memory_terms)), (d.poly_len(), d.memory_len()));
    let q = decode::<K>(&b).unwrap();
    assert_eq!(q, p);
    let mut a = Compensator::<f32, K>::new(&p).unwrap();
    let mut c = Compensator::<f64, K>::new(&q).unwrap();
    for s in random_samples(&d, 100, seed) {
        let (x, y) = (a.step(&s), c.step(&s.cast()));
        assert_eq!(x.values().len(), m);
        assert_eq!(x.flags, y.flags);
        for (u, v) in x.values().iter().zip(y.values()) {
            assert!(u.is_nan() == v.is_nan() && (u.is_nan() || (f64::from(*u) - v).abs() <= 1e-3 * (1.0 + v.abs())));
        }
    }
    // A sample with another grating count is answered as non-finite.
    let other = fbg_shared::Sample::from_slice(&vec![0.0f32; if g == 1 { 2 } else { g - 1 }], 20.0, 0.0).unwrap();
    assert!(a.step(&other).flags.contains(fbg_shared::Flags::NON_FINITE));
}

#[test]
fn every_dims_round_trips_and_runs() {
    for g in 1..=MAX_GRATINGS {
        for m in 1..=MAX_OUTPUTS {
            for ambient in [false, true] {
                dims_round_trip::<5>(g, ambient, m, 5, (g * 10 + m) as u64);
            }
        }
    }
    dims_round_trip::<0>(2, false, 2, 0, 1);
}

// ---------------------------------------------------------------------------------------------
// Typed errors, deterministic cases

#[test]
fn header_errors() {
    assert_eq!(decode::<2>(&[]), Err(Error::Truncated { part: "header" }));
    assert_eq!(decode::<2>(b"FBG"), Err(Error::Truncated { part: "header" }));
    assert_eq!(decode::<2>(b"{\"a\":1}"), Err(Error::BadMagic));
    assert_eq!(decode::<2>(b"X"), Err(Error::BadMagic));
    let mut b = GOLDEN_V4.to_vec();
    b[0] = b'f';
    assert_eq!(decode::<2>(&b), Err(Error::BadMagic));
    assert_eq!(Header::parse(&b), Err(Error::BadMagic));
    assert_eq!(decode::<2>(&GOLDEN_V4[..17]), Err(Error::Truncated { part: "header" }));
    assert_eq!(Header::parse(&GOLDEN_V4[..17]), Err(Error::Truncated { part: "header" }));
    assert_eq!(decode::<2>(&GOLDEN_V4[..18]), Err(Error::Truncated { part: "payload" }));
    assert_eq!(
        Header::parse(GOLDEN_V4),
        Ok(Header { version: 4, gratings: 3, ambient: 1, measurands: 3, poly_terms: 10, memory_terms: 32, centres: 2 })
    );
    // The header alone parses (the payload is not looked at).
    assert_eq!(Header::parse(&GOLDEN_V4[..18]).map(|h| h.centres), Ok(2));
}

#[test]
fn k64_blob_into_capacity_32_is_wrong_dims() {
    let p: ModelParams<f32, 64> = any_model(64, 5, true);
    let b = encode_vec(&p).unwrap();
    assert_eq!(decode::<32>(&b), Err(Error::WrongDims { field: "centres", found: 64, expected: 32 }));
    assert_eq!(decode::<63>(&b), Err(Error::WrongDims { field: "centres", found: 64, expected: 63 }));
    assert_eq!(decode::<64>(&b), Ok(p));
}

#[test]
fn header_count_must_match_payload_count() {
    let p: ModelParams<f32, 8> = any_model(5, 6, false);
    let mut b = encode_vec(&p).unwrap();
    b[16] = 4;
    fix_crc(&mut b);
    assert_eq!(decode::<8>(&b), Err(Error::WrongDims { field: "centres", found: 4, expected: 5 }));
    b[16] = 6;
    fix_crc(&mut b);
    assert_eq!(decode::<8>(&b), Err(Error::WrongDims { field: "centres", found: 6, expected: 5 }));
}

#[test]
fn every_cut_of_fixed_blobs_is_truncated_or_bad_crc() {
    fn check<const K: usize>(p: &ModelParams<f32, K>) {
        let b = encode_vec(p).unwrap();
        let min = min_len(p.centres.len());
        for cut in 0..b.len() {
            let r = decode::<K>(&b[..cut]);
            if cut < HEADER_LEN {
                assert_eq!(r, Err(Error::Truncated { part: "header" }), "cut {cut}");
            } else if cut < min {
                assert!(matches!(r, Err(Error::Truncated { .. })), "cut {cut}: {r:?}");
            } else {
                assert_eq!(r, Err(Error::BadCrc), "cut {cut}");
            }
        }
        assert_eq!(decode::<K>(&b).as_ref(), Ok(p));
    }
    check(&tiny());
    check::<0>(&any_model(0, 1, true));
    check::<0>(&any_model(0, 1, false));
    check::<8>(&any_model(8, 2, true));
    check::<32>(&any_model(32, 3, true));
    check::<32>(&any_model(7, 4, false));
}

#[test]
fn trailing_bytes() {
    let mut b = GOLDEN_V4.to_vec();
    b.push(0xFF);
    assert_eq!(decode::<2>(&b), Err(Error::TrailingBytes { extra: 1 }));
    // Erased-flash padding after a stored blob.
    b.extend_from_slice(&[0xFF; 99]);
    assert_eq!(decode::<2>(&b), Err(Error::TrailingBytes { extra: 100 }));
    // Junk under a recomputed CRC: old CRC + junk lie between payload and trailer.
    b.extend_from_slice(&[0; 4]);
    fix_crc(&mut b);
    assert_eq!(decode::<2>(&b), Err(Error::TrailingBytes { extra: 104 }));
}

#[test]
fn huge_lengths_with_valid_crc_are_bad_payload() {
    let p = tiny();
    let b = GOLDEN_V4.to_vec();
    let prov = provenance_offset(&b, &p);
    // Scenario string length: one byte after the 1-byte seed varint (42).
    assert_eq!(b[prov], 42);
    assert_eq!(b[prov + 1], 6);
    let huge: [&[u8]; 4] = [
        &[0xFF, 0xFF, 0xFF, 0xFF, 0x0F],                                     // u32::MAX
        &[0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01],       // u64::MAX
        &[0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F],       // overflowing varint
        &[0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80], // never ends
    ];
    for (pos, name) in [(prov + 1, "scenario length"), (CENTRES_OFFSET, "centre count")] {
        for h in huge {
            let mut m = b[..pos].to_vec();
            m.extend_from_slice(h);
            m.extend_from_slice(&b[pos + 1..]);
            fix_crc(&mut m);
            assert_eq!(decode::<2>(&m), Err(Error::BadPayload), "{name} {h:x?}");
        }
    }
    // The seed is a u64: its longest varint is fine, an overflowing or endless one is not.
    for (h, want) in [(huge[1], Ok(u64::MAX)), (huge[2], Err(Error::BadPayload)), (huge[3], Err(Error::BadPayload))] {
        let mut m = b[..prov].to_vec();
        m.extend_from_slice(h);
        m.extend_from_slice(&b[prov + 1..]);
        fix_crc(&mut m);
        assert_eq!(decode::<2>(&m).map(|q| q.provenance.seed), want, "seed {h:x?}");
    }
    // A string longer than its capacity, bytes present.
    let mut m = b[..prov + 1].to_vec();
    m.push(25);
    m.extend_from_slice(&[b'a'; 25]);
    m.extend_from_slice(&b[prov + 2 + 6..]);
    fix_crc(&mut m);
    assert_eq!(decode::<2>(&m), Err(Error::BadPayload));
    // Invalid UTF-8.
    let mut m = b.clone();
    m[prov + 2] = 0xFF;
    fix_crc(&mut m);
    assert_eq!(decode::<2>(&m), Err(Error::BadPayload));
    // Unknown feature-set code.
    let mut m = b.clone();
    m[HEADER_LEN + 6] = 3;
    fix_crc(&mut m);
    assert_eq!(decode::<2>(&m), Err(Error::BadPayload));
    // Payload shorter than the signed region claims (CRC valid): the last provenance byte is
    // gone and the trailer is reattached.
    let mut m = b[..b.len() - CRC_LEN - 1].to_vec();
    m.extend_from_slice(&[0; CRC_LEN]);
    fix_crc(&mut m);
    assert_eq!(decode::<2>(&m), Err(Error::BadPayload));
}

// ---------------------------------------------------------------------------------------------
// validate(), field by field, directly and through a blob with a valid CRC

type P = ModelParams<f32, 4>;
type Case = (&'static str, fn(&mut P));

fn case(field: &'static str, f: fn(&mut P)) -> Case {
    (field, f)
}

fn bad_cases() -> Vec<Case> {
    vec![
        case("hyper.sigma", |p| p.hyper.sigma = f32::NAN),
        case("hyper.sigma", |p| p.hyper.sigma = 0.0),
        case("hyper.sigma", |p| p.hyper.sigma = -1.0),
        case("hyper.sigma", |p| p.hyper.sigma = f32::INFINITY),
        case("hyper.sigma_mult", |p| p.hyper.sigma_mult = 0.0),
        case("hyper.sigma_mult", |p| p.hyper.sigma_mult = f32::NAN),
        case("hyper.alpha", |p| p.hyper.alpha = -1e-6),
        case("hyper.alpha", |p| p.hyper.alpha = f32::INFINITY),
        case("hyper.dead_band_pm", |p| p.hyper.dead_band_pm = -0.5),
        case("hyper.dead_band_pm", |p| p.hyper.dead_band_pm = f32::NAN),
        case("hyper.weak_support", |p| p.hyper.weak_support = 1.5),
        case("hyper.weak_support", |p| p.hyper.weak_support = -0.1),
        case("hyper.weak_support", |p| p.hyper.weak_support = f32::NAN),
        case("hyper.envelope_margin", |p| p.hyper.envelope_margin = -0.1),
        case("hyper.envelope_margin", |p| p.hyper.envelope_margin = f32::NEG_INFINITY),
        case("hyper.flagged_band_factor", |p| p.hyper.flagged_band_factor = 0.5),
        case("hyper.flagged_band_factor", |p| p.hyper.flagged_band_factor = f32::INFINITY),
        case("stage1", |p| p.stage1[2][4] = f32::NAN),
        case("stage1", |p| p.stage1[0][0] = f32::INFINITY),
        case("guess_mean", |p| p.guess_mean[1] = f32::NAN),
        case("guess_std", |p| p.guess_std[0] = 0.0),
        case("guess_std", |p| p.guess_std[2] = -1.0),
        case("guess_std", |p| p.guess_std[1] = f32::INFINITY),
        case("poly", |p| p.poly[1][9] = f32::NEG_INFINITY),
        case("z_mean", |p| p.z_mean[7] = f32::NAN),
        case("z_std", |p| p.z_std[0] = 0.0),
        case("z_std", |p| p.z_std[3] = -2.0),
        case("z_std", |p| p.z_std[6] = f32::NAN), // unused by Paper, but must be finite
        case("centres.mu", |p| p.centres[0].mu[0] = f32::NAN),
        case("centres.w", |p| p.centres[3].w[2] = f32::INFINITY),
        case("centres.v", |p| p.centres[1].v[3] = f32::NAN),
        case("var_inv_g", |p| p.var_inv_g[0] = -1.0),
        case("var_inv_g", |p| p.var_inv_g[3] = f32::NAN),
        case("var_inv_g_tail", |p| p.var_inv_g_tail = -0.5),
        case("var_inv_g_tail", |p| p.var_inv_g_tail = f32::INFINITY),
        case("resid_var", |p| p.resid_var[2] = -1.0),
        case("resid_var", |p| p.resid_var[0] = f32::NAN),
        case("resid_var_growth", |p| p.resid_var_growth[1] = -1e-9),
        case("resid_var_growth", |p| p.resid_var_growth[2] = f32::INFINITY),
        case("t_cal_end_s", |p| p.t_cal_end_s = f32::NAN),
        case("t_cal_end_s", |p| p.t_cal_end_s = f32::NEG_INFINITY),
        case("band_k", |p| p.band_k[0] = 0.0),
        case("band_k", |p| p.band_k[1] = -1.96),
        case("band_k", |p| p.band_k[2] = f32::NAN),
        case("envelope", |p| p.envelope_lo[0] = 61.0),
        case("envelope", |p| p.envelope_hi[3] = f32::INFINITY),
        case("envelope", |p| p.envelope_lo[2] = f32::NAN),
        // Memory terms (the model has none: every slot unused).
        case("gamma", |p| p.gamma[0][0] = 0.5),
        case("gamma", |p| p.gamma[2][MEM_OBSERVER] = -1e-30),
        case("gamma", |p| {
            p.memory.grating_tau_s[0] = 60.0;
            p.gamma[1][0] = f32::INFINITY;
        }),
        case("gamma", |p| {
            p.memory.play_half_width_pm[1] = 5.0;
            p.gamma[1][MEM_STOP] = 1.0; // play slot 0, not 1
        }),
        case("memory.grating_tau_s", |p| p.memory.grating_tau_s[3] = -600.0),
        case("memory.grating_tau_s", |p| p.memory.grating_tau_s[0] = f32::NAN),
        case("memory.ambient_tau_s", |p| p.memory.ambient_tau_s[1] = f32::INFINITY),
        case("memory.play_half_width_pm", |p| p.memory.play_half_width_pm[2] = -1.0),
        case("memory.observer", |p| p.memory.observer_lag_s = -1.0),
        case("memory.observer_smooth_s", |p| p.memory.observer_lag_s = 600.0),
        case("memory.observer_row", |p| p.memory.observer_row[2] = f32::NAN),
    ]
}

/// Finite values no fit can produce (issue 28 item 4): each field just beyond its bound
/// (`fbg_shared::model::bounds`) and at f32::MAX, named by the decoder although the CRC holds.
fn implausible_cases() -> Vec<Case> {
    const BIG: f32 = f32::MAX; // 3.4e38
    vec![
        case("dims.outputs", |p| {
            p.dims = Dims::new(
                3,
                true,
                &[
                    Output::first(Quantity::Temperature),
                    Output { quantity: Quantity::Strain, index: 200 },
                    Output::first(Quantity::Pressure),
                ],
            )
            .unwrap()
        }),
        case("dims.outputs", |p| {
            p.dims = Dims::new(
                3,
                true,
                &[
                    Output { quantity: Quantity::Temperature, index: 5 },
                    Output::first(Quantity::Strain),
                    Output::first(Quantity::Pressure),
                ],
            )
            .unwrap()
        }),
        case("hyper.sigma", |p| p.hyper.sigma = 1.1e6),
        case("hyper.sigma_mult", |p| p.hyper.sigma_mult = BIG),
        case("hyper.alpha", |p| p.hyper.alpha = 1.1e12),
        case("hyper.dead_band_pm", |p| p.hyper.dead_band_pm = 1.1e6),
        case("hyper.envelope_margin", |p| p.hyper.envelope_margin = 1.1e3),
        case("hyper.flagged_band_factor", |p| p.hyper.flagged_band_factor = BIG),
        case("stage1", |p| p.stage1[0][4] = BIG), // the T intercept
        case("stage1", |p| p.stage1[1][0] = -1.1e9),
        case("guess_mean", |p| p.guess_mean[0] = BIG),
        case("guess_mean", |p| p.guess_mean[2] = -1.1e6),
        case("guess_std", |p| p.guess_std[1] = 1.1e6),
        case("poly", |p| p.poly[0][0] = BIG), // the T intercept of the core
        case("poly", |p| p.poly[2][9] = -1.1e9),
        case("gamma", |p| {
            p.memory.grating_tau_s[0] = 60.0;
            p.gamma[1][0] = 1.1e9;
        }),
        case("memory.grating_tau_s", |p| p.memory.grating_tau_s[2] = 1.1e10),
        case("memory.ambient_tau_s", |p| p.memory.ambient_tau_s[0] = BIG),
        case("memory.play_half_width_pm", |p| p.memory.play_half_width_pm[1] = 1.1e6),
        case("memory.observer", |p| p.memory.observer_smooth_s = BIG),
        case("memory.observer_row", |p| p.memory.observer_row[0] = -1.1e9),
        case("z_mean", |p| p.z_mean[0] = 1.1e6),  // a shift's mean [pm]
        case("z_mean", |p| p.z_mean[4] = 1.1e10), // time's mean [s]
        case("z_std", |p| p.z_std[3] = 1.1e6),    // T_amb's deviation [°C]
        case("z_std", |p| p.z_std[4] = BIG),
        case("centres.mu", |p| p.centres[2].mu[1] = -1.1e6),
        case("centres.w", |p| p.centres[0].w[0] = BIG),
        case("centres.v", |p| p.centres[3].v[0] = BIG), // a variance component
        case("centres.v", |p| p.centres[1].v[1] = 1.01),
        case("var_inv_g", |p| p.var_inv_g[0] = BIG),
        case("var_inv_g_tail", |p| p.var_inv_g_tail = 1.1e12),
        case("resid_var", |p| p.resid_var[1] = BIG),
        case("resid_var_growth", |p| p.resid_var_growth[0] = 1.1e12),
        case("t_cal_end_s", |p| p.t_cal_end_s = -1.1e10),
        case("band_k", |p| p.band_k[2] = 1.1e3),
        case("envelope", |p| p.envelope_hi[1] = 1.1e6),
        case("envelope", |p| p.envelope_lo[3] = -BIG),
        case("field.lambda_ref_tol_pm", |p| p.field.lambda_ref_tol_pm = BIG),
        case("field.lead_max_s", |p| p.field.lead_max_s = 1.1e10),
        case("field.cal_end_unix_s", |p| p.field.cal_end_unix_s = Some(1.1e11)),
        case("field.cal_end_unix_s", |p| p.field.cal_end_unix_s = Some(-1.1e11)),
        case("field.cal_end_unix_s", |p| p.field.cal_end_unix_s = Some(f64::NAN)),
        case("field.output_envelope", |p| p.field.output_hi[0] = BIG),
        case("field.output_envelope", |p| p.field.output_lo[1] = -1.1e6),
        case("field.band_max", |p| p.field.band_max[2] = BIG),
    ]
}

#[test]
fn implausible_values_are_refused_by_name() {
    let good: P = memory_model(4, 21, FeatureSet::HysteresisAware, long_provenance(), full_memory_spec());
    assert_eq!(good.validate(), Ok(()));
    for (field, f) in implausible_cases() {
        let mut p = good.clone();
        f(&mut p);
        let want: Result<(), Error> = Err(Error::BadParameter { field });
        assert_eq!(p.validate(), want, "{field}");
        // In a blob with a valid CRC: refused by both decoders, by name.
        let bytes = encode_unchecked(&p);
        assert_eq!(decode::<4>(&bytes).map(|_| ()), want, "{field}");
        let mut head = ModelParams::<f32, 0>::empty();
        assert_eq!(decode_split::<4>(&bytes, &mut head).map(|_| ()), want, "{field} (split)");
        // The encoder never writes it.
        let mut buf = vec![0u8; blob::max_len(4)];
        assert_eq!(blob::encode(&p, &mut buf).map(|_| ()), want, "{field} (encode)");
        // And in f64 (a host model).
        let q: ModelParams<f64, 4> = p.convert().unwrap();
        assert_eq!(q.validate(), want, "{field} (f64)");
    }
}

#[test]
fn values_at_their_bounds_are_accepted() {
    use fbg_shared::model::bounds::*;
    let good: P = memory_model(4, 22, FeatureSet::HysteresisAware, short_provenance(), full_memory_spec());
    let at: [fn(&mut P); 8] = [
        |p| p.stage1[0][4] = COEF_MAX as f32,
        |p| p.poly[1][0] = -(COEF_MAX as f32),
        |p| p.guess_mean[0] = OUTPUT_MAX as f32,
        |p| p.resid_var[2] = VARIANCE_MAX as f32,
        |p| p.var_inv_g[0] = INV_G_MAX as f32,
        |p| p.centres[0].v[0] = -1.0,
        |p| p.field.output_lo[1] = -(OUTPUT_MAX as f32),
        |p| {
            p.dims = Dims::new(
                3,
                true,
                &[
                    Output::first(Quantity::Temperature),
                    Output { quantity: Quantity::Strain, index: MAX_OUTPUTS as u8 },
                    Output::first(Quantity::Pressure),
                ],
            )
            .unwrap()
        },
    ];
    for (i, f) in at.iter().enumerate() {
        let mut p = good.clone();
        f(&mut p);
        assert_eq!(p.validate(), Ok(()), "case {i}");
        assert_eq!(decode::<4>(&encode_unchecked(&p)).map(|_| ()), Ok(()), "case {i}");
    }
}

#[test]
fn validate_names_each_bad_field() {
    let good: P = model(4, 11, FeatureSet::Paper, long_provenance());
    assert_eq!(good.validate(), Ok(()));
    for (field, f) in bad_cases() {
        let mut p = good.clone();
        f(&mut p);
        assert_eq!(p.validate(), Err(Error::BadParameter { field }), "{field}");
        // The same parameters in a blob with a valid CRC: decoded, then refused by name.
        assert_eq!(decode::<4>(&encode_unchecked(&p)), Err(Error::BadParameter { field }), "{field}");
        // And in f64.
        let q: ModelParams<f64, 4> = p.convert().unwrap();
        assert_eq!(q.validate(), Err(Error::BadParameter { field }), "{field} (f64)");
    }
}

#[test]
fn validate_accepts_boundary_values() {
    let good: P = model(4, 12, FeatureSet::Paper, short_provenance());
    let ok_cases: [fn(&mut P); 14] = [
        |p| p.hyper.alpha = 0.0,
        |p| p.hyper.dead_band_pm = 0.0,
        |p| p.hyper.weak_support = 0.0,
        |p| p.hyper.weak_support = 1.0,
        |p| p.hyper.envelope_margin = 0.0,
        |p| p.hyper.flagged_band_factor = 1.0,
        |p| p.z_std[6] = 0.0, // latch dims unused by Paper
        |p| p.envelope_lo[1] = p.envelope_hi[1],
        |p| p.resid_var_growth = pad(&[0.0, 1e-3, 0.0]),
        |p| p.t_cal_end_s = -5.0, // any finite clock origin
        |p| {
            p.var_inv_g = [0.0; 4];
            p.resid_var = [0.0; 4];
        },
        // An observer smoothing without a lag is unused (and needs no Γ); so is a zero slot.
        |p| p.memory.observer_smooth_s = 100.0,
        |p| p.memory.observer_row = pad(&[1.0, -1.0, 0.5, 2.0, -40.0]),
        |p| {
            p.memory.observer_lag_s = 1e-3;
            p.memory.observer_smooth_s = 1e-3;
            p.gamma[0][MEM_OBSERVER] = 1.0;
        },
    ];
    for (i, f) in ok_cases.into_iter().enumerate() {
        let mut p = good.clone();
        f(&mut p);
        assert_eq!(p.validate(), Ok(()), "case {i}");
        assert_eq!(decode::<4>(&encode_vec(&p).unwrap()), Ok(p), "case {i}");
    }
    // Unused z dimensions must still be > 0 when a feature set does use them.
    let mut p = good.clone();
    p.hyper.feature_set = FeatureSet::HysteresisAware;
    p.z_std[6] = 0.0;
    assert_eq!(p.validate(), Err(Error::BadParameter { field: "z_std" }));
    p.hyper.feature_set = FeatureSet::Paper;
    p.z_std[4] = 0.0;
    assert_eq!(p.validate(), Err(Error::BadParameter { field: "z_std" }));
}

#[test]
fn nan_sigma_under_valid_crc_by_byte_patch() {
    let mut b = GOLDEN_V4.to_vec();
    // sigma follows the output kinds, the feature-set tag and sigma_mult.
    b[HEADER_LEN + 11..HEADER_LEN + 15].copy_from_slice(&f32::NAN.to_le_bytes());
    fix_crc(&mut b);
    assert_eq!(decode::<2>(&b), Err(Error::BadParameter { field: "hyper.sigma" }));
}

#[test]
fn errors_display() {
    for e in [
        Error::Truncated { part: "payload" },
        Error::BadMagic,
        Error::UnsupportedVersion { found: 1, supported: 2 },
        Error::WrongDims { field: "centres", found: 64, expected: 32 },
        Error::BadCrc,
        Error::BadPayload,
        Error::TrailingBytes { extra: 3 },
        Error::TooManyCentres { found: 9, capacity: 8 },
        Error::BadParameter { field: "hyper.sigma" },
        Error::BufferTooSmall,
    ] {
        assert!(!e.to_string().is_empty());
    }
}

// ---------------------------------------------------------------------------------------------
// Property tests: arbitrary and damaged input never panics and gets its typed error.

const CAP: usize = 8;

fn valid_blob() -> impl Strategy<Value = (ModelParams<f32, CAP>, Vec<u8>)> {
    (0..=CAP, any::<u64>(), any::<bool>()).prop_map(|(n, seed, long)| {
        let p: ModelParams<f32, CAP> = any_model(n, seed, long);
        let b = encode_vec(&p).unwrap();
        (p, b)
    })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 512,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..1200)) {
        let _ = decode::<CAP>(&bytes);
        let _ = decode::<0>(&bytes);
        let _ = Header::parse(&bytes);
    }

    #[test]
    fn arbitrary_payload_after_a_valid_header(
        centres in 0u16..12,
        body in proptest::collection::vec(any::<u8>(), 0..1200),
        with_crc in any::<bool>(),
    ) {
        let mut b = b"FBGM".to_vec();
        for v in [FORMAT_VERSION, 5, 3, 10, 32, centres] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&body);
        if with_crc && b.len() >= HEADER_LEN + CRC_LEN {
            fix_crc(&mut b);
        }
        match decode::<CAP>(&b) {
            // Vanishingly unlikely, but if random bytes do decode they are a valid model.
            Ok(p) => prop_assert_eq!(p.validate(), Ok(())),
            Err(Error::BadMagic | Error::UnsupportedVersion { .. }) => prop_assert!(false),
            Err(_) => {}
        }
    }

    #[test]
    fn bit_flip((p, b) in valid_blob(), pos in any::<prop::sample::Index>(), bit in 0u8..8) {
        let i = pos.index(b.len());
        let mut m = b.clone();
        m[i] ^= 1 << bit;
        let r = decode::<CAP>(&m);
        if i < 4 {
            prop_assert_eq!(r, Err(Error::BadMagic));
        } else if i < 6 {
            prop_assert_eq!(r, Err(Error::UnsupportedVersion { found: u16::from_le_bytes([m[4], m[5]]), supported: FORMAT_VERSION }));
        } else if i < HEADER_LEN {
            // A damaged dim changes how the payload is read: a blob too short for the dims it
            // claims reads as truncated; either way it is refused.
            prop_assert!(matches!(r, Err(Error::BadCrc | Error::Truncated { .. })), "flip at {}: {:?}", i, r);
        } else {
            // Payload or trailer: CRC-32C catches every single-bit error.
            prop_assert_eq!(r, Err(Error::BadCrc), "flip at {} of {}", i, b.len());
        }
        prop_assert_eq!(decode::<CAP>(&b), Ok(p));
    }

    #[test]
    fn byte_replacement((_p, b) in valid_blob(), pos in any::<prop::sample::Index>(), v in any::<u8>()) {
        let i = pos.index(b.len());
        let mut m = b.clone();
        m[i] = v;
        let r = decode::<CAP>(&m);
        if m == b {
            prop_assert!(r.is_ok());
        } else if i < 4 {
            prop_assert_eq!(r, Err(Error::BadMagic));
        } else if i < 6 {
            prop_assert_eq!(r, Err(Error::UnsupportedVersion { found: u16::from_le_bytes([m[4], m[5]]), supported: FORMAT_VERSION }));
        } else if i < HEADER_LEN {
            // A damaged dim: refused as corrupted, or as too short for the dims it claims.
            prop_assert!(matches!(r, Err(Error::BadCrc | Error::Truncated { .. })), "byte {}: {:?}", i, r);
        } else {
            // A single-byte error (burst of <= 8 bits) is always caught by CRC-32C.
            prop_assert_eq!(r, Err(Error::BadCrc));
        }
    }

    #[test]
    fn truncation_at_every_length((p, b) in valid_blob()) {
        let min = min_len(p.centres.len());
        for cut in 0..b.len() {
            let r = decode::<CAP>(&b[..cut]);
            if cut < HEADER_LEN {
                prop_assert_eq!(r, Err(Error::Truncated { part: "header" }));
            } else if cut < min {
                prop_assert!(matches!(r, Err(Error::Truncated { .. })), "cut {}: {:?}", cut, r);
            } else {
                prop_assert_eq!(r, Err(Error::BadCrc), "cut {}", cut);
            }
        }
    }

    #[test]
    fn insertion((_p, b) in valid_blob(), pos in any::<prop::sample::Index>(), v in any::<u8>()) {
        let i = pos.index(b.len() + 1);
        let mut m = b.clone();
        m.insert(i, v);
        let r = decode::<CAP>(&m);
        let mut appended = b.clone();
        appended.push(v);
        if m == appended {
            prop_assert_eq!(r, Err(Error::TrailingBytes { extra: 1 }));
        } else if i >= HEADER_LEN {
            prop_assert_eq!(r, Err(Error::BadCrc), "insert at {}", i);
        } else {
            prop_assert!(r.is_err());
        }
    }

    #[test]
    fn appended_junk((_p, b) in valid_blob(), junk in proptest::collection::vec(any::<u8>(), 1..64), recrc in any::<bool>()) {
        let mut m = b.clone();
        m.extend_from_slice(&junk);
        if recrc {
            // Junk plus a new CRC over everything: the old CRC and the junk are unexplained.
            m.extend_from_slice(&[0; CRC_LEN]);
            fix_crc(&mut m);
            prop_assert_eq!(decode::<CAP>(&m), Err(Error::TrailingBytes { extra: junk.len() + CRC_LEN }));
        } else {
            prop_assert_eq!(decode::<CAP>(&m), Err(Error::TrailingBytes { extra: junk.len() }));
        }
    }

    #[test]
    fn dims_changed_with_crc_recomputed((p, b) in valid_blob(), field in 3usize..6, v in any::<u16>()) {
        // Poly terms, memory terms (with the paper's gratings, ambient and measurands) and the
        // centre count; gratings and measurands beyond the capacity are
        // `over_capacity_dims_are_refused_naming_both`.
        let (name, expected) = [("", 0u16), ("", 0), ("", 0), ("poly_terms", 10), ("memory_terms", 31), ("centres", 0)][field];
        let off = 6 + 2 * field;
        let n = p.centres.len() as u16;
        let old = if field == 5 { n } else if field == 4 { 32 } else { expected };
        prop_assume!(v != old && !(field == 4 && v == 31));
        let mut m = b.clone();
        m[off..off + 2].copy_from_slice(&v.to_le_bytes());
        fix_crc(&mut m);
        let r = decode::<CAP>(&m);
        if field < 5 {
            prop_assert_eq!(r, Err(Error::WrongDims { field: name, found: v, expected }));
            prop_assert_eq!(Header::parse(&m), Err(Error::WrongDims { field: name, found: v, expected }));
        } else if usize::from(v) > CAP {
            prop_assert_eq!(r, Err(Error::WrongDims { field: "centres", found: v, expected: CAP as u16 }));
        } else {
            prop_assert_eq!(r, Err(Error::WrongDims { field: "centres", found: v, expected: n }));
        }
        // Without the CRC fix the change is corruption.
        let mut m = b.clone();
        m[off..off + 2].copy_from_slice(&v.to_le_bytes());
        prop_assert_eq!(decode::<CAP>(&m), Err(Error::BadCrc));
    }

    #[test]
    fn version_changed((_p, b) in valid_blob(), v in any::<u16>(), recrc in any::<bool>()) {
        prop_assume!(v != FORMAT_VERSION);
        let mut m = b.clone();
        m[4..6].copy_from_slice(&v.to_le_bytes());
        if recrc {
            fix_crc(&mut m);
        }
        prop_assert_eq!(decode::<CAP>(&m), Err(Error::UnsupportedVersion { found: v, supported: FORMAT_VERSION }));
        prop_assert_eq!(Header::parse(&m), Err(Error::UnsupportedVersion { found: v, supported: FORMAT_VERSION }));
    }

    #[test]
    fn huge_varints_with_valid_crc((p, b) in valid_blob(), which in 0usize..4, h in prop::collection::vec(0x80u8..=0xFF, 4..12), last in 1u8..0x80) {
        // A long varint (>= 4 continuation bytes, then a non-zero terminator, so >= 2^28 or
        // overflowing) in place of a length, count or enum tag.
        let prov = provenance_offset(&b, &p);
        let seed_len = {
            let mut buf = [0u8; 16];
            postcard::to_slice(&p.provenance.seed, &mut buf).unwrap().len()
        };
        let pos = match which {
            0 => CENTRES_OFFSET,
            1 => prov + seed_len,                       // scenario length
            2 => prov + seed_len + 1 + p.provenance.scenario.len(), // trainer_version length
            _ => HEADER_LEN + 6,                        // feature-set tag
        };
        let mut m = b[..pos].to_vec();
        m.extend_from_slice(&h);
        m.push(last);
        m.extend_from_slice(&b[pos + 1..]);
        fix_crc(&mut m);
        let r = decode::<CAP>(&m);
        prop_assert_eq!(r, Err(Error::BadPayload), "which {}", which);
    }

    #[test]
    fn mutations_under_valid_crc_never_panic(
        (_p, b) in valid_blob(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..8),
    ) {
        // Edit the payload freely, keep the header, re-sign: exercises the parser and validate.
        let mut m = b.clone();
        for (i, v, op) in edits {
            let body_len = m.len().saturating_sub(HEADER_LEN + CRC_LEN);
            if body_len == 0 { break; }
            let at = HEADER_LEN + i.index(body_len);
            match op {
                0 => m[at] = v,
                1 => m.insert(at, v),
                _ => { m.remove(at); }
            }
        }
        fix_crc(&mut m);
        if let Ok(q) = decode::<CAP>(&m) {
            prop_assert_eq!(q.validate(), Ok(()));
            // Whatever decodes re-encodes and decodes to the same model.
            prop_assert_eq!(decode::<CAP>(&encode_vec(&q).unwrap()), Ok(q.clone()));
            // Loading may still refuse a model whose coefficients overflow once folded.
            match Compensator::<f32, CAP>::new(&q) {
                Ok(mut c) => {
                    let _ = c.step(&Sample::new([1.0, 2.0, 3.0], 20.0, 0.0));
                }
                Err(e) => prop_assert!(matches!(e, Error::BadParameter { .. }), "{:?}", e),
            }
        }
    }
}

#[test]
fn decoded_blob_module_constants() {
    assert_eq!(blob::MAGIC, *b"FBGM");
    assert_eq!(HEADER_LEN, 18);
    assert_eq!(FORMAT_VERSION, 4);
    assert_eq!(CRC_LEN, 4);
}

#[test]
fn fuzz_seeds_are_valid_blobs() {
    // The seeds of `shared/fuzz` must stay decodable, or the fuzzer starts from nothing; three
    // of them carry memory terms (the tiny golden model, K = 8 with `some_memory_spec`, K = 32
    // with every slot on), so mutations reach the memory spec and Γ.
    let seeds: [(&[u8], usize, bool); 4] = [
        (include_bytes!("../fuzz/corpus/decode/seed-tiny-k2.fbgm"), 2, true),
        (include_bytes!("../fuzz/corpus/decode/seed-k0.fbgm"), 0, false),
        (include_bytes!("../fuzz/corpus/decode/seed-k8-long-provenance.fbgm"), 8, true),
        (include_bytes!("../fuzz/corpus/decode/seed-k32.fbgm"), 32, true),
    ];
    if std::env::var_os("FBG_WRITE_GOLDEN").is_some() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/fuzz/corpus/decode/");
        let k8: ModelParams<f32, 8> = fbg_testkit::models::memory_model(
            8,
            8,
            FeatureSet::HysteresisAwareTime,
            long_provenance(),
            fbg_testkit::models::some_memory_spec(),
        );
        let k32: ModelParams<f32, 32> = fbg_testkit::models::memory_model(
            32,
            32,
            FeatureSet::HysteresisAware,
            short_provenance(),
            fbg_testkit::models::full_memory_spec(),
        );
        let k0: ModelParams<f32, 0> = model(0, 0, FeatureSet::Paper, short_provenance());
        std::fs::write(format!("{dir}seed-tiny-k2.fbgm"), GOLDEN_V4).unwrap();
        std::fs::write(format!("{dir}seed-k0.fbgm"), encode_vec(&k0).unwrap()).unwrap();
        std::fs::write(format!("{dir}seed-k8-long-provenance.fbgm"), encode_vec(&k8).unwrap()).unwrap();
        std::fs::write(format!("{dir}seed-k32.fbgm"), encode_vec(&k32).unwrap()).unwrap();
    }
    for (b, n, memory) in seeds {
        assert_eq!(decode::<32>(b).map(|p| (p.centres.len(), p.has_memory())), Ok((n, memory)));
    }
    assert_eq!(seeds[0].0, GOLDEN_V4);
}
