//! Host tests of the device logic: the same code as on the Cortex-M4F, driven through in-memory
//! streams, the real host link client and a recording alarm pin.

extern crate std;

use std::collections::VecDeque;
use std::format;
use std::vec::Vec;

use embedded_hal::digital::{ErrorType, OutputPin};
use embedded_storage::nor_flash::{check_erase, check_read, check_write, NorFlashErrorKind, ReadNorFlash};
use fbg_link::{LinkClient, LinkError};
use fbg_shared::layout::paper::N_MEMORY;
use fbg_shared::protocol::{crc32, encode_host, RejectReason, MAX_CHUNK};
use fbg_shared::signature::{key_id, SignFlags, TrailerHead, TRAILER_V2_LEN};
use fbg_shared::{blob, Centre, Flags, MemoryBank, ModelParams};

use super::*;

const K: usize = 32;
const STAGE: usize = blob::max_len(K) + TRAILER_V2_LEN;

/// The staging slot of the test devices: 8-byte flash words, 1 KiB erase units (the board's
/// are 4 and 4 KiB; other granularities are tested on [`Staging`] directly).
type Slot = Nor<8, 1024>;

/// The test lab's key pair (seed fixed here; the QEMU tests use the committed test key).
fn lab() -> ed25519_compact::KeyPair {
    ed25519_compact::KeyPair::from_seed(ed25519_compact::Seed::new([0x5a; 32]))
}

/// Another key pair, trusted by nobody.
fn stranger() -> ed25519_compact::KeyPair {
    ed25519_compact::KeyPair::from_seed(ed25519_compact::Seed::new([0x77; 32]))
}

fn trusted(kp: &ed25519_compact::KeyPair) -> TrustedKey {
    let public: [u8; 32] = *kp.pk;
    TrustedKey { id: key_id(&public), public }
}

/// The policy of the test devices: the lab's key, rollback allowed when signed so.
fn policy() -> Policy {
    static KEYS: std::sync::OnceLock<[TrustedKey; 1]> = std::sync::OnceLock::new();
    Policy { trusted: KEYS.get_or_init(|| [trusted(&lab())]), allow_rollback: true }
}

/// `blob_bytes` signed by `kp` with `serial` and `flags`, as the trainer writes it (a version-1
/// trailer).
fn sign_with(kp: &ed25519_compact::KeyPair, blob_bytes: &[u8], serial: u64, flags: SignFlags) -> Vec<u8> {
    sign_head(kp, blob_bytes, TrailerHead { flags, serial, key_id: trusted(kp).id, replaces: None })
}

/// `blob_bytes` signed by the lab as a rollback to `serial` that may replace `replaces` (a
/// version-2 trailer, as `fbg-trainer sign --allow-rollback --replaces` writes it).
fn sign_rollback(blob_bytes: &[u8], serial: u64, replaces: u64) -> Vec<u8> {
    let head =
        TrailerHead { flags: SignFlags::ALLOW_ROLLBACK, serial, key_id: trusted(&lab()).id, replaces: Some(replaces) };
    sign_head(&lab(), blob_bytes, head)
}

fn sign_head(kp: &ed25519_compact::KeyPair, blob_bytes: &[u8], head: TrailerHead) -> Vec<u8> {
    let mut out = blob_bytes.to_vec();
    out.extend_from_slice(&head.to_bytes());
    let sig = kp.sk.sign(&out, None);
    out.extend_from_slice(&sig[..]);
    out
}

/// `blob_bytes` signed by the lab with `serial`.
fn sign(blob_bytes: &[u8], serial: u64) -> Vec<u8> {
    sign_with(&lab(), blob_bytes, serial, SignFlags::NONE)
}

/// The firmware's embedded default model (a valid K = 32 blob), or the blob named by
/// `FBG_TEST_MODEL` (xtask passes its freshly generated fixture, so these tests follow the
/// current blob format even before `default.fbgm` is re-exported).
static EMBEDDED: &[u8] = include_bytes!("../../model/default.fbgm");

fn default_blob() -> &'static [u8] {
    static CELL: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    CELL.get_or_init(|| match std::env::var_os("FBG_TEST_MODEL") {
        Some(p) => std::fs::read(&p).unwrap_or_else(|e| panic!("FBG_TEST_MODEL {p:?}: {e}")),
        None => EMBEDDED.to_vec(),
    })
}

/// An alarm pin that records every level it was driven to.
#[derive(Default)]
struct Pin {
    levels: Vec<bool>,
}

impl ErrorType for Pin {
    type Error = Infallible;
}

impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.levels.push(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.levels.push(true);
        Ok(())
    }
}

impl Pin {
    fn is_on(&self) -> bool {
        self.levels.last().copied().unwrap_or(false)
    }
}

/// embedded-io writer collecting the device's output.
#[derive(Default)]
struct Tx(Vec<u8>);

impl embedded_io::ErrorType for Tx {
    type Error = Infallible;
}

impl Write for Tx {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// NOR flash in memory for the tests, with the semantics of the real thing: an erase sets
/// whole `E`-byte units to `0xFF`, a write covers whole `W`-byte units and only lands on erased
/// bytes (anything else is an error, as on a part with ECC), and reads go through
/// `ReadNorFlash` or in place. It starts out holding garbage, not erased, so a transfer that
/// forgot to erase fails. `fault` makes the next erase, or the write that covers a given
/// offset, fail.
struct Nor<const W: usize, const E: usize> {
    mem: Vec<u8>,
    fault: core::cell::Cell<Fault>,
    erases: usize,
    writes: usize,
}

/// A flash failure to inject.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fault {
    None,
    Erase,
    WriteAt(usize),
}

impl<const W: usize, const E: usize> Nor<W, E> {
    /// `units` erase units of garbage.
    fn new(units: usize) -> Self {
        let mem = (0..units * E).map(|i| (i as u8).wrapping_mul(37) ^ 0x5A).collect();
        Nor { mem, fault: core::cell::Cell::new(Fault::None), erases: 0, writes: 0 }
    }
    /// Enough units for `len` bytes.
    fn for_len(len: usize) -> Self {
        Self::new(len.div_ceil(E))
    }
}

impl<const W: usize, const E: usize> embedded_storage::nor_flash::ErrorType for Nor<W, E> {
    type Error = NorFlashErrorKind;
}

impl<const W: usize, const E: usize> ReadNorFlash for Nor<W, E> {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), NorFlashErrorKind> {
        check_read(self, offset, bytes.len())?;
        let at = offset as usize;
        bytes.copy_from_slice(&self.mem[at..at + bytes.len()]);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl<const W: usize, const E: usize> NorFlash for Nor<W, E> {
    const WRITE_SIZE: usize = W;
    const ERASE_SIZE: usize = E;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), NorFlashErrorKind> {
        check_erase(self, from, to)?;
        if self.fault.get() == Fault::Erase {
            return Err(NorFlashErrorKind::Other);
        }
        self.mem[from as usize..to as usize].fill(0xFF);
        self.erases += 1;
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), NorFlashErrorKind> {
        check_write(self, offset, bytes.len())?;
        let range = offset as usize..offset as usize + bytes.len();
        if matches!(self.fault.get(), Fault::WriteAt(at) if range.contains(&at)) {
            return Err(NorFlashErrorKind::Other);
        }
        if self.mem[range.clone()].iter().any(|&b| b != 0xFF) {
            return Err(NorFlashErrorKind::Other);
        }
        for (m, &b) in self.mem[range].iter_mut().zip(bytes) {
            *m &= b;
        }
        self.writes += 1;
        Ok(())
    }
}

impl<const W: usize, const E: usize> MappedFlash for Nor<W, E> {
    fn contents(&self) -> &[u8] {
        &self.mem
    }
}

/// A device in memory behind `std::io::{Read, Write}`, so the host's `LinkClient` can drive it.
struct Wire<'d> {
    dev: Device<'d, Pin, &'d mut Slot, K>,
    out: VecDeque<u8>,
}

impl std::io::Write for Wire<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut tx = Tx::default();
        // Deliver in small pieces like a UART would.
        for piece in buf.chunks(5) {
            self.dev.feed(piece, &mut tx).unwrap();
        }
        self.out.extend(tx.0);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Read for Wire<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = buf.len().min(self.out.len());
        for b in buf.iter_mut().take(n) {
            *b = self.out.pop_front().unwrap();
        }
        Ok(n)
    }
}

/// Memory of one device under test, as the firmware lays it out (there in statics; boxed
/// here so that the test threads' stacks stay small).
struct Mem {
    comp: std::boxed::Box<Compensator<f32, K>>,
    reader: std::boxed::Box<FrameReader<HOST_MAX_FRAME>>,
    flash: Slot,
}

impl Mem {
    fn new() -> Self {
        Mem {
            comp: std::boxed::Box::new(unloaded()),
            reader: std::boxed::Box::new(FrameReader::new()),
            flash: Slot::for_len(STAGE),
        }
    }
    /// Boot `blob_bytes` the way the firmware boots its default model.
    fn boot(&mut self, blob_bytes: &[u8]) -> Result<ModelInfo, Rejection> {
        load_blob(&Kernel::LIBRARY, &mut self.comp, blob_bytes)
    }
    fn device(&mut self, info: ModelInfo) -> Device<'_, Pin, &mut Slot, K> {
        Device::new(
            &mut self.comp,
            Kernel::LIBRARY,
            policy(),
            &mut self.reader,
            info,
            Staging::new(&mut self.flash, STAGE),
            Pin::default(),
        )
    }
    fn link(&mut self, blob_bytes: &[u8]) -> LinkClient<Wire<'_>> {
        let info = self.boot(blob_bytes).unwrap();
        LinkClient::new(Wire { dev: self.device(info), out: VecDeque::new() })
    }
}

fn params(bytes: &[u8]) -> ModelParams<f32, K> {
    blob::decode::<K>(bytes).unwrap()
}

fn encode(p: &ModelParams<f32, K>) -> Vec<u8> {
    let mut buf = std::vec![0u8; STAGE];
    let n = blob::encode(p, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// Centres of the default model.
fn n_default() -> u16 {
    params(default_blob()).centres.len() as u16
}

/// `p` with exactly `n` centres: its own, then copies of them (or of a centre at the origin
/// when it has none) shifted a little, so that the model stays valid.
fn with_centres(mut p: ModelParams<f32, K>, n: usize) -> ModelParams<f32, K> {
    p.centres.truncate(n);
    let base: Vec<Centre<f32>> = if p.centres.is_empty() { std::vec![Centre::default()] } else { p.centres.to_vec() };
    let mut i = 0;
    while p.centres.len() < n {
        let mut c = base[i % base.len()];
        for m in c.mu.iter_mut() {
            *m += 0.01 * (i + 1) as f32;
        }
        p.centres.push(c).unwrap();
        i += 1;
    }
    p
}

/// The default model with every memory operator of the bank on (grating high-passes at six
/// time constants, ambient at four, three plays, the drift observer on the stage-1 T row) and
/// a small Γ on every term: the device's memory bank in full, whatever the trainer chose.
fn memory_model() -> Vec<u8> {
    let b = fbg_testkit::installation::with_full_memory(default_blob()).unwrap();
    let p = params(&b);
    assert!(p.memory.any() && (0..N_MEMORY).all(|k| p.memory.term_active(&p.dims, k)));
    b
}

/// `samples(n)` on an irregular clock: 60 s steps, some 17 s and 95 s steps, a repeated time
/// stamp and a 6 h gap, so that the memory bank recomputes its smoothing factors.
fn timed_samples(n: usize) -> Vec<Sample<f32>> {
    let mut t = 1.0e5f32;
    samples(n)
        .into_iter()
        .enumerate()
        .map(|(i, mut s)| {
            t += match i % 37 {
                _ if i == n / 2 => 6.0 * 3600.0,
                5 => 17.0,
                11 => 95.0,
                23 => 0.0,
                _ => 60.0,
            };
            s.t_s = t;
            s
        })
        .collect()
}

/// A second valid model: the default with other residual weights and intercepts.
fn other_model() -> Vec<u8> {
    let mut p = params(default_blob());
    for c in p.centres.iter_mut() {
        c.w = [c.w[0] * -2.0 + 0.01, c.w[1] + 1.0, c.w[2] * 0.5, 0.0];
    }
    p.poly[0][0] += 0.25;
    encode(&p)
}

/// Samples along a smooth path with turning points, inside the default model's envelope.
fn samples(n: usize) -> Vec<Sample<f32>> {
    let p = params(default_blob());
    (0..n)
        .map(|i| {
            let x = i as f32;
            let mid = |d: usize| 0.5 * (p.envelope_lo[d] + p.envelope_hi[d]);
            let half = |d: usize| 0.25 * (p.envelope_hi[d] - p.envelope_lo[d]);
            Sample::new(
                [
                    mid(0) + half(0) * (x / 9.0).sin(),
                    mid(1) + half(1) * (x / 13.0).sin(),
                    mid(2) + half(2) * (x / 7.0).cos(),
                ],
                mid(3) + half(3) * (x / 11.0).sin(),
                60.0 * x,
            )
        })
        .collect()
}

/// Run `samples` through the link and through a local compensator; they must agree exactly
/// (same code, same f32 arithmetic).
fn assert_serves(link: &mut LinkClient<Wire<'_>>, reference: &mut Compensator<f32, K>, s: &[Sample<f32>], seq0: u32) {
    for (i, x) in s.iter().enumerate() {
        let got = link.compensate(seq0 + i as u32, x).unwrap();
        let want = reference.step(x);
        assert_eq!(format!("{:?}", got.values), format!("{:?}", want.values), "sample {i}");
        assert_eq!(format!("{:?}", got.band), format!("{:?}", want.band95), "sample {i}");
        assert_eq!(got.flags, want.flags, "sample {i}");
    }
}

#[test]
fn boots_answers_pings_and_compensates_like_the_library() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    link.ping(7).unwrap();
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut reference, &samples(50), 0);
    let st = link.status().unwrap();
    assert_eq!(st.samples, 50);
    assert_eq!(st.frames_ok, 52);
    assert_eq!(st.frames_malformed, 0);
    assert_eq!(st.model_centres, n_default());
    assert_eq!(st.model_capacity, K as u16);
    assert_eq!(st.model_crc, blob::stored_crc(default_blob()).unwrap());
    assert_eq!(st.last_rejection, None);
}

#[test]
fn the_alarm_follows_the_flags() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let good = samples(1)[0];
    // Booted without a clock, a model whose band grows does not know the band's lead: said by
    // a flag that is no fault, so the alarm stays off.
    let p = params(default_blob());
    let e = link.compensate(0, &good).unwrap();
    assert!(!e.flags.is_fault());
    assert_eq!(e.flags.contains(Flags::LEAD_UNKNOWN), p.resid_var_growth.iter().any(|&q| q > 0.0));
    assert!(!link.get_ref().dev.alarm().is_on());
    // With the stream's start time (an hour after calibration ended) the lead is known.
    let start = p.field.cal_end_unix_s.unwrap() + 3600.0;
    let clock = fbg_shared::StreamClock::StartUnix(start);
    assert_eq!(link.request(&HostMsg::ResetStream { nonce: 9, clock }).unwrap(), DeviceMsg::Pong { nonce: 9 });
    assert!(link.compensate(0, &good).unwrap().flags.is_ok());
    assert!(!link.get_ref().dev.alarm().is_on());
    let mut nan = good;
    nan.dl_pm[1] = f32::NAN;
    let e = link.compensate(1, &nan).unwrap();
    assert_eq!(e.flags, Flags::NON_FINITE);
    assert!(link.get_ref().dev.alarm().is_on());
    let mut far = good;
    far.t_amb_c = 1.0e4;
    assert!(link.compensate(2, &far).unwrap().flags.contains(Flags::OUT_OF_ENVELOPE));
    assert!(link.get_ref().dev.alarm().is_on());
    assert!(link.compensate(3, &good).unwrap().flags.is_ok());
    assert!(!link.get_ref().dev.alarm().is_on());
}

#[test]
fn garbage_is_counted_and_the_device_keeps_serving() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut damaged = {
        let mut buf = [0u8; 64];
        encode_host(&HostMsg::Ping { nonce: 1 }, &mut buf).unwrap().to_vec()
    };
    damaged[2] ^= 0x40; // a flipped bit: CRC mismatch
    let mut garbage = std::vec![0x01, 0x02, 0xFF, 0x00]; // 1 framing error
    garbage.extend(std::vec![0x11; 1000]); // 1 oversize frame
    garbage.push(0);
    garbage.extend(&damaged); // 1 CRC error
    garbage.extend([0, 0, 0]); // idle fill: not counted
    link.send_raw(&garbage).unwrap();
    link.ping(99).unwrap();
    let st = link.status().unwrap();
    assert_eq!(st.frames_malformed, 3);
    assert_eq!(st.frames_ok, 2);
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut reference, &samples(5), 0);
}

#[test]
fn a_valid_update_swaps_the_model_and_resets_the_stream() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = samples(40);
    let mut old = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut old, &s[..20], 0);
    let b = other_model();
    let r = link.update_model(&sign(&b, 1)).unwrap();
    assert_eq!(r, UpdateResult::Accepted { centres: n_default(), crc: blob::stored_crc(&b).unwrap() });
    let mut new = Compensator::<f32, K>::new(&params(&b)).unwrap();
    assert_serves(&mut link, &mut new, &s[20..], 20);
    // And the answers did change.
    let mut old_again = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let mut new_again = Compensator::<f32, K>::new(&params(&b)).unwrap();
    let differ = s.iter().any(|x| old_again.step(x).values != new_again.step(x).values);
    assert!(differ);
    let st = link.status().unwrap();
    assert_eq!((st.updates_accepted, st.updates_rejected), (1, 0));
    assert_eq!(st.model_crc, blob::stored_crc(&b).unwrap());
    assert_eq!((st.model_serial, st.model_key_id), (1, Some(trusted(&lab()).id)));
}

#[test]
fn bad_updates_are_rejected_with_the_reason_and_the_old_model_keeps_answering() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let s = samples(100);
    let good = other_model();

    let mut corrupt = good.clone();
    corrupt[100] ^= 0x10;
    // `encode` refuses invalid params, so patch a NaN into σ (header, output kinds 2 B each,
    // feature-set tag 1 B, σ_mult 4 B, then σ) and re-sign the blob.
    let mut nan_sigma = good.clone();
    let at = blob::HEADER_LEN + 6 + 1 + 4;
    nan_sigma[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let n = nan_sigma.len();
    let c = crc32(&nan_sigma[..n - 4]).to_le_bytes();
    nan_sigma[n - 4..].copy_from_slice(&c);
    let mut bad_version = good.clone();
    bad_version[4] = 9;
    // Nine gratings in the header (CRC recomputed): beyond the capacity of eight.
    let mut nine = good.clone();
    nine[6] = 9;
    let n = nine.len();
    let c = crc32(&nine[..n - 4]).to_le_bytes();
    nine[n - 4..].copy_from_slice(&c);
    let mut too_many = params(default_blob());
    too_many.centres.truncate(20);
    let small = encode(&too_many); // a valid, shorter model to cut short
    let cases: Vec<(&str, Vec<u8>, RejectReason)> = std::vec![
        ("corrupt byte", corrupt, RejectReason::BadCrc),
        ("bad version", bad_version, RejectReason::UnsupportedVersion),
        ("nan sigma", nan_sigma, RejectReason::BadParameter),
        ("nine gratings", nine, RejectReason::OverCapacity),
        ("truncated", small[..200].to_vec(), RejectReason::Truncated),
        ("not a blob", std::vec![0x42; 300], RejectReason::BadMagic),
        ("too large", std::vec![0; STAGE + 1], RejectReason::TooLarge),
    ];
    let mut rejected = 0;
    for (i, (name, bytes, reason)) in cases.iter().enumerate() {
        // Signed as they are: the signature holds, the blob inside does not.
        let bytes = if *reason == RejectReason::TooLarge { bytes.clone() } else { sign(bytes, 1) };
        let r = link.update_model(&bytes).unwrap();
        match r {
            UpdateResult::Rejected(rej) => {
                assert_eq!(rej.reason, *reason, "{name}: {rej}");
                if *reason == RejectReason::OverCapacity {
                    // The model's count and the capacity, both named.
                    assert_eq!(rej.detail, 9 << 16 | 8, "{name}");
                }
            }
            other => panic!("{name}: {other:?}"),
        }
        rejected += 1;
        let st = link.status().unwrap();
        assert_eq!(st.updates_rejected, rejected, "{name}");
        assert_eq!(st.model_crc, blob::stored_crc(default_blob()).unwrap(), "{name}: old model still active");
        assert_serves(&mut link, &mut reference, &s[i * 10..i * 10 + 10], i as u32 * 10);
    }

    // Transfer-level errors.
    let good = sign(&good, 1);
    let crc = crc32(&good);
    let r = link.update_model_with(&good, crc ^ 1, MAX_CHUNK).unwrap();
    assert_eq!(r, UpdateResult::Rejected(Rejection::new(RejectReason::TransferCrc)));
    let r = link.request(&HostMsg::ModelChunk { offset: 0, data: &[1, 2, 3] }).unwrap();
    assert_eq!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection::new(RejectReason::NoUpdateInProgress))));
    let r = link.request(&HostMsg::ModelCommit).unwrap();
    assert_eq!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection::new(RejectReason::NoUpdateInProgress))));
    let total_len = good.len() as u32;
    assert_eq!(
        link.request(&HostMsg::ModelBegin { total_len, crc32: crc }).unwrap(),
        DeviceMsg::UpdateProgress { received: 0 }
    );
    let r = link.request(&HostMsg::ModelChunk { offset: 5, data: &good[5..10] }).unwrap();
    assert_eq!(
        r,
        DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::OutOfOrder, detail: 0 }))
    );
    link.request(&HostMsg::ModelBegin { total_len: 24, crc32: crc }).unwrap();
    let r = link.request(&HostMsg::ModelChunk { offset: 0, data: &good[..30] }).unwrap();
    assert!(matches!(
        r,
        DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::Overrun, .. }))
    ));
    link.request(&HostMsg::ModelBegin { total_len, crc32: crc }).unwrap();
    link.request(&HostMsg::ModelChunk { offset: 0, data: &good[..100] }).unwrap();
    let r = link.request(&HostMsg::ModelCommit).unwrap();
    assert_eq!(
        r,
        DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::Incomplete, detail: 100 }))
    );

    assert_serves(&mut link, &mut reference, &s[70..], 70);
    let st = link.status().unwrap();
    assert_eq!(st.updates_accepted, 0);
    assert_eq!(st.last_rejection.map(|r| r.reason), Some(RejectReason::Incomplete));

    // Finally a good one still goes through.
    assert!(matches!(link.update_model(&good).unwrap(), UpdateResult::Accepted { .. }));
}

#[test]
fn a_model_beyond_the_capacity_is_refused() {
    // A device built for 16 centres refuses a 32-centre model.
    let b32 = encode(&with_centres(params(default_blob()), 32));
    let mut comp = std::boxed::Box::new(unloaded::<16>());
    let e = load_blob(&Kernel::LIBRARY, &mut comp, &b32).err().unwrap();
    assert_eq!(e.reason, RejectReason::WrongDims);
    assert_eq!(e.detail, 32 << 16 | 16);
    assert_eq!(comp.n_centres(), 0, "still unloaded");
}

#[test]
fn an_unloaded_compensator_is_usable() {
    // All-zero bytes: no centres, no output fitted, latches that have seen nothing.
    let mut comp = std::boxed::Box::new(unloaded::<K>());
    assert_eq!(comp.n_centres(), 0);
    assert_eq!(comp.state().latch_values(), [0.0; 8]);
    // No model: no output, and every sample (its gratings are not the model's none) is
    // answered as non-finite.
    let e = comp.step(&samples(1)[0]);
    assert!(e.values().is_empty() && e.band().is_empty(), "{e:?}");
    assert_eq!(e.flags, fbg_shared::Flags::NON_FINITE, "{e:?}");
    // Loading into it gives exactly `Compensator::new`.
    let info = load_blob(&Kernel::LIBRARY, &mut comp, default_blob()).unwrap();
    assert_eq!(
        info,
        ModelInfo { centres: n_default(), crc: blob::stored_crc(default_blob()).unwrap(), serial: 0, key_id: None }
    );
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    for x in samples(30) {
        assert_eq!(format!("{:?}", comp.step(&x)), format!("{:?}", reference.step(&x)));
    }
}

#[test]
fn serving_goes_on_across_updates_and_a_partial_frame_does_not_survive_a_new_device() {
    // Updates do not disturb the frame reader: pings before, between and after them.
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    link.ping(3).unwrap();
    assert!(matches!(link.update_model(&sign(&other_model(), 1)).unwrap(), UpdateResult::Accepted { .. }));
    link.ping(4).unwrap();
    assert!(matches!(link.update_model(&sign(default_blob(), 2)).unwrap(), UpdateResult::Accepted { .. }));
    link.ping(5).unwrap();
    assert_eq!(link.status().unwrap().frames_malformed, 0);
    drop(link);
    // A reader left inside a frame is reset when a device starts serving with it.
    let mut buf = [0u8; 64];
    let ping = encode_host(&HostMsg::Ping { nonce: 9 }, &mut buf).unwrap().to_vec();
    let (ev, _) = mem.reader.feed::<HostMsg<'_>>(&ping[..3]);
    assert_eq!(ev, Feed::Pending);
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    let mut tx = Tx::default();
    dev.feed(&ping, &mut tx).unwrap();
    assert_eq!(dev.status().frames_malformed, 0);
    assert_eq!(dev.status().frames_ok, 1);
}

#[test]
fn a_failed_load_keeps_the_old_model_and_its_stream_state() {
    let mut mem = Mem::new();
    let info = mem.boot(default_blob()).unwrap();
    let s = samples(40);
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    for x in &s[..20] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
    // A blob that parses but does not fold (σ so small that the f32 folding overflows) and one
    // that does not parse: both leave the model and the latches as they were.
    let mut p = params(other_model().as_slice());
    p.hyper.sigma = 1e-38;
    let tiny_sigma = encode(&p);
    let mut corrupt = other_model();
    corrupt[50] ^= 1;
    for bad in [tiny_sigma, corrupt] {
        let before = mem.comp.state().latch_values();
        assert!(load(&Kernel::LIBRARY, &mut mem.comp, &bad).is_err());
        assert_eq!(mem.comp.state().latch_values(), before);
    }
    for x in &s[20..] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
    let _ = info;
}

#[test]
fn a_link_error_ends_serve() {
    struct Script {
        input: VecDeque<u8>,
        out: Vec<u8>,
    }
    #[derive(Debug)]
    struct End;
    impl core::fmt::Display for End {
        fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            f.write_str("end")
        }
    }
    impl core::error::Error for End {}
    impl embedded_io::Error for End {
        fn kind(&self) -> embedded_io::ErrorKind {
            embedded_io::ErrorKind::BrokenPipe
        }
    }
    impl embedded_io::ErrorType for Script {
        type Error = End;
    }
    impl Read for Script {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, End> {
            if self.input.is_empty() {
                return Err(End);
            }
            let n = buf.len().min(self.input.len()).min(3);
            for b in buf.iter_mut().take(n) {
                *b = self.input.pop_front().unwrap();
            }
            Ok(n)
        }
    }
    impl Write for Script {
        fn write(&mut self, buf: &[u8]) -> Result<usize, End> {
            self.out.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> Result<(), End> {
            Ok(())
        }
    }
    let mut buf = [0u8; 64];
    let ping = encode_host(&HostMsg::Ping { nonce: 5 }, &mut buf).unwrap().to_vec();
    let mut mem = Mem::new();
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    dev.set_stack_probe(|| 1234, 4321);
    let mut script = Script { input: ping.iter().copied().chain(ping.iter().copied()).collect(), out: Vec::new() };
    assert!(dev.serve(&mut script).is_err());
    let mut r = FrameReader::<DEVICE_MAX_FRAME>::new();
    let mut w = &script.out[..];
    let mut pongs = 0;
    while !w.is_empty() {
        let (ev, rest) = r.feed::<DeviceMsg>(w);
        w = rest;
        if ev == Feed::Message(DeviceMsg::Pong { nonce: 5 }) {
            pongs += 1;
        }
    }
    assert_eq!(pongs, 2);
    assert_eq!(dev.status().stack_peak_bytes, 1234);
    assert_eq!(dev.status().stack_boot_bytes, 4321);
    let _: Option<LinkError> = None;
}

#[test]
fn a_zeroed_memory_bank_is_the_default_one() {
    // The bank of an unloaded compensator (`MemoryBank::off`) is all zero bytes, which is what
    // keeps the firmware's static compensator in `.bss`.
    // SAFETY: every field of the bank is a float, an integer or a bool, all valid as zeros.
    let zeroed: MemoryBank<f32> = unsafe { core::mem::MaybeUninit::zeroed().assume_init() };
    assert_eq!(zeroed, MemoryBank::off());
    assert_eq!(zeroed, MemoryBank::default());
    assert!(!zeroed.is_active());
    assert_eq!(zeroed.state(), fbg_shared::MemoryState::new());
}

#[test]
fn a_memory_model_is_served_like_the_library_across_gaps_resets_and_updates() {
    let mem_blob = memory_model();
    let s = timed_samples(400);
    // Booted with the memory model.
    let mut mem = Mem::new();
    let mut link = mem.link(&mem_blob);
    let mut reference = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    assert!(reference.has_memory());
    assert_serves(&mut link, &mut reference, &s[..250], 0);
    // ResetStream forgets the memory (and the latches), on the device as in the library.
    assert_eq!(
        link.request(&HostMsg::ResetStream { nonce: 4, clock: fbg_shared::StreamClock::Unknown }).unwrap(),
        DeviceMsg::Pong { nonce: 4 }
    );
    reference.reset();
    assert_serves(&mut link, &mut reference, &s[250..], 250);
    // Swapped in by an update from a model without memory, and back.
    let mut mem2 = Mem::new();
    let mut link2 = mem2.link(default_blob());
    assert!(matches!(link2.update_model(&sign(&mem_blob, 1)).unwrap(), UpdateResult::Accepted { .. }));
    let mut reference2 = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    assert_serves(&mut link2, &mut reference2, &s, 0);
    assert!(matches!(link2.update_model(&sign(default_blob(), 2)).unwrap(), UpdateResult::Accepted { .. }));
    let mut plain = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link2, &mut plain, &s[..50], 400);
    // The memory terms do move the answers.
    let mut a = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    let mut b = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert!(s.iter().any(|x| a.step(x).values != b.step(x).values));
}

#[test]
fn a_failed_load_keeps_the_memory_state() {
    let mem_blob = memory_model();
    let mut mem = Mem::new();
    mem.boot(&mem_blob).unwrap();
    let s = timed_samples(80);
    let mut reference = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    for x in &s[..40] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
    let mut p = params(&mem_blob);
    p.hyper.sigma = 1e-38; // parses, does not fold in f32
    let tiny_sigma = encode(&p);
    let before = *mem.comp.state();
    assert!(load_blob(&Kernel::LIBRARY, &mut mem.comp, &tiny_sigma).is_err());
    assert_eq!(*mem.comp.state(), before);
    for x in &s[40..] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
}

/// The signature check of an update: unsigned, unknown key, tampered after signing and an
/// older serial are each refused with their reason and counted, the old model answering bit for
/// bit as before; a signed update with a serial at least the running one's is accepted; an
/// older one signed to allow the rollback is accepted where the build allows it.
#[test]
fn updates_must_be_signed_by_a_trusted_key_and_not_roll_back() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let st = link.status().unwrap();
    assert_eq!((st.model_serial, st.model_key_id), (0, None), "the embedded default is unsigned");
    let s = samples(120);
    let other = other_model();
    let v5 = sign(&other, 5);
    assert!(matches!(link.update_model(&v5).unwrap(), UpdateResult::Accepted { .. }));
    let mut running = Compensator::<f32, K>::new(&params(&other)).unwrap();
    assert_serves(&mut link, &mut running, &s[..10], 0);

    let mut tampered = v5.clone();
    tampered[blob::HEADER_LEN + 40] ^= 0x04; // one payload bit
    let mut tampered_fixed_crc = tampered.clone();
    let n = other.len();
    let c = crc32(&tampered_fixed_crc[..n - 4]).to_le_bytes();
    tampered_fixed_crc[n - 4..n].copy_from_slice(&c);
    let mut serial_raised = v5.clone();
    serial_raised[n + 8] = 9; // serial 5 -> 9 without re-signing
    let cases: Vec<(&str, Vec<u8>, RejectReason)> = std::vec![
        ("unsigned", default_blob().to_vec(), RejectReason::Unsigned),
        ("unknown key", sign_with(&stranger(), default_blob(), 6, SignFlags::NONE), RejectReason::UnknownKey),
        ("tampered payload bit", tampered, RejectReason::BadSignature),
        ("tampered, CRC made right again", tampered_fixed_crc, RejectReason::BadSignature),
        ("serial raised after signing", serial_raised, RejectReason::BadSignature),
        ("older serial replayed", sign(default_blob(), 4), RejectReason::Rollback),
    ];
    for (i, (name, bytes, reason)) in cases.iter().enumerate() {
        match link.update_model(bytes).unwrap() {
            UpdateResult::Rejected(r) => assert_eq!(r.reason, *reason, "{name}: {r}"),
            other => panic!("{name}: accepted? {other:?}"),
        }
        let st = link.status().unwrap();
        assert_eq!((st.model_crc, st.model_serial), (blob::stored_crc(&other).unwrap(), 5), "{name}");
        let seq = 10 + 10 * i;
        assert_serves(&mut link, &mut running, &s[seq..seq + 10], seq as u32);
    }
    let st = link.status().unwrap();
    assert_eq!(
        st.refused,
        fbg_shared::protocol::Refusals { unsigned: 1, bad_signature: 3, unknown_key: 1, rollback: 1, serial_reused: 0 }
    );
    assert_eq!((st.updates_accepted, st.updates_rejected), (1, 6));
    assert_eq!(st.last_rejection.map(|r| (r.reason, r.detail)), Some((RejectReason::Rollback, 4)));
    let unknown = Rejection::from(SignatureError::UnknownKey { key_id: trusted(&stranger()).id });
    assert_eq!(unknown.reason, RejectReason::UnknownKey);

    // The same serial again (a re-install) and a newer one are accepted.
    assert!(matches!(link.update_model(&sign(&other, 5)).unwrap(), UpdateResult::Accepted { .. }));
    assert!(matches!(link.update_model(&sign(default_blob(), 7)).unwrap(), UpdateResult::Accepted { .. }));
    // A deliberate downgrade, signed as a rollback of serial 7: accepted by a build that allows it.
    let down = sign_rollback(&other, 2, 7);
    assert!(matches!(link.update_model(&down).unwrap(), UpdateResult::Accepted { .. }));
    let st = link.status().unwrap();
    assert_eq!((st.model_serial, st.updates_accepted), (2, 4));
}

/// Send `bytes` as one update to `dev` (frames fed directly) and return the device's answer
/// to the commit.
fn update_direct<F: MappedFlash>(dev: &mut Device<'_, Pin, F, K>, bytes: &[u8]) -> DeviceMsg {
    let mut frame = [0u8; HOST_MAX_FRAME];
    let mut tx = Tx::default();
    let begin = HostMsg::ModelBegin { total_len: bytes.len() as u32, crc32: crc32(bytes) };
    dev.feed(encode_host(&begin, &mut frame).unwrap(), &mut tx).unwrap();
    for (k, chunk) in bytes.chunks(MAX_CHUNK).enumerate() {
        let msg = HostMsg::ModelChunk { offset: (k * MAX_CHUNK) as u32, data: chunk };
        dev.feed(encode_host(&msg, &mut frame).unwrap(), &mut tx).unwrap();
    }
    dev.handle(&HostMsg::ModelCommit)
}

fn reason(m: &DeviceMsg) -> Option<RejectReason> {
    match m {
        DeviceMsg::UpdateResult(UpdateResult::Rejected(r)) => Some(r.reason),
        _ => None,
    }
}

/// Issue 28, item 3: a rollback names the serial it replaces and is accepted only while that
/// serial runs: no replay after the device moved on (the serial-2 blob after serial 9),
/// none of the same blob twice, no swapping of two models signed with one serial, nothing on a
/// build without rollback, and a version-1 allow-rollback flag grants nothing.
#[test]
fn a_rollback_is_bounded_to_the_serial_it_replaces() {
    let other = other_model();
    let def = default_blob();
    let crc = |b: &[u8]| blob::stored_crc(b).unwrap();
    let run = |serial: u64, b: &[u8]| ModelInfo { serial, crc: crc(b), centres: 0, key_id: None };
    let p = policy();
    let strict = Policy { allow_rollback: false, ..policy() };
    let refused = |policy: &Policy, bytes: &[u8], running: ModelInfo| {
        authenticate(policy, bytes, Some(&running)).map(|(_, s)| s.serial).map_err(|r| r.reason)
    };
    let back = sign_rollback(def, 2, 5);
    // Accepted exactly while serial 5 runs, whatever model that is.
    assert_eq!(refused(&p, &back, run(5, &other)), Ok(2));
    assert_eq!(refused(&p, &back, run(5, def)), Ok(2));
    for running in [9, 6, 4, 3, 2, 0] {
        let got = refused(&p, &back, run(running, &other));
        assert_eq!(got, Err(RejectReason::RollbackNotPermitted), "running serial {running}");
    }
    // Once applied, the device runs serial 2: the same blob again is refused (no replay).
    assert_eq!(refused(&p, &back, run(2, def)), Err(RejectReason::RollbackNotPermitted));
    // A build without rollback refuses it even over serial 5.
    assert_eq!(refused(&strict, &back, run(5, &other)), Err(RejectReason::RollbackNotPermitted));
    let e = authenticate(&strict, &back, Some(&run(5, &other))).unwrap_err();
    assert_eq!(e.detail, 5, "the detail names the serial it may replace");
    // A version-1 allow-rollback flag (older signers): judged as an ordinary update.
    let v1 = sign_with(&lab(), def, 2, SignFlags::ALLOW_ROLLBACK);
    assert_eq!(refused(&p, &v1, run(9, &other)), Err(RejectReason::Rollback));
    assert_eq!(refused(&p, &v1, run(1, &other)), Ok(2));
    // One serial, two models: the running one again is a re-install, the other is refused.
    let a5 = sign(&other, 5);
    let b5 = sign(def, 5);
    assert_eq!(refused(&p, &a5, run(5, &other)), Ok(5));
    assert_eq!(refused(&p, &b5, run(5, &other)), Err(RejectReason::SerialReused));
    assert_eq!(refused(&p, &a5, run(5, def)), Err(RejectReason::SerialReused));
    let e = authenticate(&p, &b5, Some(&run(5, &other))).unwrap_err();
    assert_eq!(e, Rejection { reason: RejectReason::SerialReused, detail: 5 });
    // A rollback that names its own serial is no way around it either.
    assert_eq!(refused(&p, &sign_rollback(def, 5, 5), run(5, &other)), Err(RejectReason::SerialReused));
    // At boot (nothing running) only the signature counts.
    assert_eq!(authenticate(&p, &back, None).map(|(_, s)| s.serial), Ok(2));

    // Through the device: the sequence, counted by reason.
    let mut mem = Mem::new();
    let info = mem.boot(def).unwrap();
    let mut dev = mem.device(info);
    let ok = |m: &DeviceMsg| matches!(m, DeviceMsg::UpdateResult(UpdateResult::Accepted { .. }));
    assert!(ok(&update_direct(&mut dev, &sign(&other, 5))));
    assert_eq!(reason(&update_direct(&mut dev, &b5)), Some(RejectReason::SerialReused), "swap");
    assert!(ok(&update_direct(&mut dev, &back)), "bounded rollback over serial 5");
    assert_eq!(dev.model().serial, 2);
    assert_eq!(reason(&update_direct(&mut dev, &back)), Some(RejectReason::RollbackNotPermitted), "replayed");
    assert!(ok(&update_direct(&mut dev, &sign(&other, 9))));
    assert_eq!(reason(&update_direct(&mut dev, &back)), Some(RejectReason::RollbackNotPermitted), "after 9");
    assert_eq!(reason(&update_direct(&mut dev, &sign(def, 2))), Some(RejectReason::Rollback));
    let st = dev.status();
    assert_eq!((st.model_serial, st.model_crc), (9, crc(&other)));
    assert_eq!((st.refused.rollback, st.refused.serial_reused, st.updates_accepted), (3, 1, 3));
}

/// A build that does not accept rollbacks (the firmware's default) refuses one even over the
/// serial it names.
#[test]
fn a_build_without_rollback_refuses_every_rollback() {
    let mut mem = Mem::new();
    let other = other_model();
    let strict = Policy { allow_rollback: false, ..policy() };
    let info = ModelInfo { serial: 7, ..mem.boot(default_blob()).unwrap() };
    let staging = Staging::new(&mut mem.flash, STAGE);
    let mut dev = Device::new(&mut mem.comp, Kernel::LIBRARY, strict, &mut mem.reader, info, staging, Pin::default());
    let r = update_direct(&mut dev, &sign_rollback(&other, 2, 7));
    assert_eq!(reason(&r), Some(RejectReason::RollbackNotPermitted));
    assert_eq!(dev.status().refused.rollback, 1);
    assert_eq!(dev.status().model_serial, 7);
}

/// Issue 28, item 6: `ModelBegin` erases only a slot that is not blank, so 1 000 begins cost
/// one erase (the slot starts with garbage); the erases are counted in `Status`; and the link
/// alone cannot erase more than the budget between accepted updates.
#[test]
fn begins_erase_only_a_written_slot_and_within_the_budget() {
    let mut mem = Mem::new();
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    let good = sign(&other_model(), 1);
    let mut frame = [0u8; HOST_MAX_FRAME];
    let mut tx = Tx::default();
    let begin = HostMsg::ModelBegin { total_len: good.len() as u32, crc32: crc32(&good) };
    let begin = encode_host(&begin, &mut frame).unwrap().to_vec();
    for _ in 0..1000 {
        dev.feed(&begin, &mut tx).unwrap();
    }
    assert_eq!(dev.staging().flash().erases, 1, "1 000 begins, one erase (the slot held garbage)");
    assert_eq!(dev.status().staging_erases, 1);
    assert_eq!(dev.status().updates_rejected, 0);
    // Data written, then begun again: one more erase, once.
    let chunk = HostMsg::ModelChunk { offset: 0, data: &good[..MAX_CHUNK] };
    dev.feed(encode_host(&chunk, &mut frame).unwrap(), &mut tx).unwrap();
    for _ in 0..1000 {
        dev.feed(&begin, &mut tx).unwrap();
    }
    assert_eq!(dev.status().staging_erases, 2);

    // A transfer that writes and is begun again, over and over: erases stop at the budget.
    let mut rounds = 0;
    let last = loop {
        let mut out = Tx::default();
        dev.feed(&begin, &mut out).unwrap();
        let msgs = fbg_shared_frames(&out.0);
        if let Some(DeviceMsg::UpdateResult(UpdateResult::Rejected(r))) = msgs.last() {
            break *r;
        }
        dev.feed(encode_host(&chunk, &mut frame).unwrap(), &mut tx).unwrap();
        rounds += 1;
        assert!(rounds < 100, "never refused");
    };
    assert_eq!(last, Rejection { reason: RejectReason::EraseLimit, detail: staging::ERASE_BUDGET });
    // Every erase since boot counts, the first one (garbage) too.
    assert_eq!(dev.status().staging_erases, staging::ERASE_BUDGET);
    assert_eq!(dev.staging().flash().erases as u32, staging::ERASE_BUDGET);
    // The slot is written, so no whole update can be staged until an accepted update or a
    // restart renews the budget.
    let r = dev.handle(&HostMsg::ModelBegin { total_len: good.len() as u32, crc32: crc32(&good) });
    assert_eq!(reason(&r), Some(RejectReason::EraseLimit));
    assert_eq!(reason(&update_direct(&mut dev, &good)), Some(RejectReason::NoUpdateInProgress));
    drop(dev);
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    let r = update_direct(&mut dev, &good);
    assert!(matches!(r, DeviceMsg::UpdateResult(UpdateResult::Accepted { .. })), "after a restart: {r:?}");
    assert_eq!(dev.status().staging_erases, 1);
}

/// The device messages in `bytes`.
fn fbg_shared_frames(bytes: &[u8]) -> Vec<DeviceMsg> {
    let mut reader = FrameReader::<{ fbg_shared::protocol::DEVICE_MAX_FRAME }>::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        let (ev, r) = reader.feed::<DeviceMsg>(rest);
        rest = r;
        if let Feed::Message(m) = ev {
            out.push(m);
        }
    }
    out
}

/// The embedded default: trusted as part of the image by default (a trailer it carries names
/// its serial and key), or required to be signed by a build option.
#[test]
fn the_embedded_model_is_trusted_or_must_be_signed() {
    let mut mem = Mem::new();
    let info = boot(&Kernel::LIBRARY, &policy(), false, &mut mem.comp, default_blob()).unwrap();
    assert_eq!((info.serial, info.key_id), (0, None));
    let e = boot(&Kernel::LIBRARY, &policy(), true, &mut mem.comp, default_blob()).unwrap_err();
    assert_eq!(e.reason, RejectReason::Unsigned);
    let signed = sign(default_blob(), 3);
    let info = boot(&Kernel::LIBRARY, &policy(), true, &mut mem.comp, &signed).unwrap();
    assert_eq!(
        (info.serial, info.key_id, info.crc),
        (3, Some(trusted(&lab()).id), blob::stored_crc(default_blob()).unwrap())
    );
    let foreign = sign_with(&stranger(), default_blob(), 3, SignFlags::NONE);
    assert_eq!(
        boot(&Kernel::LIBRARY, &policy(), true, &mut mem.comp, &foreign).unwrap_err().reason,
        RejectReason::UnknownKey
    );
    let info = boot(&Kernel::LIBRARY, &policy(), false, &mut mem.comp, &foreign).unwrap();
    assert_eq!(info.serial, 3, "trusted as part of the image, its trailer names it");
}

/// RFC 8032 section 7.1 TEST 1 through the verifier this crate links (fbg-shared's `verify`, the
/// device's code path built for the host; the other vectors are in fbg-shared's tests).
#[test]
fn the_device_verifier_passes_rfc8032_test_1() {
    let hex = |s: &str| -> Vec<u8> {
        (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
    };
    let pk: [u8; 32] = hex("d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a").try_into().unwrap();
    let sig: [u8; 64] = hex("e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b").try_into().unwrap();
    assert_eq!(signature::verify_message(&[], &sig, &pk), Ok(()));
    let mut bad = sig;
    bad[0] ^= 1;
    assert_eq!(signature::verify_message(&[], &bad, &pk), Err(SignatureError::BadSignature));
}

#[test]
fn the_test_flash_behaves_like_nor_flash() {
    let mut f = Nor::<4, 256>::new(2);
    assert_ne!(f.mem[0], 0xFF, "starts with garbage");
    assert_eq!(f.write(0, &[1, 2, 3, 4]), Err(NorFlashErrorKind::Other), "not erased");
    f.erase(0, 256).unwrap();
    assert!(f.mem[..256].iter().all(|&b| b == 0xFF));
    assert!(f.mem[256..].iter().any(|&b| b != 0xFF), "only the erased unit");
    assert_eq!(f.erase(0, 100), Err(NorFlashErrorKind::NotAligned));
    assert_eq!(f.erase(0, 1024), Err(NorFlashErrorKind::OutOfBounds));
    assert_eq!(f.write(2, &[1, 2, 3, 4]), Err(NorFlashErrorKind::NotAligned));
    assert_eq!(f.write(0, &[1, 2, 3]), Err(NorFlashErrorKind::NotAligned));
    f.write(0, &[1, 2, 3, 4]).unwrap();
    assert_eq!(f.write(0, &[1, 2, 3, 4]), Err(NorFlashErrorKind::Other), "written twice");
    let mut back = [0u8; 4];
    f.read(0, &mut back).unwrap();
    assert_eq!(back, [1, 2, 3, 4]);
    assert_eq!(&f.contents()[..4], &[1, 2, 3, 4]);
}

/// Stage `bytes` into a fresh `Nor<W, E>` in chunks of the lengths `sizes` (cycled) and check
/// what the slot holds: the bytes, `0xFF` up to the end of the last write unit, and only the
/// erase units the transfer needs erased.
fn stage_in<const W: usize, const E: usize>(bytes: &[u8], sizes: &[usize]) {
    let mut flash = Nor::<W, E>::for_len(STAGE);
    let garbage = flash.mem.clone();
    {
        let mut st = Staging::new(&mut flash, STAGE);
        st.begin(bytes.len(), crc32(bytes)).unwrap();
        let (mut at, mut i) = (0, 0);
        while at < bytes.len() {
            let n = sizes[i % sizes.len()].min(bytes.len() - at);
            assert_eq!(st.chunk(at as u32, &bytes[at..at + n]), Ok(at + n), "W {W}, chunks {sizes:?}");
            at += n;
            i += 1;
        }
        assert_eq!(st.finish().unwrap(), bytes, "W {W}, chunks {sizes:?}");
    }
    let unit_end = bytes.len().div_ceil(W) * W;
    let erased_end = bytes.len().div_ceil(E) * E;
    assert!(flash.mem[bytes.len()..erased_end].iter().all(|&b| b == 0xFF), "W {W}: padded with the erased value");
    assert_eq!(flash.mem[erased_end..], garbage[erased_end..], "E {E}: the rest of the slot untouched");
    assert_eq!(flash.erases, 1);
    assert!(flash.writes <= unit_end / W, "W {W}: every unit written once at most");
}

#[test]
fn an_update_is_staged_at_the_flash_granularity_whatever_the_chunks() {
    let signed = sign(&other_model(), 1);
    let odd = &signed[..signed.len() - 3];
    for bytes in [&signed[..], odd] {
        for sizes in [&[MAX_CHUNK][..], &[1], &[3, 7, 64], &[5, MAX_CHUNK, 2, 31]] {
            stage_in::<1, 256>(bytes, sizes);
            stage_in::<4, 4096>(bytes, sizes);
            stage_in::<8, 2048>(bytes, sizes);
            stage_in::<32, 128>(bytes, sizes);
        }
    }
}

#[test]
fn staging_refuses_what_does_not_fit_or_comes_out_of_turn() {
    let mut flash = Nor::<4, 256>::new(4);
    let mut st = Staging::new(&mut flash, 5000);
    assert_eq!(st.limit(), 1024, "at most the slot");
    fn r<T>(reason: RejectReason, detail: u32) -> Result<T, Rejection> {
        Err(Rejection { reason, detail })
    }
    assert_eq!(st.begin(1025, 0), r(RejectReason::TooLarge, 1025));
    assert_eq!(st.begin(4, 0), r(RejectReason::Truncated, 4));
    assert_eq!(st.chunk(0, &[1]), r(RejectReason::NoUpdateInProgress, 0));
    const N: usize = 40;
    st.begin(N, crc32(&[7; N])).unwrap();
    assert_eq!(st.chunk(1, &[7]), r(RejectReason::OutOfOrder, 0));
    assert_eq!(st.chunk(0, &[7; 26]), Ok(26));
    assert_eq!(st.chunk(26, &[7; 15]), r(RejectReason::Overrun, 26));
    assert_eq!(st.finish().map(<[u8]>::len), r(RejectReason::Incomplete, 26));
    assert_eq!(st.finish().map(<[u8]>::len), r(RejectReason::NoUpdateInProgress, 0), "the transfer ended");
    // Again from the start: the slot is erased anew, so the bytes written before are no obstacle.
    st.begin(N, crc32(&[7; N]) ^ 1).unwrap();
    assert_eq!(st.chunk(0, &[7; N]), Ok(N));
    assert_eq!(st.finish().map(<[u8]>::len), r(RejectReason::TransferCrc, 0));
    st.begin(N, crc32(&[7; N])).unwrap();
    st.chunk(0, &[7; N]).unwrap();
    assert_eq!(st.finish(), Ok(&[7u8; N][..]));
}

#[test]
fn a_flash_failure_refuses_the_update_and_the_old_model_keeps_serving() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let s = samples(40);
    assert_serves(&mut link, &mut reference, &s[..10], 0);
    let other = other_model();
    let good = sign(&other, 1);
    let inject = |link: &LinkClient<Wire<'_>>, f: Fault| link.get_ref().dev.staging().flash().fault.set(f);

    inject(&link, Fault::Erase);
    let r = link.update_model(&good).unwrap();
    assert_eq!(r, UpdateResult::Rejected(Rejection { reason: RejectReason::Storage, detail: 0 }));
    assert_serves(&mut link, &mut reference, &s[10..20], 10);
    // A write that fails in the third chunk: refused with the offset of the failed write.
    inject(&link, Fault::WriteAt(2 * MAX_CHUNK + 5));
    let r = link.update_model(&good).unwrap();
    assert_eq!(r, UpdateResult::Rejected(Rejection { reason: RejectReason::Storage, detail: (2 * MAX_CHUNK) as u32 }));
    assert_serves(&mut link, &mut reference, &s[20..30], 20);
    let st = link.status().unwrap();
    assert_eq!((st.updates_accepted, st.updates_rejected), (0, 2));
    assert_eq!(st.model_crc, blob::stored_crc(default_blob()).unwrap());
    // The flash works again: the same update goes through.
    inject(&link, Fault::None);
    assert!(matches!(link.update_model(&good).unwrap(), UpdateResult::Accepted { .. }));
    let mut new = Compensator::<f32, K>::new(&params(&other)).unwrap();
    assert_serves(&mut link, &mut new, &s[30..], 30);
}

/// The default model reading T 500 °C high (a wrong zero): every number in range, so it
/// decodes, signs and loads; every estimate is outside T's calibration envelope.
fn wrong_model() -> Vec<u8> {
    let mut p = params(default_blob());
    p.poly[0][0] += 500.0;
    encode(&p)
}

#[test]
fn a_wrong_model_turns_the_alarm_on() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = samples(30);
    let clock = fbg_shared::StreamClock::StartUnix(params(default_blob()).field.cal_end_unix_s.unwrap() + 3600.0);
    assert_eq!(link.request(&HostMsg::ResetStream { nonce: 1, clock }).unwrap(), DeviceMsg::Pong { nonce: 1 });
    for (i, x) in s[..10].iter().enumerate() {
        assert!(link.compensate(i as u32, x).unwrap().flags.is_ok());
        assert!(!link.get_ref().dev.alarm().is_on());
    }
    let wrong = wrong_model();
    assert!(matches!(link.update_model(&sign(&wrong, 1)).unwrap(), UpdateResult::Accepted { .. }));
    let mut reference = Compensator::<f32, K>::new(&params(&wrong)).unwrap();
    reference.set_clock(clock);
    for (i, x) in s[10..20].iter().enumerate() {
        let e = link.compensate(10 + i as u32, x).unwrap();
        assert_eq!(e.flags, Flags::IMPLAUSIBLE, "sample {i}");
        assert_eq!(e.flags, reference.step(x).flags);
        assert!(link.get_ref().dev.alarm().is_on(), "sample {i}");
    }
    // The right model again: the alarm goes off.
    assert!(matches!(link.update_model(&sign(default_blob(), 2)).unwrap(), UpdateResult::Accepted { .. }));
    for (i, x) in s[20..].iter().enumerate() {
        assert!(link.compensate(20 + i as u32, x).unwrap().flags.is_ok());
        assert!(!link.get_ref().dev.alarm().is_on());
    }
}

#[test]
fn an_implausible_update_is_refused_and_the_old_model_keeps_serving() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let s = samples(30);
    // The cases, each with a valid CRC and a valid signature.
    let base = params(default_blob());
    let s1 = base.dims.stage1_len();
    let mut intercept = base.clone();
    intercept.stage1[0][s1 - 1] = 3.4e38;
    let mut variance = base.clone();
    variance.centres[0].v[1] = 3.4e38;
    let mut index = base.clone();
    let outs = [
        fbg_shared::layout::Output::first(fbg_shared::layout::Quantity::Temperature),
        fbg_shared::layout::Output { quantity: fbg_shared::layout::Quantity::Strain, index: 200 },
        fbg_shared::layout::Output::first(fbg_shared::layout::Quantity::Pressure),
    ];
    index.dims = fbg_shared::layout::Dims::new(base.dims.gratings(), base.dims.ambient(), &outs).unwrap();
    for (i, p) in [intercept, variance, index].iter().enumerate() {
        let mut buf = std::vec![0u8; STAGE];
        let n = blob::encode_unchecked(p, &mut buf).unwrap();
        let r = link.update_model(&sign(&buf[..n], 1 + i as u64)).unwrap();
        assert_eq!(r, UpdateResult::Rejected(Rejection::new(RejectReason::BadParameter)), "case {i}");
        assert_serves(&mut link, &mut reference, &s[i * 10..i * 10 + 10], i as u32 * 10);
        assert!(!link.get_ref().dev.alarm().is_on());
    }
    assert_eq!(link.status().unwrap().model_crc, blob::stored_crc(default_blob()).unwrap());
}
