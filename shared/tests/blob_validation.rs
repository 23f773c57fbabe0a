//! The `.fbgm` codec's validation: every field refused by name at its bound (directly and
//! through a blob with a valid CRC), and arbitrary or damaged bytes never panic and get their
//! typed error.

use crate::common;

use common::blob::*;
use fbg_shared::blob::{self, decode, decode_split, Header, CRC_LEN, FORMAT_VERSION, HEADER_LEN};
use fbg_shared::layout::paper::{MEM_OBSERVER, MEM_STOP};
use fbg_shared::layout::{pad, Dims, Output, Quantity, MAX_MEMORY, MAX_OUTPUTS};
use fbg_shared::{Compensator, Error, FeatureSet, ModelParams, Sample};
use fbg_testkit::models::{
    any_model, encode_vec, full_memory_spec, long_provenance, memory_model, model, short_provenance,
};
use proptest::prelude::*;

/// The golden v7 blob (`blob.rs` pins its bytes).
const GOLDEN_V7: &[u8] = include_bytes!("golden/tiny_v7.fbgm");

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

/// Finite values no fit can produce: each field just beyond its bound
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
        assert_eq!(decode_split::<4, MAX_MEMORY>(&bytes, &mut head).map(|_| ()), want, "{field} (split)");
        // A device's slot, which leaves Γ in the blob too.
        let mut head = ModelParams::<f32, 0, 0>::empty();
        assert_eq!(decode_split::<4, 0>(&bytes, &mut head).map(|_| ()), want, "{field} (split, Γ in the blob)");
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
    let mut b = GOLDEN_V7.to_vec();
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
    assert_eq!(FORMAT_VERSION, 7);
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
        std::fs::write(format!("{dir}seed-tiny-k2.fbgm"), GOLDEN_V7).unwrap();
        std::fs::write(format!("{dir}seed-k0.fbgm"), encode_vec(&k0).unwrap()).unwrap();
        std::fs::write(format!("{dir}seed-k8-long-provenance.fbgm"), encode_vec(&k8).unwrap()).unwrap();
        std::fs::write(format!("{dir}seed-k32.fbgm"), encode_vec(&k32).unwrap()).unwrap();
    }
    for (b, n, memory) in seeds {
        assert_eq!(decode::<32>(b).map(|p| (p.centres.len(), p.has_memory())), Ok((n, memory)));
    }
    assert_eq!(seeds[0].0, GOLDEN_V7);
}
