//! Host tests of the device logic: the same code as on the Cortex-M4F, driven through in-memory
//! streams, the real host link client and a recording alarm pin.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

extern crate std;

use std::collections::VecDeque;
use std::format;
use std::vec::Vec;

use embedded_hal::digital::{ErrorType, OutputPin};
use fbg_shared::link_client::{LinkClient, LinkError};
use fbg_shared::protocol::{encode_host, RejectReason, MAX_CHUNK};
use fbg_shared::{blob, Flags, ModelParams};

use super::*;

const K: usize = 32;
const STAGE: usize = blob::max_len(K);

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

/// A device in memory behind `std::io::{Read, Write}`, so the host's `LinkClient` can drive it.
struct Wire<'d> {
    dev: Device<'d, Pin, K>,
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
    scratch: std::boxed::Box<Scratch<K>>,
    staging: Vec<u8>,
}

impl Mem {
    fn new() -> Self {
        Mem {
            comp: std::boxed::Box::new(unloaded()),
            scratch: std::boxed::Box::new(Scratch::new()),
            staging: std::vec![0u8; STAGE],
        }
    }
    /// Boot `blob_bytes` the way the firmware boots its default model.
    fn boot(&mut self, blob_bytes: &[u8]) -> Result<ModelInfo, Rejection> {
        load_with(&Kernel::LIBRARY, &mut self.comp, &mut self.scratch, blob_bytes)
    }
    fn device(&mut self, info: ModelInfo) -> Device<'_, Pin, K> {
        Device::new(&mut self.comp, Kernel::LIBRARY, &mut self.scratch, info, &mut self.staging, Pin::default())
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

/// A second valid model: the default with other residual weights and intercepts.
fn other_model() -> Vec<u8> {
    let mut p = params(default_blob());
    for c in p.centres.iter_mut() {
        c.w = [c.w[0] * -2.0 + 0.01, c.w[1] + 1.0, c.w[2] * 0.5];
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
            Sample {
                dl_pm: [
                    mid(0) + half(0) * (x / 9.0).sin(),
                    mid(1) + half(1) * (x / 13.0).sin(),
                    mid(2) + half(2) * (x / 7.0).cos(),
                ],
                t_amb_c: mid(3) + half(3) * (x / 11.0).sin(),
                t_s: 60.0 * x,
            }
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
    assert_eq!(st.model_centres, 32);
    assert_eq!(st.model_capacity, K as u16);
    assert_eq!(st.model_crc, blob_crc(default_blob()));
    assert_eq!(st.last_rejection, None);
}

#[test]
fn the_alarm_follows_the_flags() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let good = samples(1)[0];
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
    let r = link.update_model(&b).unwrap();
    assert_eq!(r, UpdateResult::Accepted { centres: 32, crc: blob_crc(&b) });
    let mut new = Compensator::<f32, K>::new(&params(&b)).unwrap();
    assert_serves(&mut link, &mut new, &s[20..], 20);
    // And the answers did change.
    let mut old_again = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let mut new_again = Compensator::<f32, K>::new(&params(&b)).unwrap();
    let differ = s.iter().any(|x| old_again.step(x).values != new_again.step(x).values);
    assert!(differ);
    let st = link.status().unwrap();
    assert_eq!((st.updates_accepted, st.updates_rejected), (1, 0));
    assert_eq!(st.model_crc, blob_crc(&b));
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
    // `encode` refuses invalid params, so patch a NaN into σ (header 14 B, feature-set tag 1 B,
    // σ_mult 4 B, then σ) and re-sign the blob.
    let mut nan_sigma = good.clone();
    nan_sigma[19..23].copy_from_slice(&f32::NAN.to_le_bytes());
    let n = nan_sigma.len();
    let c = crc32(&nan_sigma[..n - 4]).to_le_bytes();
    nan_sigma[n - 4..].copy_from_slice(&c);
    let mut bad_version = good.clone();
    bad_version[4] = 9;
    let mut too_many = params(default_blob());
    too_many.centres.truncate(20);
    let small = encode(&too_many); // a valid, shorter model to cut short
    let cases: Vec<(&str, Vec<u8>, RejectReason)> = std::vec![
        ("corrupt byte", corrupt, RejectReason::BadCrc),
        ("bad version", bad_version, RejectReason::UnsupportedVersion),
        ("nan sigma", nan_sigma, RejectReason::BadParameter),
        ("truncated", small[..200].to_vec(), RejectReason::Truncated),
        ("not a blob", std::vec![0x42; 300], RejectReason::BadMagic),
        ("too large", std::vec![0; STAGE + 1], RejectReason::TooLarge),
    ];
    let mut rejected = 0;
    for (i, (name, bytes, reason)) in cases.iter().enumerate() {
        let r = link.update_model(bytes).unwrap();
        match r {
            UpdateResult::Rejected(rej) => assert_eq!(rej.reason, *reason, "{name}: {rej}"),
            other => panic!("{name}: {other:?}"),
        }
        rejected += 1;
        let st = link.status().unwrap();
        assert_eq!(st.updates_rejected, rejected, "{name}");
        assert_eq!(st.model_crc, blob_crc(default_blob()), "{name}: old model still active");
        assert_serves(&mut link, &mut reference, &s[i * 10..i * 10 + 10], i as u32 * 10);
    }

    // Transfer-level errors.
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
    assert_eq!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::OutOfOrder, detail: 0 })));
    link.request(&HostMsg::ModelBegin { total_len: 20, crc32: crc }).unwrap();
    let r = link.request(&HostMsg::ModelChunk { offset: 0, data: &good[..30] }).unwrap();
    assert!(matches!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::Overrun, .. }))));
    link.request(&HostMsg::ModelBegin { total_len, crc32: crc }).unwrap();
    link.request(&HostMsg::ModelChunk { offset: 0, data: &good[..100] }).unwrap();
    let r = link.request(&HostMsg::ModelCommit).unwrap();
    assert_eq!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::Incomplete, detail: 100 })));

    assert_serves(&mut link, &mut reference, &s[70..], 70);
    let st = link.status().unwrap();
    assert_eq!(st.updates_accepted, 0);
    assert_eq!(st.last_rejection.map(|r| r.reason), Some(RejectReason::Incomplete));

    // Finally a good one still goes through.
    assert!(matches!(link.update_model(&good).unwrap(), UpdateResult::Accepted { .. }));
}

#[test]
fn a_model_beyond_the_capacity_is_refused() {
    // A device built for 16 centres refuses the 32-centre default model.
    let mut comp = std::boxed::Box::new(unloaded::<16>());
    let mut scratch = std::boxed::Box::new(Scratch::<16>::new());
    let e = load_with(&Kernel::LIBRARY, &mut comp, &mut scratch, default_blob()).err().unwrap();
    assert_eq!(e.reason, RejectReason::WrongDims);
    assert_eq!(e.detail, 32 << 16 | 16);
    assert_eq!(comp.n_centres(), 0, "still unloaded");
}

#[test]
fn an_unloaded_compensator_is_usable() {
    // All-zero bytes: no centres, no output fitted, latches that have seen nothing.
    let mut comp = std::boxed::Box::new(unloaded::<K>());
    assert_eq!(comp.n_centres(), 0);
    assert_eq!(comp.latch_values(), [0.0; 3]);
    let e = comp.step(&samples(1)[0]);
    assert!(e.values.iter().all(|v| v.is_nan()), "{e:?}");
    assert!(e.band95.iter().all(|b| b.is_infinite()), "{e:?}");
    // Loading into it gives exactly `Compensator::new`.
    let mut scratch = std::boxed::Box::new(Scratch::<K>::new());
    let info = load_with(&Kernel::LIBRARY, &mut comp, &mut scratch, default_blob()).unwrap();
    assert_eq!(info, ModelInfo { centres: 32, crc: blob_crc(default_blob()) });
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    for x in samples(30) {
        assert_eq!(format!("{:?}", comp.step(&x)), format!("{:?}", reference.step(&x)));
    }
}

#[test]
fn the_scratch_area_switches_between_reader_and_staging_slot() {
    let mut scratch = std::boxed::Box::new(Scratch::<K>::new());
    assert!(matches!(*scratch, Scratch::Params(_)));
    // Switch to the reader and decode a frame with it.
    let mut buf = [0u8; 64];
    let ping = encode_host(&HostMsg::Ping { nonce: 9 }, &mut buf).unwrap().to_vec();
    {
        let r = scratch.reader().unwrap();
        let (ev, rest) = r.feed::<HostMsg<'_>>(&ping);
        assert_eq!(ev, Feed::Message(HostMsg::Ping { nonce: 9 }));
        assert!(rest.is_empty());
    }
    assert!(matches!(*scratch, Scratch::Reader(_)));
    // Fill the slot, switch away and back: it comes back exactly `empty_params()`.
    *scratch.params().unwrap() = params(default_blob());
    assert!(matches!(*scratch, Scratch::Params(_)));
    let _ = scratch.reader().unwrap();
    let p = scratch.params().unwrap();
    assert_eq!(*p, empty_params::<K>());
    assert_eq!(p.centres.len(), 0, "a fresh, empty slot");
    // And a reader that held half a frame comes back empty too.
    {
        let r = scratch.reader().unwrap();
        let (ev, _) = r.feed::<HostMsg<'_>>(&ping[..3]);
        assert_eq!(ev, Feed::Pending);
    }
    let _ = scratch.params().unwrap();
    let r = scratch.reader().unwrap();
    let (ev, _) = r.feed::<HostMsg<'_>>(&ping);
    assert_eq!(ev, Feed::Message(HostMsg::Ping { nonce: 9 }));
    // Serving goes on across an update that switches it back and forth.
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    link.ping(3).unwrap();
    assert!(matches!(link.update_model(&other_model()).unwrap(), UpdateResult::Accepted { .. }));
    link.ping(4).unwrap();
    assert!(matches!(link.update_model(default_blob()).unwrap(), UpdateResult::Accepted { .. }));
    assert_eq!(link.status().unwrap().frames_malformed, 0);
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
        let before = mem.comp.latch_values();
        let params = mem.scratch.params().unwrap();
        assert!(load(&Kernel::LIBRARY, &mut mem.comp, params, &bad).is_err());
        assert_eq!(mem.comp.latch_values(), before);
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
