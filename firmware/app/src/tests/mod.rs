//! Host tests of the device logic: the same code as on the Cortex-M4F, driven through in-memory
//! streams, the real host link client and a recording alarm pin.

extern crate std;

mod flash;
mod serving;
mod signing;
#[cfg(feature = "spectrum")]
mod spectrum;
mod store;

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

/// The model store of the test devices: 8-byte flash words, 8 KiB erase units (four of them:
/// two slots, two log sectors; the emulated board's are 4 and 16 KiB; other granularities are
/// tested on [`Staging`] directly).
type Slot = Nor<8, 8192>;

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
static EMBEDDED: &[u8] = include_bytes!("../../../model/default.fbgm");

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
            flash: Slot::new(crate::store::STORE_UNITS),
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
            Store::open(&mut self.flash, STAGE).unwrap(),
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
