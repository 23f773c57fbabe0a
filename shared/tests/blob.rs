//! The `.fbgm` codec: round trips (any dims), exact lengths, the golden v4 blob (and the v1,
//! v3 and v2 ones refused by name), over-capacity dims refused naming both, and typed errors for
//! every kind of damage (`blob_validation.rs`: every field's bound, and arbitrary bytes).

use crate::common;

use common::blob::*;
use fbg_shared::blob::{self, decode, encode, max_len, max_len_for, Header, CRC_LEN, FORMAT_VERSION, HEADER_LEN};
use fbg_shared::layout::paper::{MEM_AMBIENT, MEM_OBSERVER, MEM_STOP, N_MEMORY};
use fbg_shared::layout::{pad, pad2, Dims, MAX_GRATINGS, MAX_MEMORY, MAX_OUTPUTS};
use fbg_shared::{
    Centre, Compensator, Error, FeatureSet, FieldContext, Hyper, MemorySpec, ModelParams, Provenance, TrustSpec,
    ZeroSource,
};
use fbg_testkit::models::{any_model, encode_vec, long_provenance, model, short_provenance};

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
    // field context (3 × 9 bytes of λ_ref and source, 4 + 1 + 4, 3 × 3 f32); version 5 the
    // trust spec (4 rate limits, 3 quiet times, 2 × 3 f32); version 6 the pace (4 f32);
    // version 7 the speeds and the smallest swings (4 + 4 f32).
    assert_eq!(min_len(0), 416 + 2 + 4 * 116 + 2 + 6 + 27 + 9 + 36 + 52 + 16 + 32);
    assert_eq!(min_len(0), 1062);
    assert_eq!(min_len(32), 1062 + 60 * 32);
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
        trust: TrustSpec {
            rate_max: pad(&[0.5, 0.25, 0.125, 0.01]),
            quiet_max_s: pad(&[7200.0, 3600.0, 1800.0]),
            fallback_var: pad(&[0.04, 16.0, 4.0]),
            fallback_var_growth: pad(&[1e-6, 1e-4, 1e-5]),
            swing_rms_max: pad(&[6.0, 3.0, 1.5, 0.75]),
            speed_rms_max: pad(&[0.5, 0.25, 0.125, 0.001]),
            swing_rms_min: pad(&[1.0, 0.5, 0.25, 0.125]),
        },
    }
}

/// GOLDEN: the exact bytes of format version 7.
///
/// A change here is a format change → bump `FORMAT_VERSION` and keep decoding v7 or reject it
/// by name (`Error::UnsupportedVersion { found: 7, .. }`). Never regenerate this file to make
/// the test pass. (It was written once by the encoder when version 7 was introduced, with
/// `FBG_WRITE_GOLDEN=1 cargo test -p fbg-shared --test shared blob::golden`.)
const GOLDEN_V7: &[u8] = include_bytes!("golden/tiny_v7.fbgm");

/// The version-6 golden blob (no speed term), kept as an "old version refused" fixture.
const GOLDEN_V6: &[u8] = include_bytes!("golden/tiny_v6.fbgm");

/// The version-5 golden blob (no swing term), kept as an "old version refused" fixture.
const GOLDEN_V5: &[u8] = include_bytes!("golden/tiny_v5.fbgm");

/// The version-4 golden blob (no trust spec), kept as an "old version refused" fixture.
const GOLDEN_V4: &[u8] = include_bytes!("golden/tiny_v4.fbgm");

/// The version-3 golden blob (no field context), kept as an "old version refused" fixture.
const GOLDEN_V3: &[u8] = include_bytes!("golden/tiny_v3.fbgm");

/// The version-2 golden blob (fixed paper layout), kept as an "old version refused" fixture.
const GOLDEN_V2: &[u8] = include_bytes!("golden/tiny_v2.fbgm");

/// The version-1 golden blob (no memory terms), kept as the "old version refused" fixture.
const GOLDEN_V1: &[u8] = include_bytes!("golden/tiny_v1.fbgm");

#[test]
fn golden_v7_bytes_are_pinned() {
    let b = encode_vec(&tiny()).unwrap();
    if std::env::var_os("FBG_WRITE_GOLDEN").is_some() && GOLDEN_V7.is_empty() {
        std::fs::write(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/tiny_v7.fbgm"), &b).unwrap();
    }
    // Shortest 2-centre blob plus "golden" (6), "0.1.0" (5), date varint 4 bytes (+3),
    // n_cal varint 2 bytes (+1), and a known end of calibration (+8).
    assert_eq!(b.len(), min_len(2) + 6 + 5 + 3 + 1 + 8);
    assert_eq!(b.len(), 1205);
    assert_eq!(
        &b[..HEADER_LEN],
        &[b'F', b'B', b'G', b'M', 7, 0, 3, 0, 1, 0, 3, 0, 10, 0, 32, 0, 2, 0],
        "magic, version 7, dims 3 gratings / ambient / 3 measurands / 10 poly / 32 memory, 2 centres (u16 LE)"
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
    // The v5 payload is the v4 payload followed by the trust spec: the rate limits (4 f32),
    // the quiet times (3 f32, the first 7200 s = 0x45E10000), Model-P's band (3 f32) and its growth (3 f32).
    let v4_end = GOLDEN_V4.len() - CRC_LEN;
    assert_eq!(&b[HEADER_LEN..v4_end], &GOLDEN_V4[HEADER_LEN..v4_end]);
    assert_eq!(&b[v4_end..v4_end + 4], &0.5f32.to_le_bytes());
    assert_eq!(&b[v4_end + 16..v4_end + 20], &[0x00, 0x00, 0xE1, 0x45]);
    // The v6 payload is the v5 payload followed by the calibration's pace: the largest RMS
    // swing per envelope input (4 f32, the first 6.0 = 0x40C00000, the last 0.75).
    let v5_end = GOLDEN_V5.len() - CRC_LEN;
    assert_eq!(&b[HEADER_LEN..v5_end], &GOLDEN_V5[HEADER_LEN..v5_end]);
    assert_eq!(&b[v5_end..v5_end + 4], &[0x00, 0x00, 0xC0, 0x40]);
    assert_eq!(&b[v5_end + 12..v5_end + 16], &0.75f32.to_le_bytes());
    // The v7 payload is the v6 payload followed by the largest RMS speed per envelope input
    // (4 f32, the first 0.5 = 0x3F000000, the last 0.001) and the smallest RMS swing (4 f32,
    // the first 1.0 = 0x3F800000).
    let v6_end = GOLDEN_V6.len() - CRC_LEN;
    assert_eq!(&b[HEADER_LEN..v6_end], &GOLDEN_V6[HEADER_LEN..v6_end]);
    assert_eq!(&b[v6_end..v6_end + 4], &[0x00, 0x00, 0x00, 0x3F]);
    assert_eq!(&b[v6_end + 12..v6_end + 16], &0.001f32.to_le_bytes());
    assert_eq!(&b[v6_end + 16..v6_end + 20], &[0x00, 0x00, 0x80, 0x3F]);
    // Trailer: CRC-32C over everything before it, little-endian.
    let n = b.len() - CRC_LEN;
    assert_eq!(b[n..], ISCSI.checksum(&b[..n]).to_le_bytes());
    assert!(b == GOLDEN_V7, "encoder output differs from the v7 golden blob: format change?");
    assert_eq!(decode::<2>(GOLDEN_V7), Ok(tiny()));
    assert_eq!(decode::<32>(GOLDEN_V7).map(|p| p.provenance), Ok(tiny().provenance));
    // It loads, with its memory terms.
    let c = Compensator::<f32, 2>::new(&decode::<2>(GOLDEN_V7).unwrap()).unwrap();
    assert!(c.has_memory());
}

#[test]
fn golden_blob_is_v7() {
    assert_eq!(FORMAT_VERSION, 7, "a new format version needs its own golden blob");
    assert_eq!(Header::parse(GOLDEN_V7).map(|h| h.version), Ok(7));
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
    assert_eq!(&GOLDEN_V4[..6], &[b'F', b'B', b'G', b'M', 4, 0]);
    assert_eq!(GOLDEN_V4.len(), 1105);
    assert_eq!(&GOLDEN_V5[..6], &[b'F', b'B', b'G', b'M', 5, 0]);
    assert_eq!(GOLDEN_V5.len(), 1157);
    assert_eq!(&GOLDEN_V6[..6], &[b'F', b'B', b'G', b'M', 6, 0]);
    assert_eq!(GOLDEN_V6.len(), 1173);
    for (old, v) in [(GOLDEN_V1, 1u16), (GOLDEN_V2, 2), (GOLDEN_V3, 3), (GOLDEN_V4, 4), (GOLDEN_V5, 5), (GOLDEN_V6, 6)]
    {
        let want = Error::UnsupportedVersion { found: v, supported: 7 };
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
        assert!(msg.contains(&format!("version {v}")) && msg.contains("version 7"), "{msg}");
    }
}

#[test]
fn over_capacity_dims_are_refused_naming_both() {
    // 9 gratings or 5 measurands in the header (CRC valid): the capacity is named with them.
    for (off, v, field, cap) in [(6, 9u16, "gratings", MAX_GRATINGS), (10, 5, "measurands", MAX_OUTPUTS)] {
        let mut m = GOLDEN_V7.to_vec();
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
    let mut b = GOLDEN_V7.to_vec();
    b[0] = b'f';
    assert_eq!(decode::<2>(&b), Err(Error::BadMagic));
    assert_eq!(Header::parse(&b), Err(Error::BadMagic));
    assert_eq!(decode::<2>(&GOLDEN_V7[..17]), Err(Error::Truncated { part: "header" }));
    assert_eq!(Header::parse(&GOLDEN_V7[..17]), Err(Error::Truncated { part: "header" }));
    assert_eq!(decode::<2>(&GOLDEN_V7[..18]), Err(Error::Truncated { part: "payload" }));
    assert_eq!(
        Header::parse(GOLDEN_V7),
        Ok(Header { version: 7, gratings: 3, ambient: 1, measurands: 3, poly_terms: 10, memory_terms: 32, centres: 2 })
    );
    // The header alone parses (the payload is not looked at).
    assert_eq!(Header::parse(&GOLDEN_V7[..18]).map(|h| h.centres), Ok(2));
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
    let mut b = GOLDEN_V7.to_vec();
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
    let b = GOLDEN_V7.to_vec();
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
