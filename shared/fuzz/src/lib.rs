//! The body of the `decode` fuzz target, a library so that the target and the corpus replay
//! test (`tests/corpus.rs`, compiled and run on stable by `cargo xtask lint`) run the same
//! checks: no byte string may panic the `.fbgm` decoder, and whatever it accepts must load, run
//! and re-encode to the same model.
//!
//! Each input is decoded twice: as is (header, length and CRC checks), and re-signed with a
//! valid CRC trailer, so that mutations also reach the payload parser and `validate` instead
//! of stopping at the CRC.

use crc::{Crc, CRC_32_ISCSI};
use fbg_shared::blob::{self, decode, encode, CRC_LEN};
use fbg_shared::{Compensator, Flags, Sample};

const K: usize = 32;
const ISCSI: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

fn check(data: &[u8]) {
    let Ok(params) = decode::<K>(data) else {
        return;
    };
    // Decoded params are validated and fit the capacity; loading can only refuse a model whose
    // coefficients overflow f32 once folded, and must say so.
    let mut c = match Compensator::<f32, K>::new(&params) {
        Ok(c) => c,
        Err(e) => {
            assert!(matches!(e, fbg_shared::Error::BadParameter { .. }), "{e:?}");
            return;
        }
    };
    let g = params.dims.gratings();
    let dl = [1.0f32, -2.0, 3.0, 0.5, -0.5, 1.5, -1.5, 2.5];
    let sample = |d0: f32, t_s: f32| {
        let mut d = dl;
        d[0] = d0;
        Sample::from_slice(d.get(..g).unwrap_or(&[]), 20.0, t_s).expect("within the capacity")
    };
    let e = c.step(&sample(1.0, 1.0));
    // A finite sample is NON_FINITE only if the result overflowed, and then the model's outputs
    // read NaN (the slots past them stay 0).
    if e.flags.contains(Flags::NON_FINITE) {
        assert!(e.values().iter().all(|v| v.is_nan()));
    } else if !e.flags.contains(Flags::IMPLAUSIBLE) {
        // Whatever the decoder let through, an unflagged estimate of a fitted output lies in
        // its plausible range with a band below its limit.
        for (o, (&v, &b)) in e.values().iter().zip(e.band()).enumerate() {
            let (lo, hi, lim) = params.field.plausible(o);
            assert!(!params.fitted[o] || ((lo..=hi).contains(&v) && b < lim * params.hyper.flagged_band_factor));
        }
    }
    let e = c.step(&sample(f32::NAN, 1.0));
    assert_eq!(e.flags, Flags::NON_FINITE);
    // A model with memory terms reads t: a NaN time is a non-finite sample and leaves the
    // stream state (latches and memory operators) as it was.
    let before = *c.state();
    let e = c.step(&sample(1.0, f32::NAN));
    if c.has_memory() {
        assert_eq!(e.flags, Flags::NON_FINITE);
        assert_eq!(*c.state(), before);
    }
    // Whatever decodes re-encodes (within max_len) and decodes to the same model.
    let mut buf = [0u8; blob::max_len(K)];
    let n = encode(&params, &mut buf).expect("a decoded model re-encodes");
    assert_eq!(decode::<K>(buf.get(..n).unwrap_or(&[])).as_ref(), Ok(&params));
}

/// One fuzz input: `data` as it is, then with its last four bytes replaced by a valid CRC.
pub fn decode_input(data: &[u8]) {
    check(data);
    if let Some(signed_len) = data.len().checked_sub(CRC_LEN) {
        let mut resigned = data.to_vec();
        let crc = ISCSI.checksum(&data[..signed_len]);
        resigned[signed_len..].copy_from_slice(&crc.to_le_bytes());
        check(&resigned);
    }
}
