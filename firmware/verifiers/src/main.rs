//! Verify-only image of one Ed25519 verifier crate (the `v-*` feature of the build), for the
//! device bench's choice of verifier (`cargo xtask device-bench`, "Ed25519 verifiers").
//!
//! 1. The RFC 8032 test vectors (section 7.1: TEST 1, 2, 3 and SHA(abc)) through the verifier:
//!    each must verify, and must be refused with one bit of its signature flipped, with one
//!    more message byte and with `S + L` in place of `S` (a non-canonical `S`, which RFC 8032
//!    refuses; the check the product adds in front of a verifier that leaves it out is part of
//!    [`verify`]). Anything else ends the run with failure.
//! 2. One verification of the bench's signed model (`FBG_BENCH_SIGNED`, signed with the QEMU
//!    test key; when absent, of the SHA(abc) vector) timed like the bench image times a step:
//!    SysTick ticks under QEMU `-icount shift=0`, calibrated by a loop of known length, with
//!    the stack the verification reached (painting).
//!
//! Lines of `key=value` go out on UART0; the run ends with a semihosting exit. The build
//! without a `v-*` feature verifies nothing (it fails the vectors by design and reports `verifier=none`): its
//! flash is the baseline the other builds' flash is measured against.

#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m_rt::entry;
use embedded_io::Write;
use fbg_firmware::counters::{known_loop, systick_elapsed, systick_now, systick_start, CALIB_ITERS};
use fbg_firmware::rfc8032::VECTORS;
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack};

/// The verifier of this build, as the report names it (one `v-*` feature; without one, none:
/// the baseline).
#[cfg(feature = "v-salty")]
const NAME: &str = "salty";
#[cfg(all(not(feature = "v-salty"), feature = "v-compact-size"))]
const NAME: &str = "ed25519-compact-opt_size";
#[cfg(all(not(feature = "v-salty"), not(feature = "v-compact-size"), feature = "v-compact"))]
const NAME: &str = "ed25519-compact";
#[cfg(all(not(feature = "v-salty"), not(feature = "v-compact-size"), not(feature = "v-compact"), feature = "v-dalek"))]
const NAME: &str = "ed25519-dalek";
#[cfg(not(any(feature = "v-salty", feature = "v-compact-size", feature = "v-compact", feature = "v-dalek")))]
const NAME: &str = "none";

static SIGNED: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bench_signed.fbgm"));
static SIGNER: &[u8; 32] = include_bytes!(concat!(env!("OUT_DIR"), "/signer.pub"));

/// The group order L, little-endian.
const GROUP_ORDER: [u8; 32] = [
    0xed, 0xd3, 0xf5, 0x5c, 0x1a, 0x63, 0x12, 0x58, 0xd6, 0x9c, 0xf7, 0xa2, 0xde, 0xf9, 0xde, 0x14, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0x10,
];

/// Whether the `S` half of `sig` is below L (as `fbg_shared::signature` checks it).
fn s_is_canonical(sig: &[u8; 64]) -> bool {
    for (s, l) in sig.iter().skip(32).rev().zip(GROUP_ORDER.iter().rev()) {
        if s != l {
            return s < l;
        }
    }
    false
}

/// `sig` with `S + L` in place of `S` (below 2^253: no carry out).
fn s_plus_l(sig: &[u8; 64]) -> [u8; 64] {
    let mut out = *sig;
    let mut carry = 0u16;
    for (o, l) in out.iter_mut().skip(32).zip(GROUP_ORDER.iter()) {
        let v = u16::from(*o) + u16::from(*l) + carry;
        *o = v as u8;
        carry = v >> 8;
    }
    out
}

/// RFC 8032 verification of `sig` over `msg` with `pk`: `S` below L, then the crate's verify.
#[inline(never)]
fn verify(msg: &[u8], sig: &[u8; 64], pk: &[u8; 32]) -> bool {
    s_is_canonical(sig) && crate_verify(msg, sig, pk)
}

#[cfg(feature = "v-salty")]
fn crate_verify(msg: &[u8], sig: &[u8; 64], pk: &[u8; 32]) -> bool {
    let Ok(key) = salty::PublicKey::try_from(pk) else { return false };
    key.verify(msg, &salty::Signature::from(sig)).is_ok()
}

#[cfg(all(not(feature = "v-salty"), any(feature = "v-compact", feature = "v-compact-size")))]
fn crate_verify(msg: &[u8], sig: &[u8; 64], pk: &[u8; 32]) -> bool {
    ed25519_compact::PublicKey::new(*pk).verify(msg, &ed25519_compact::Signature::new(*sig)).is_ok()
}

#[cfg(all(not(feature = "v-salty"), not(feature = "v-compact"), not(feature = "v-compact-size"), feature = "v-dalek"))]
fn crate_verify(msg: &[u8], sig: &[u8; 64], pk: &[u8; 32]) -> bool {
    use ed25519_dalek::Verifier as _;
    let Ok(key) = ed25519_dalek::VerifyingKey::from_bytes(pk) else { return false };
    key.verify(msg, &ed25519_dalek::Signature::from_bytes(sig)).is_ok()
}

#[cfg(not(any(feature = "v-salty", feature = "v-compact-size", feature = "v-compact", feature = "v-dalek")))]
fn crate_verify(msg: &[u8], sig: &[u8; 64], pk: &[u8; 32]) -> bool {
    black_box((msg, sig, pk));
    false
}

/// A line of text on UART0, built without `core::fmt`.
struct Line {
    buf: [u8; 160],
    len: usize,
}

impl Line {
    fn new() -> Line {
        Line { buf: [0; 160], len: 0 }
    }
    fn s(&mut self, s: &str) -> &mut Line {
        for &b in s.as_bytes() {
            if let Some(d) = self.buf.get_mut(self.len) {
                *d = b;
                self.len += 1;
            }
        }
        self
    }
    fn n(&mut self, mut v: u32) -> &mut Line {
        let mut digits = [0u8; 10];
        let mut i = digits.len();
        loop {
            i -= 1;
            if let Some(d) = digits.get_mut(i) {
                *d = b'0' + (v % 10) as u8;
            }
            v /= 10;
            if v == 0 || i == 0 {
                break;
            }
        }
        for &b in digits.get(i..).unwrap_or(&[]) {
            if let Some(d) = self.buf.get_mut(self.len) {
                *d = b;
                self.len += 1;
            }
        }
        self
    }
    fn send(&self, uart: &mut CmsdkUart) {
        let _ = uart.write_all(self.buf.get(..self.len).unwrap_or(&[]));
        let _ = uart.write_all(b"\n");
    }
}

/// SysTick ticks of `f`.
#[inline(never)]
fn ticks(f: impl FnOnce()) -> u32 {
    let t0 = systick_now();
    f();
    systick_elapsed(t0, systick_now())
}

/// The RFC 8032 vectors: (vectors passed, checks failed).
fn check_vectors(uart: &mut CmsdkUart) -> u32 {
    let mut failed = 0;
    for (i, (pk, msg, sig)) in VECTORS.iter().enumerate() {
        let good = verify(msg, sig, pk);
        let mut flipped = *sig;
        if let Some(b) = flipped.get_mut(i * 7 + 3) {
            *b ^= 0x10;
        }
        let flipped_refused = !verify(msg, &flipped, pk);
        let mut longer = [0u8; 65];
        let n = msg.len().min(64);
        if let (Some(d), Some(s)) = (longer.get_mut(..n), msg.get(..n)) {
            d.copy_from_slice(s);
        }
        let longer_refused = !verify(longer.get(..n + 1).unwrap_or(&[]), sig, pk);
        let s_l_refused = !verify(msg, &s_plus_l(sig), pk);
        let ok = good && flipped_refused && longer_refused && s_l_refused;
        failed += u32::from(!ok);
        Line::new()
            .s("vector test=")
            .n(i as u32 + 1)
            .s(" verifies=")
            .n(good as u32)
            .s(" flipped_refused=")
            .n(flipped_refused as u32)
            .s(" longer_refused=")
            .n(longer_refused as u32)
            .s(" s_plus_l_refused=")
            .n(s_l_refused as u32)
            .send(uart);
    }
    failed
}

#[entry]
fn main() -> ! {
    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
    let Some(mut cp) = cortex_m::Peripherals::take() else { exit_failure() };
    systick_start(&mut cp.SYST);
    Line::new().s("verifier name=").s(NAME).send(&mut uart);
    let t = ticks(|| known_loop(CALIB_ITERS));
    Line::new().s("calib insns=").n(2 * CALIB_ITERS).s(" ticks=").n(t).send(&mut uart);

    let failed = check_vectors(&mut uart);

    // The timed verification: the bench's signed model (message, then its 64-byte signature),
    // else the SHA(abc) vector.
    let (msg, sig, pk) = match SIGNED.len().checked_sub(64).and_then(|n| SIGNED.split_at_checked(n)) {
        Some((msg, sig)) if !msg.is_empty() => match <[u8; 64]>::try_from(sig) {
            Ok(s) => (msg, s, *SIGNER),
            Err(_) => exit_failure(),
        },
        _ => match VECTORS.get(3) {
            Some(&(pk, msg, sig)) => (msg, sig, pk),
            None => exit_failure(),
        },
    };
    stack::repaint();
    let before = stack::peak_bytes();
    let mut ok = false;
    let t_empty = ticks(|| ok = black_box(black_box(&sig).len() == 64));
    let t_verify = ticks(|| ok = verify(black_box(msg), black_box(&sig), black_box(&pk)));
    let peak = stack::peak_bytes();
    Line::new()
        .s("verify bytes=")
        .n(msg.len() as u32 + 64)
        .s(" ok=")
        .n(ok as u32)
        .s(" ticks=")
        .n(t_verify.saturating_sub(t_empty))
        .s(" stack_before=")
        .n(before)
        .s(" stack_peak=")
        .n(peak)
        .send(&mut uart);
    Line::new().s("done failed=").n(failed).send(&mut uart);
    if failed == 0 || NAME == "none" {
        exit_success()
    } else {
        exit_failure()
    }
}
