//! Hardware-independent application logic of the FBG firmware: frame handling, message
//! dispatch, model updates, counters and the alarm output.
//!
//! It talks to the board only through `embedded-io` (`Read`/`Write` for the serial link) and
//! `embedded-hal` (`OutputPin` for the alarm), so the very code that runs on the Cortex-M4F is
//! unit-tested on the host with in-memory streams and a recording pin (`cargo test` in
//! `firmware/` for the host target; `cargo xtask test` does it).
//!
//! # Memory
//!
//! The device borrows from the caller (the firmware puts them in statics) what must live
//! across messages:
//!
//! - the active [`Compensator`] (from [`unloaded`], then [`load`]ed in place);
//! - the link's frame reader (`HOST_MAX_FRAME` bytes and a few flags).
//!
//! A model update is not staged in RAM: `ModelChunk`s are programmed into a slot of NOR
//! flash as they arrive ([`staging`]: any `embedded-storage` [`NorFlash`] the CPU can also
//! read in place, [`MappedFlash`]), and the commit checks and decodes the blob from there.
//!
//! (BENCHMARKS.md has the footprint they add up to: flash, static RAM and stack at K = 32.)
//!
//! A model is loaded — at boot and during the handling of a `ModelCommit`, which carries no
//! data and is handled outside the frame decoding — by [`load_blob`]: everything but the
//! centres and Γ is parsed into a parameter slot without either (`ModelParams<f32, 0, 0>`,
//! about a fifth of a whole one) on the loader's stack frame, the centres and Γ are read
//! from the staged bytes, and [`Compensator::reload_blob`] folds it all into the active
//! compensator in place, checking every number before it writes one: a refused model leaves
//! the active one serving.
//!
//! # Signed updates
//!
//! A model update must be signed ([`fbg_shared::signature`]): [`authenticate`] checks the
//! staged bytes against the build's [`Policy`] — a trailer (else `Unsigned`), a trusted key id
//! (else `UnknownKey`), an Ed25519 signature that verifies (else `BadSignature`), and the serial
//! rule (not lower than the running model's, else `Rollback`; the running serial only on the
//! same model, else `SerialReused`; a rollback only where the build accepts rollbacks and only
//! over the one serial it was signed to replace, else `RollbackNotPermitted`) — before a byte
//! of the blob is parsed. The verification runs in
//! its own never-inlined frame, before the load, so its stack and the parameter slot's are
//! never on the stack together. Refusals are counted by reason in [`Status::refused`]. The
//! embedded default model is trusted as part of the firmware image unless the build requires
//! it to be signed too ([`boot`]).
//!
//! No heap, no panicking paths.

#![no_std]

/// Log through defmt when the `defmt` feature is on; nothing otherwise.
macro_rules! log {
    ($level:ident, $($arg:tt)*) => {
        #[cfg(feature = "defmt")]
        defmt::$level!($($arg)*);
    };
}

#[cfg(feature = "spectrum")]
pub mod spectrum;
pub mod staging;
pub mod store;

use core::convert::Infallible;

use embedded_hal::digital::{OutputPin, PinState};
use embedded_io::{Read, Write};
pub use embedded_storage::nor_flash::NorFlash;
use fbg_shared::blob;
use fbg_shared::container::{self, Envelope};
use fbg_shared::protocol::{
    encode_device, DeviceEstimate, DeviceMsg, Feed, FrameReader, HostMsg, Malformed, Refusals, RejectReason, Rejection,
    Status, UpdateResult, DEVICE_MAX_FRAME, HOST_MAX_FRAME,
};
#[cfg(not(feature = "spectrum"))]
use fbg_shared::protocol::{SpectrumError, SpectrumRefusal, SpectrumStatus};
use fbg_shared::signature::{self, KeyId, SignatureError, TrustedKey};
#[cfg(feature = "spectrum")]
use fbg_shared::spectrum::{ShiftRef, Window};
use fbg_shared::{Compensator, Estimate, Flags, Sample};
#[cfg(feature = "spectrum")]
use spectrum::{GratingSetup, GridSetup, Outcome, SpectrumFront};
pub use staging::{MappedFlash, Staging};
pub use store::Store;

/// The two library functions whose code generation matters more than their size, passed in
/// as function pointers so that the firmware can compile them apart from the size-optimised
/// rest (`fbg-firmware-kernel`): the per-sample step (instructions per step) and the model
/// loader (its stack depth during a model update). [`Kernel::LIBRARY`] is the plain library,
/// what the host tests use; the firmware's kernel runs the very same code.
#[derive(Clone, Copy)]
pub struct Kernel<const K: usize> {
    /// `Compensator::step`.
    pub step: fn(&mut Compensator<f32, K>, &Sample<f32>) -> Estimate<f32>,
    /// `Compensator::reload_blob`: decode a blob and fold it in, atomically.
    pub load: fn(&mut Compensator<f32, K>, &[u8]) -> Result<(), fbg_shared::Error>,
}

impl<const K: usize> Kernel<K> {
    /// The library functions, compiled wherever they are used.
    pub const LIBRARY: Self = Kernel { step: Compensator::step, load: Compensator::reload_blob };
}

/// Identity of a loaded model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelInfo {
    /// RBF centres in use.
    pub centres: u16,
    /// The blob's CRC trailer.
    pub crc: u32,
    /// Serial of its signature trailer (0 when unsigned).
    pub serial: u64,
    /// Its signer's key id (`None` when unsigned).
    pub key_id: Option<KeyId>,
}

/// Who may change what this device measures: fixed when the firmware is built.
#[derive(Clone, Copy, Debug)]
pub struct Policy {
    /// The public keys whose signatures are accepted.
    pub trusted: &'static [TrustedKey],
    /// Whether a rollback (signed with [`signature::SignFlags::ALLOW_ROLLBACK`] in a version-2 trailer
    /// naming the serial it replaces) is accepted while that serial runs; without, every
    /// rollback is refused. The firmware's default build does not accept rollbacks.
    pub allow_rollback: bool,
}

/// Who signed an accepted model, and which release it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Signer {
    /// The trailer's serial.
    pub serial: u64,
    /// The key that signed.
    pub key_id: KeyId,
}

/// Check a model file against `policy` before anything of it is parsed: a signature trailer,
/// a trusted key, a signature that verifies over blob, serial, flags and replaced serial, and
/// then the serial rule against the `running` model (none at boot):
///
/// - a rollback (allow-rollback flag in a version-2 trailer, naming the serial it replaces) is
///   accepted only by a build that accepts rollbacks and only while exactly that serial runs
///   (else `RollbackNotPermitted`: a replay once the device has moved on, or a build without
///   rollback);
/// - any other update needs a serial not lower than the running one (else `Rollback`; a
///   version-1 allow-rollback flag grants nothing);
/// - the running serial itself is accepted only on the same model, i.e. the same blob CRC (a
///   re-install; else `SerialReused`: two models signed with one serial cannot be swapped).
///
/// Returns the blob inside and its signer. Never inlined: the verifier's stack is gone before
/// the model loads.
#[inline(never)]
pub fn authenticate<'b>(
    policy: &Policy,
    bytes: &'b [u8],
    running: Option<&ModelInfo>,
) -> Result<(&'b [u8], Signer), Rejection> {
    let signed = match container::open(bytes)? {
        Envelope::Signed(s) => s,
        Envelope::Unsigned(_) => return Err(SignatureError::Unsigned.into()),
    };
    signature::verify(&signed, policy.trusted)?;
    let head = signed.head;
    if let Some(run) = running {
        let serial = head.serial;
        match head.rollback_of() {
            Some(replaces) if !policy.allow_rollback || replaces != run.serial => {
                let enabled = policy.allow_rollback;
                return Err(
                    SignatureError::RollbackNotPermitted { serial, replaces, running: run.serial, enabled }.into()
                );
            }
            Some(_) => {}
            None if serial < run.serial => {
                return Err(SignatureError::Rollback { serial, running: run.serial }.into());
            }
            None => {}
        }
        if serial == run.serial && blob::stored_crc(signed.blob) != Some(run.crc) {
            return Err(SignatureError::SerialReused { serial }.into());
        }
    }
    Ok((signed.blob, Signer { serial: head.serial, key_id: head.key_id }))
}

/// Load the embedded default model at boot. With `require_signed` it must pass
/// [`authenticate`] like any update (the build option for images whose model is provisioned
/// apart from the code); without, it is trusted as part of the firmware image, and a trailer
/// it carries (if any) only names its serial and key.
pub fn boot<const K: usize>(
    kernel: &Kernel<K>,
    policy: &Policy,
    require_signed: bool,
    comp: &mut Compensator<f32, K>,
    bytes: &[u8],
) -> Result<ModelInfo, Rejection> {
    let (blob, signer) = embedded(policy, require_signed, bytes)?;
    let info = load_blob(kernel, comp, blob)?;
    Ok(info.signed_by(signer))
}

/// The blob of the embedded model and its signer (see [`boot`]). Never inlined: the signed
/// envelope is gone from the stack before the model loads.
#[inline(never)]
fn embedded<'b>(
    policy: &Policy,
    require_signed: bool,
    bytes: &'b [u8],
) -> Result<(&'b [u8], Option<Signer>), Rejection> {
    if require_signed {
        let (blob, s) = authenticate(policy, bytes, None)?;
        return Ok((blob, Some(s)));
    }
    Ok(match container::open(bytes) {
        Ok(Envelope::Signed(s)) => (s.blob, Some(Signer { serial: s.head.serial, key_id: s.head.key_id })),
        _ => (bytes, None),
    })
}

impl ModelInfo {
    /// This model as signed by `signer` (unsigned with `None`).
    pub fn signed_by(self, signer: Option<Signer>) -> ModelInfo {
        ModelInfo { serial: signer.map_or(0, |s| s.serial), key_id: signer.map(|s| s.key_id), ..self }
    }
}

/// A compensator with no model loaded, for a `static` that [`load`] then fills in place (the
/// embedded default at boot): all bytes zero, so the static lands in `.bss` and no
/// compensator-sized value is ever built on the stack (`Compensator::new` returns one by
/// value, a compensator's size of stack, twice over with its `Result`). Until a model is loaded it
/// has no output and answers every sample as non-finite.
pub const fn unloaded<const K: usize>() -> Compensator<f32, K> {
    Compensator::unloaded()
}

/// Load the model in `bytes` into `comp` (at boot, the embedded default into an [`unloaded`]
/// compensator; later, a committed update) when, and only when, it is entirely valid
/// (`kernel.load`, i.e. [`Compensator::reload_blob`]): everything but the centres and Γ is
/// parsed into a parameter slot without either on the loader's stack frame, the centres (one
/// at a time) and Γ are read from `bytes`, and every folded number is checked before the
/// first is written. On any error `comp` keeps its model and stream state.
#[inline(never)]
pub fn load<const K: usize>(
    kernel: &Kernel<K>,
    comp: &mut Compensator<f32, K>,
    bytes: &[u8],
) -> Result<ModelInfo, Rejection> {
    (kernel.load)(comp, bytes)?;
    // The blob decoded, so it has a trailer.
    Ok(ModelInfo {
        centres: centres_u16(comp.n_centres()),
        crc: blob::stored_crc(bytes).unwrap_or(0),
        serial: 0,
        key_id: None,
    })
}

/// [`load`] (kept under its former name: the parameter slot is on the stack of the loader,
/// during the load only).
#[inline(never)]
pub fn load_blob<const K: usize>(
    kernel: &Kernel<K>,
    comp: &mut Compensator<f32, K>,
    bytes: &[u8],
) -> Result<ModelInfo, Rejection> {
    load(kernel, comp, bytes)
}

fn centres_u16(n: usize) -> u16 {
    u16::try_from(n).unwrap_or(u16::MAX)
}

/// Everything but the frame reader (split so that a decoded message, which borrows the
/// frame reader's buffer, can be handled while the rest is mutated).
struct Core<'a, P, F, const K: usize> {
    comp: &'a mut Compensator<f32, K>,
    kernel: Kernel<K>,
    policy: Policy,
    store: Store<F>,
    model: ModelInfo,
    status: Counters,
    alarm: P,
    stack_probe: Option<fn() -> u32>,
    #[cfg(feature = "spectrum")]
    spectrum: SpectrumFront,
}

/// The counters the device keeps in RAM (the rest of [`Status`] is computed when asked for):
/// since boot, but the update counters, which start from the store's log.
#[derive(Clone, Copy, Debug, Default)]
struct Counters {
    frames_ok: u32,
    frames_malformed: u32,
    samples: u32,
    updates_accepted: u32,
    updates_rejected: u32,
    refused: Refusals,
    last_rejection: Option<Rejection>,
    stack_boot_bytes: u32,
    /// Spectrum messages refused by a build without them (each `Unsupported`, detail 0: the
    /// count is all of its [`SpectrumStatus`]).
    #[cfg(not(feature = "spectrum"))]
    spectra_refused: u32,
}

/// The device: answers host frames with the active model.
///
/// `K` is the centre capacity of this build; `P` the alarm output (on while the latest
/// estimate carries any flag); `F` the flash of the model store ([`store`]).
pub struct Device<'a, P, F, const K: usize> {
    reader: &'a mut FrameReader<HOST_MAX_FRAME>,
    core: Core<'a, P, F, K>,
}

impl<'a, P: OutputPin, F: MappedFlash, const K: usize> Device<'a, P, F, K> {
    /// A device serving `comp` (identified by `model`, as [`Store::boot`] loaded it) with
    /// `kernel`, accepting updates that pass `policy` into `store` (whose slots hold at least
    /// `blob::max_len(K)` bytes plus a signature trailer to accept any model this build can
    /// hold), reading frames with `reader`, driving `alarm`. The update counters start from
    /// the store's log. Inlined into its caller, so that the device is built in
    /// place and not copied from a temporary (the firmware's `main` holds it on its stack).
    #[inline(always)]
    pub fn new(
        comp: &'a mut Compensator<f32, K>,
        kernel: Kernel<K>,
        policy: Policy,
        reader: &'a mut FrameReader<HOST_MAX_FRAME>,
        model: ModelInfo,
        store: Store<F>,
        mut alarm: P,
    ) -> Self {
        // Start with the alarm off; an output that cannot be driven is not fatal.
        let _ = alarm.set_low();
        let (updates_accepted, updates_rejected, refused) = store.totals();
        let status = Counters { updates_accepted, updates_rejected, refused, ..Counters::default() };
        // Serving starts between frames.
        *reader = FrameReader::new();
        Device {
            reader,
            core: Core {
                comp,
                kernel,
                policy,
                store,
                model,
                status,
                alarm,
                stack_probe: None,
                #[cfg(feature = "spectrum")]
                spectrum: SpectrumFront::new(),
            },
        }
    }

    /// Boot the model the store selects (its newest verified slot at or above the rollback
    /// floor, else the embedded `default`; [`Store::boot`]) into this device's compensator, and
    /// identify the device by it. The way the firmware boots: the device (and the store in it)
    /// is built once, in place, before the model loads, so no second copy of the store sits
    /// on the stack. Not inlined: the boot's temporaries are gone once it returns.
    #[inline(never)]
    pub fn boot(&mut self, require_signed: bool, default: &[u8]) -> Result<ModelInfo, Rejection> {
        let core = &mut self.core;
        let info = core.store.boot(&core.kernel, &core.policy, require_signed, core.comp, default)?;
        core.model = info;
        // Boot may have logged a recovered update.
        let (accepted, rejected, refused) = core.store.totals();
        core.status.updates_accepted = accepted;
        core.status.updates_rejected = rejected;
        core.status.refused = refused;
        Ok(info)
    }

    /// Report the deepest stack use through `probe` in [`Status::stack_peak_bytes`], and the
    /// peak measured during boot in [`Status::stack_boot_bytes`].
    pub fn set_stack_probe(&mut self, probe: fn() -> u32, boot_peak: u32) {
        self.core.stack_probe = Some(probe);
        self.core.status.stack_boot_bytes = boot_peak;
    }

    /// The current counters and active model.
    pub fn status(&self) -> Status {
        self.core.status()
    }

    /// The active model's identity.
    pub fn model(&self) -> ModelInfo {
        self.core.model
    }

    /// The alarm output.
    pub fn alarm(&self) -> &P {
        &self.core.alarm
    }

    /// The model store.
    pub fn store(&self) -> &Store<F> {
        &self.core.store
    }

    /// The model store, mutable (tests injecting flash faults).
    pub fn store_mut(&mut self) -> &mut Store<F> {
        &mut self.core.store
    }

    /// Record the time from reset to serving, µs (`Status::store.boot_time_us`).
    pub fn set_boot_time_us(&mut self, us: u32) {
        self.core.store.set_boot_time_us(us);
    }

    /// Answer one decoded message.
    pub fn handle(&mut self, msg: &HostMsg<'_>) -> DeviceMsg {
        match msg {
            HostMsg::ModelCommit => {
                let loaded = self.commit();
                self.core.commit_reply(loaded)
            }
            other => self.core.handle(other),
        }
    }

    /// Consume received bytes: decode complete frames, answer each valid message on `tx`,
    /// count and drop malformed frames. Partial frames are kept for the next call.
    pub fn feed<W: Write>(&mut self, bytes: &[u8], tx: &mut W) -> Result<(), W::Error> {
        let mut window = bytes;
        // A commit is handled here, outside the frame decoding (`feed_until_commit` has
        // returned, its temporaries are gone): loading a model is the deepest the stack goes.
        while let Some(rest) = self.feed_until_commit(window, tx)? {
            let loaded = self.commit();
            self.core.answer_commit(loaded, tx)?;
            window = rest;
        }
        Ok(())
    }

    /// [`Device::feed`] up to and including a `ModelCommit` frame: returns the bytes after it
    /// (`Some`, the commit still to be handled), or `None` once `bytes` are consumed.
    #[inline(never)]
    fn feed_until_commit<'b, W: Write>(&mut self, bytes: &'b [u8], tx: &mut W) -> Result<Option<&'b [u8]>, W::Error> {
        let mut window = bytes;
        while !window.is_empty() {
            let (ev, rest) = self.reader.feed::<HostMsg<'_>>(window);
            window = rest;
            match ev {
                Feed::Pending => {}
                Feed::Malformed(why) => self.core.malformed(why),
                // A commit borrows nothing from the reader, which is between frames now: it
                // is handled once this function's frames are gone.
                Feed::Message(HostMsg::ModelCommit) => {
                    self.core.count_frame();
                    return Ok(Some(window));
                }
                Feed::Message(msg) => self.core.answer(&msg, tx)?,
            }
        }
        Ok(None)
    }

    /// Serve the link forever: read what arrives, answer it. Returns only on a link error.
    pub fn serve<U: Read + Write>(&mut self, link: &mut U) -> Result<Infallible, U::Error> {
        // The UART hands over what has arrived (at least one byte); a small buffer keeps the
        // serving loop's frame small.
        let mut buf = [0u8; 16];
        loop {
            let n = link.read(&mut buf)?;
            let got = buf.get(..n).unwrap_or(&[]);
            self.feed(got, link)?;
        }
    }

    /// Check the transfer (its last bytes written, the staged bytes read back from the flash
    /// slot against the announced CRC), then the signature ([`authenticate`]), then make it
    /// the store's booting model and load the staged blob in place in the slot ([`load_blob`]:
    /// the parameter slot is on the stack for the duration of the load only; [`Store::commit`]).
    /// The two checks and the load run one after the other, so the deepest of them sets the
    /// stack peak, not their sum. Cold: once per model update, never inlined into the serving
    /// loop; the answer is built afterwards ([`Core::commit_reply`]), so that it takes no stack
    /// during the load.
    #[inline(never)]
    fn commit(&mut self) -> Result<ModelInfo, Rejection> {
        let core = &mut self.core;
        core.store.commit(&core.kernel, &core.policy, core.comp, &core.model)
    }
}

impl<P: OutputPin, F: MappedFlash, const K: usize> Core<'_, P, F, K> {
    fn status(&self) -> Status {
        let c = &self.status;
        Status {
            frames_ok: c.frames_ok,
            frames_malformed: c.frames_malformed,
            samples: c.samples,
            updates_accepted: c.updates_accepted,
            updates_rejected: c.updates_rejected,
            model_capacity: centres_u16(K),
            refused: c.refused,
            last_rejection: c.last_rejection,
            stack_boot_bytes: c.stack_boot_bytes,
            model_centres: self.model.centres,
            model_crc: self.model.crc,
            model_serial: self.model.serial,
            model_key_id: self.model.key_id,
            stack_peak_bytes: self.stack_probe.map_or(0, |p| p()),
            staging_erases: self.store.transfer_erases(),
            store: self.store.status(),
            #[cfg(feature = "spectrum")]
            spectra: self.spectrum.status(),
            #[cfg(not(feature = "spectrum"))]
            spectra: SpectrumStatus {
                refused: c.spectra_refused,
                last_refusal: (c.spectra_refused > 0).then_some(SpectrumRefusal::new(SpectrumError::Unsupported, 0)),
                ..SpectrumStatus::default()
            },
        }
    }

    /// Count, handle and answer one message (not a commit). Never inlined into the serving
    /// loop: the answer's temporaries then are not on the stack while a model loads.
    /// A sample, the message the device answers most, is stepped with no reply message on
    /// this frame (a `DeviceMsg` is the size of its largest variant, the status): the estimate
    /// is framed once the step is done ([`send_estimate`]).
    #[inline(never)]
    fn answer<W: Write>(&mut self, msg: &HostMsg<'_>, tx: &mut W) -> Result<(), W::Error> {
        self.count_frame();
        if let HostMsg::Sample { seq, ref sample } = *msg {
            let e = self.step(seq, sample, Flags::OK);
            return send_estimate(tx, e);
        }
        #[cfg(feature = "spectrum")]
        if let HostMsg::SpectrumPixels { first_pixel, data } = *msg {
            // Detection returns before the step runs (`SpectrumFront::detect` is not inlined).
            return match self.spectrum.pixels(first_pixel, data) {
                Outcome::Reading { seq, sample, flags } => {
                    let e = self.step(seq, &sample, flags);
                    send_estimate(tx, e)
                }
                other => send(tx, &spectrum_reply(other)),
            };
        }
        self.answer_other(msg, tx)
    }

    /// [`Core::answer`] for every message but a sample.
    #[inline(never)]
    fn answer_other<W: Write>(&mut self, msg: &HostMsg<'_>, tx: &mut W) -> Result<(), W::Error> {
        let reply = self.handle(msg);
        send(tx, &reply)
    }

    /// The answer to a commit, and its accounting.
    fn commit_reply(&mut self, loaded: Result<ModelInfo, Rejection>) -> DeviceMsg {
        match loaded {
            Ok(info) => self.accepted(info),
            Err(r) => self.reject(r),
        }
    }

    /// [`Core::commit_reply`], sent. Never inlined (see [`Core::answer`]).
    #[inline(never)]
    fn answer_commit<W: Write>(&mut self, loaded: Result<ModelInfo, Rejection>, tx: &mut W) -> Result<(), W::Error> {
        let reply = self.commit_reply(loaded);
        send(tx, &reply)
    }

    fn count_frame(&mut self) {
        self.status.frames_ok = self.status.frames_ok.wrapping_add(1);
    }

    fn malformed(&mut self, why: Malformed) {
        self.status.frames_malformed = self.status.frames_malformed.wrapping_add(1);
        let _ = why;
        log!(warn, "dropped a malformed frame ({})", why);
    }

    /// Everything but `ModelCommit` (handled outside the frame decoding: [`Device::commit`]).
    fn handle(&mut self, msg: &HostMsg<'_>) -> DeviceMsg {
        match *msg {
            HostMsg::Ping { nonce } => DeviceMsg::Pong { nonce },
            HostMsg::ResetStream { nonce, clock } => {
                self.comp.reset();
                self.comp.set_clock(clock);
                DeviceMsg::Pong { nonce }
            }
            HostMsg::Sample { seq, ref sample } => DeviceMsg::Estimate(self.step(seq, sample, Flags::OK)),
            #[cfg(feature = "spectrum")]
            HostMsg::SpectrumGrid { gratings, pixels, uniform, coefficients, method, full_scale } => {
                spectrum_reply(self.spectrum.grid(&GridSetup {
                    gratings,
                    pixels,
                    uniform,
                    coefficients,
                    method,
                    full_scale,
                }))
            }
            #[cfg(feature = "spectrum")]
            HostMsg::SpectrumGrating { index, channel, lo_nm, hi_nm, ref_hi_nm, ref_lo_nm } => {
                spectrum_reply(self.spectrum.grating(&GratingSetup {
                    index,
                    channel,
                    window: Window::new(lo_nm, hi_nm),
                    shift: ShiftRef { hi_nm: ref_hi_nm, lo_nm: ref_lo_nm },
                }))
            }
            #[cfg(feature = "spectrum")]
            HostMsg::SpectrumBegin { seq, channel, t_s, t_amb_c } => {
                spectrum_reply(self.spectrum.begin(seq, channel, t_s, t_amb_c))
            }
            #[cfg(feature = "spectrum")]
            HostMsg::SpectrumPixels { first_pixel, data } => match self.spectrum.pixels(first_pixel, data) {
                Outcome::Reading { seq, sample, flags } => DeviceMsg::Estimate(self.step(seq, &sample, flags)),
                other => spectrum_reply(other),
            },
            #[cfg(not(feature = "spectrum"))]
            HostMsg::SpectrumGrid { .. }
            | HostMsg::SpectrumGrating { .. }
            | HostMsg::SpectrumBegin { .. }
            | HostMsg::SpectrumPixels { .. } => {
                self.status.spectra_refused = self.status.spectra_refused.wrapping_add(1);
                DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::Unsupported, 0))
            }
            HostMsg::GetStatus => DeviceMsg::Status(self.status()),
            HostMsg::ModelBegin { total_len, crc32 } => self.begin(total_len, crc32),
            HostMsg::ModelChunk { offset, data } => self.chunk(offset, data),
            // Only reached through `Device::handle`'s caller contract being broken; refuse it
            // like a commit without a transfer.
            HostMsg::ModelCommit => self.reject(Rejection::new(RejectReason::NoUpdateInProgress)),
        }
    }

    /// Compensate `sample`; `extra` are flags from outside the model (a spectrum's peaks),
    /// added to the estimate's and driving the alarm like them.
    fn step(&mut self, seq: u32, sample: &Sample<f32>, extra: Flags) -> DeviceEstimate {
        let e = (self.kernel.step)(self.comp, sample);
        self.status.samples = self.status.samples.wrapping_add(1);
        let mut d = DeviceEstimate::new(seq, &e);
        d.flags.insert(extra);
        let _ = self.alarm.set_state(PinState::from(d.flags.is_fault()));
        d
    }

    fn begin(&mut self, total_len: u32, crc: u32) -> DeviceMsg {
        if let Err(r) = self.store.begin(total_len as usize, crc) {
            return self.reject(r);
        }
        log!(info, "model transfer: {=u32} bytes", total_len);
        DeviceMsg::UpdateProgress { received: 0 }
    }

    fn chunk(&mut self, offset: u32, data: &[u8]) -> DeviceMsg {
        match self.store.chunk(offset, data) {
            Ok(end) => DeviceMsg::UpdateProgress { received: u32::try_from(end).unwrap_or(u32::MAX) },
            Err(r) => self.reject(r),
        }
    }

    fn accepted(&mut self, info: ModelInfo) -> DeviceMsg {
        self.model = info;
        self.status.updates_accepted = self.status.updates_accepted.wrapping_add(1);
        let _ = self.alarm.set_low();
        log!(
            info,
            "model update accepted: {=u16} centres, crc {=u32:#010x}, serial {=u64}",
            info.centres,
            info.crc,
            info.serial
        );
        DeviceMsg::UpdateResult(UpdateResult::Accepted { centres: info.centres, crc: info.crc })
    }

    fn reject(&mut self, r: Rejection) -> DeviceMsg {
        self.store.abort();
        self.status.updates_rejected = self.status.updates_rejected.wrapping_add(1);
        self.status.last_rejection = Some(r);
        self.status.refused.count(r.reason);
        log!(
            warn,
            "model update rejected: {} (code {=u8}, detail {=u32}); keeping the active model",
            r.reason,
            r.reason.code(),
            r.detail
        );
        DeviceMsg::UpdateResult(UpdateResult::Rejected(r))
    }
}

/// The answer to a spectrum message that did not complete a reading.
#[cfg(feature = "spectrum")]
fn spectrum_reply(out: Outcome) -> DeviceMsg {
    match out {
        Outcome::Set(missing) => DeviceMsg::SpectrumSet { missing },
        Outcome::Ack(received) => DeviceMsg::SpectrumAck { received },
        Outcome::Refused(r) => {
            log!(warn, "spectrum message refused: {} (detail {=u16})", r.reason, r.detail);
            DeviceMsg::SpectrumRefused(r)
        }
        // Not reached: a reading is stepped by the caller and answered with its estimate.
        Outcome::Reading { .. } => DeviceMsg::SpectrumAck { received: 0 },
    }
}

/// Frame and write the estimate `e` (see [`Core::answer`]).
#[inline(never)]
fn send_estimate<W: Write>(tx: &mut W, e: DeviceEstimate) -> Result<(), W::Error> {
    send(tx, &DeviceMsg::Estimate(e))
}

/// Frame and write one answer. Every device message fits [`DEVICE_MAX_FRAME`] (tested in
/// `fbg_shared::protocol`); a writer that accepts no more bytes ends the frame early rather
/// than spinning (the host then sees a malformed frame).
#[inline(never)]
fn send<W: Write>(tx: &mut W, msg: &DeviceMsg) -> Result<(), W::Error> {
    let mut buf = [0u8; DEVICE_MAX_FRAME];
    let Ok(frame) = encode_device(msg, &mut buf) else {
        return Ok(());
    };
    let mut rest: &[u8] = frame;
    while !rest.is_empty() {
        let n = tx.write(rest)?;
        if n == 0 {
            break;
        }
        rest = rest.get(n..).unwrap_or(&[]);
    }
    tx.flush()
}

#[cfg(test)]
mod tests;
