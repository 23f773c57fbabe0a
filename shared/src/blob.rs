//! The `.fbgm` model blob: the one file a trained model travels in, from the trainer to a
//! device.
//!
//! ```text
//! offset  size  field
//! 0       4     magic "FBGM"
//! 4       2     format version, u16 LE (this build writes FORMAT_VERSION)
//! 6       2     gratings     N (1..=MAX_GRATINGS)
//! 8       2     ambient      0 or 1
//! 10      2     measurands   M (1..=MAX_OUTPUTS)
//! 12      2     poly terms   1 + M + M(M+1)/2
//! 14      2     memory terms (slots of the memory vector m of these dims, used or not)
//! 16      2     centres      (K of this model)
//! 18      n     payload (postcard encoding, see below)
//! 18+n    4     CRC-32/ISCSI (postcard crc flavour) over bytes 0..18+n, u32 LE
//! ```
//!
//! The payload carries only the entries the dims use (every f32 is 4 bytes LE): per output its
//! quantity code and index (2 bytes each, [`crate::layout::Output`]); the hyper-parameters;
//! stage 1 (M rows of N + ambient + 1); the guess means and deviations (M each); the
//! polynomial core (M rows of the poly terms); the memory spec (6 grating τ, 4 ambient τ with
//! ambient, 3 plays, and with the observer slot its lag, smoothing and stage-1-length row); Γ
//! (M rows of the memory terms); z mean and deviation (2N + ambient + 1 each); the centres (a
//! varint count, each μ over z, M weights, `VAR_RANK` variance components); `var_inv_g`, its
//! tail; residual variance, its growth (M each); the end of calibration; band multipliers (M);
//! envelope low and high (N + ambient each); fitted (M bools); provenance; then what a field
//! reading needs ([`crate::field::FieldContext`]): λ_ref per grating (N f64, nm), its source
//! (N one-byte codes), the λ_ref tolerance (f32, pm), the absolute end of calibration
//! (postcard `Option<f64>`, Unix s), the largest validated lead (f32, s), the output envelope
//! low and high and the largest band (M f32 each); then where the memory may be trusted
//! ([`crate::trust::TrustSpec`]): the rate limits (N + ambient f32), the largest quiet times
//! (N f32, s), Model-P's band variance and its growth (M f32 each), the largest RMS swings, the
//! largest RMS speeds and the smallest RMS swings (N + ambient f32 each).
//!
//! The blob must be exactly `22 + n` bytes long: nothing may follow the CRC, except the
//! signature trailer of a signed model ([`crate::signature`]), which decoding skips
//! ([`crate::container::strip`]; it does not verify it: that is the device's policy,
//! [`crate::signature::verify`]).
//!
//! Version history: 1 had no memory terms (no memory field in the header, no memory spec or
//! Γ in the payload); 2 adds them, for the fixed paper layout (3 gratings, ambient, T/ε/p);
//! 3 makes the dimensions data (gratings, ambient and measurands in the header, output kinds
//! in the payload, every vector only as long as the dims need); 4 adds the field context (the
//! zero, the clock, the output envelope and largest band); 5 adds where the memory may be trusted
//! ([`crate::trust::TrustSpec`]: a rate limit per envelope input (f32), the largest quiet times
//! (N f32, s), Model-P's band variance and its growth (M f32 each)); 6 adds the calibration's
//! pace (the largest RMS swing per envelope input, f32); 7 adds the largest RMS speed and the
//! smallest RMS swing per envelope input (f32 each): the pace of oscillations faster than the
//! swing's band, and the slowest pace. An older blob is refused with
//! [`Error::UnsupportedVersion`] naming both versions: retrain, or re-export with this
//! trainer. A blob whose gratings or measurands exceed this build's capacity is refused with
//! [`Error::OverCapacity`] naming both.
//!
//! Decoding checks magic, version, CRC, dims and every parameter, and returns a typed
//! [`Error`]; it never panics and never allocates, whatever the bytes.
//!
//! A valid CRC (or signature) says the bytes are what a writer wrote, not that a fit wrote
//! them: every number must also lie within the plausibility bound of its field, derived from
//! the units and the scaling ([`crate::model::bounds`] has the table and the reasons), and each
//! output's index within its quantity may not exceed [`MAX_OUTPUTS`]. In short: output values,
//! guess means and deviations, the output envelope and the largest band within ±1e6 output
//! units (°C, µε, kPa); shifts, T_amb, the input envelope and the λ_ref tolerance within ±1e6
//! pm or °C; times and time constants within 1e10 s, the absolute end of calibration within
//! ±1e11 Unix s; stage 1, the polynomial core, Γ, the observer's row and the centre weights
//! within ±1e9; centre positions, σ and its multiplier within 1e6 standardised units; residual
//! variances and their growth within 1e12 unit² (per s); `var_inv_g`, its tail and α within
//! 1e12; the centres' variance components (unit eigenvectors) within ±1.001; band multipliers,
//! the flagged-band factor and the envelope margin within 1e3; a known λ_ref within 100–10 000
//! nm. A number beyond its bound is
//! [`Error::BadParameter`] naming the field ("stage1", "centres.v", "dims.outputs", …); the
//! encoder refuses the same, so a blob that encodes always decodes. None of this changes the
//! byte format.

use serde::Serialize;

use crate::crc32c::{crc32c, Crc32c};
use crate::error::Error;
use crate::layout::{
    head, Dims, Output, Quantity, MAX_GRATINGS, MAX_MEMORY, MAX_OUTPUTS, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS,
    VAR_RANK,
};
use crate::model::{Centre, ModelParams};

mod readers;
use readers::{floats, parse_centre, take};
pub use readers::{CentreReader, GammaReader};

/// File magic.
pub const MAGIC: [u8; 4] = *b"FBGM";
/// Format version this build writes and reads.
pub const FORMAT_VERSION: u16 = 7;
pub use crate::frame::{computed_crc, stored_crc, CRC_LEN, HEADER_LEN};

/// The fixed-size header of a blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Format version.
    pub version: u16,
    /// Gratings N.
    pub gratings: u16,
    /// 1 with an ambient input, 0 without.
    pub ambient: u16,
    /// Measurands M.
    pub measurands: u16,
    /// Polynomial terms.
    pub poly_terms: u16,
    /// Memory-term slots.
    pub memory_terms: u16,
    /// RBF centres.
    pub centres: u16,
}

impl Header {
    /// Parse and check the header of `bytes` (magic, version, the dims against this build's
    /// capacity and each other) without touching the payload or the CRC. Input that does not
    /// start like `FBGM` is [`Error::BadMagic`] even when it is shorter than a header.
    pub fn parse(bytes: &[u8]) -> Result<Header, Error> {
        let header = Header::read(bytes)?;
        header.check_version()?;
        header.check_dims()?;
        Ok(header)
    }

    /// Magic and the seven fields, unchecked.
    fn read(bytes: &[u8]) -> Result<Header, Error> {
        if bytes.iter().zip(MAGIC.iter()).any(|(b, m)| b != m) {
            return Err(Error::BadMagic);
        }
        let head = bytes.get(..HEADER_LEN).ok_or(Error::Truncated { part: "header" })?;
        let mut w = [0u16; 7];
        for (o, ch) in w.iter_mut().zip(head.get(MAGIC.len()..).unwrap_or(&[]).chunks_exact(2)) {
            let mut b = [0u8; 2];
            b.copy_from_slice(ch);
            *o = u16::from_le_bytes(b);
        }
        let [version, gratings, ambient, measurands, poly_terms, memory_terms, centres] = w;
        Ok(Header { version, gratings, ambient, measurands, poly_terms, memory_terms, centres })
    }

    /// The version decides how the rest is read, so it is checked before anything else.
    fn check_version(&self) -> Result<(), Error> {
        if self.version == FORMAT_VERSION {
            Ok(())
        } else {
            Err(Error::UnsupportedVersion { found: self.version, supported: FORMAT_VERSION })
        }
    }

    /// Gratings and measurands within this build's capacity (else [`Error::OverCapacity`]) and
    /// at least 1; ambient 0 or 1; the poly terms those of M; the memory terms those of the
    /// dims with or without the observer slot (which one the output kinds in the payload
    /// decide).
    fn check_dims(&self) -> Result<(), Error> {
        let over = |field, found: u16, capacity: usize| {
            if usize::from(found) > capacity {
                Err(Error::OverCapacity { field, found, capacity: saturate_u16(capacity) })
            } else if found == 0 {
                Err(Error::WrongDims { field, found, expected: 1 })
            } else {
                Ok(())
            }
        };
        over("gratings", self.gratings, MAX_GRATINGS)?;
        over("measurands", self.measurands, MAX_OUTPUTS)?;
        if self.ambient > 1 {
            return Err(Error::WrongDims { field: "ambient", found: self.ambient, expected: 1 });
        }
        let poly = crate::layout::poly_len(usize::from(self.measurands));
        if usize::from(self.poly_terms) != poly {
            return Err(Error::WrongDims { field: "poly_terms", found: self.poly_terms, expected: saturate_u16(poly) });
        }
        let (lo, hi) = self.memory_range();
        if usize::from(self.memory_terms) != lo && usize::from(self.memory_terms) != hi {
            return Err(Error::WrongDims {
                field: "memory_terms",
                found: self.memory_terms,
                expected: saturate_u16(lo),
            });
        }
        Ok(())
    }

    /// Memory terms without and with the observer slot.
    fn memory_range(&self) -> (usize, usize) {
        let n = usize::from(self.gratings);
        let lo = n * (N_GRATING_TAUS + N_PLAYS) + if self.ambient == 1 { N_AMBIENT_TAUS } else { 0 };
        (lo, if self.ambient == 1 { lo + 1 } else { lo })
    }

    fn check_capacity<const K: usize>(&self) -> Result<(), Error> {
        if usize::from(self.centres) > K {
            Err(Error::WrongDims { field: "centres", found: self.centres, expected: saturate_u16(K) })
        } else {
            Ok(())
        }
    }

    fn to_bytes(self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let (magic, rest) = out.split_at_mut(MAGIC.len());
        magic.copy_from_slice(&MAGIC);
        let w = [
            self.version,
            self.gratings,
            self.ambient,
            self.measurands,
            self.poly_terms,
            self.memory_terms,
            self.centres,
        ];
        for (ch, v) in rest.chunks_exact_mut(2).zip(w.iter()) {
            ch.copy_from_slice(&v.to_le_bytes());
        }
        out
    }
}

fn saturate_u16(v: usize) -> u16 {
    u16::try_from(v).unwrap_or(u16::MAX)
}

/// Postcard writer over a caller's buffer.
struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn put<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Error> {
        let rest = self.buf.get_mut(self.pos..).ok_or(Error::BufferTooSmall)?;
        let n = postcard::to_slice(v, rest).map_err(|_| Error::BufferTooSmall)?.len();
        self.pos += n;
        Ok(())
    }
    fn floats(&mut self, a: &[f32]) -> Result<(), Error> {
        a.iter().try_for_each(|v| self.put(v))
    }
}

/// Encode `params` into `buf`; returns the blob length. Invalid params are refused, so a
/// blob that encodes always decodes. A buffer of [`max_len`]`(K)` bytes always suffices.
pub fn encode<const K: usize>(params: &ModelParams<f32, K>, buf: &mut [u8]) -> Result<usize, Error> {
    params.validate()?;
    encode_unchecked(params, buf)
}

/// [`encode`] without [`ModelParams::validate`]: a blob with a valid CRC for any params, for
/// tests of the decoder's checks.
#[doc(hidden)]
pub fn encode_unchecked<const K: usize>(params: &ModelParams<f32, K>, buf: &mut [u8]) -> Result<usize, Error> {
    let d = &params.dims;
    let centres = u16::try_from(params.centres.len())
        .map_err(|_| Error::TooManyCentres { found: params.centres.len(), capacity: u16::MAX as usize })?;
    let header = Header {
        version: FORMAT_VERSION,
        gratings: d.gratings() as u16,
        ambient: u16::from(d.ambient()),
        measurands: d.n_outputs() as u16,
        poly_terms: d.poly_len() as u16,
        memory_terms: d.memory_len() as u16,
        centres,
    }
    .to_bytes();
    buf.get_mut(..HEADER_LEN).ok_or(Error::BufferTooSmall)?.copy_from_slice(&header);
    let mut w = Writer { buf, pos: HEADER_LEN };
    let (m, s1, np, nz, ne, nm) =
        (d.n_outputs(), d.stage1_len(), d.poly_len(), d.z_len(), d.envelope_len(), d.memory_len());
    for o in d.outputs() {
        w.put(&(o.quantity.code(), o.index))?;
    }
    w.put(&params.hyper)?;
    for row in head_rows(&params.stage1, m) {
        w.floats(head(row, s1))?;
    }
    w.floats(head(&params.guess_mean, m))?;
    w.floats(head(&params.guess_std, m))?;
    for row in head_rows(&params.poly, m) {
        w.floats(head(row, np))?;
    }
    let mem = &params.memory;
    w.floats(&mem.grating_tau_s)?;
    if d.ambient() {
        w.floats(&mem.ambient_tau_s)?;
    }
    w.floats(&mem.play_half_width_pm)?;
    if d.has_observer() {
        w.put(&mem.observer_lag_s)?;
        w.put(&mem.observer_smooth_s)?;
        w.floats(head(&mem.observer_row, s1))?;
    }
    for row in head_rows(&params.gamma, m) {
        w.floats(head(row, nm))?;
    }
    w.floats(head(&params.z_mean, nz))?;
    w.floats(head(&params.z_std, nz))?;
    w.put(&(params.centres.len() as u32))?;
    for c in params.centres.iter() {
        w.floats(head(&c.mu, nz))?;
        w.floats(head(&c.w, m))?;
        w.floats(&c.v)?;
    }
    w.floats(&params.var_inv_g)?;
    w.put(&params.var_inv_g_tail)?;
    w.floats(head(&params.resid_var, m))?;
    w.floats(head(&params.resid_var_growth, m))?;
    w.put(&params.t_cal_end_s)?;
    w.floats(head(&params.band_k, m))?;
    w.floats(head(&params.envelope_lo, ne))?;
    w.floats(head(&params.envelope_hi, ne))?;
    for f in head(&params.fitted, m) {
        w.put(f)?;
    }
    w.put(&params.provenance)?;
    let fc = &params.field;
    for &nm in head(&fc.lambda_ref_nm, d.gratings()) {
        w.put(&nm)?;
    }
    for src in head(&fc.lambda_ref_source, d.gratings()) {
        w.put(&src.code())?;
    }
    w.put(&fc.lambda_ref_tol_pm)?;
    w.put(&fc.cal_end_unix_s)?;
    w.put(&fc.lead_max_s)?;
    w.floats(head(&fc.output_lo, m))?;
    w.floats(head(&fc.output_hi, m))?;
    w.floats(head(&fc.band_max, m))?;
    let tr = &params.trust;
    w.floats(head(&tr.rate_max, ne))?;
    w.floats(head(&tr.quiet_max_s, d.gratings()))?;
    w.floats(head(&tr.fallback_var, m))?;
    w.floats(head(&tr.fallback_var_growth, m))?;
    w.floats(head(&tr.swing_rms_max, ne))?;
    w.floats(head(&tr.speed_rms_max, ne))?;
    w.floats(head(&tr.swing_rms_min, ne))?;
    let end = w.pos;
    let body = buf.get(..end).ok_or(Error::BufferTooSmall)?;
    let crc = crc32c(body).to_le_bytes();
    buf.get_mut(end..end + CRC_LEN).ok_or(Error::BufferTooSmall)?.copy_from_slice(&crc);
    Ok(end + CRC_LEN)
}

fn head_rows<T, const C: usize>(a: &[[T; C]; MAX_OUTPUTS], m: usize) -> &[[T; C]] {
    head(a, m)
}

/// Decode and fully validate a blob into a model of capacity `K`.
///
/// Order of checks:
/// 1. magic and format version (they decide how everything else is read);
/// 2. length and CRC over everything but the 4-byte trailer: a mismatch is reported as
///    [`Error::BadCrc`], as [`Error::Truncated`] when the input is shorter than any blob with
///    the header's dims and centre count, or as [`Error::TrailingBytes`] when a complete blob
///    with a valid CRC is followed by extra bytes;
/// 3. the dims against this build's capacity ([`Error::OverCapacity`]) and each other, then
///    the centre count against the capacity `K` (all now known to be what the writer wrote, so
///    a mismatch is a real one, not corruption);
/// 4. the payload, which must end exactly at the CRC trailer;
/// 5. the payload's output kinds, memory terms and centre count against the header's, then
///    every parameter range.
pub fn decode<const K: usize>(bytes: &[u8]) -> Result<ModelParams<f32, K>, Error> {
    let mut out = ModelParams::default();
    decode_into(bytes, &mut out)?;
    Ok(out)
}

/// [`decode`] into caller-provided storage, without a model-sized temporary: the payload is
/// parsed field by field straight into `out` (the largest temporary is one f32), so a device
/// can decode an update into a staging slot with a small stack. On error `out` holds a
/// partial model and must not be used; on success it is fully validated.
pub fn decode_into<const K: usize>(bytes: &[u8], out: &mut ModelParams<f32, K>) -> Result<(), Error> {
    let parsed = decode_checked::<K, K, MAX_MEMORY>(bytes, out, true)?;
    if out.centres.len() != usize::from(parsed.header.centres) {
        return Err(Error::WrongDims {
            field: "centres",
            found: parsed.header.centres,
            expected: saturate_u16(out.centres.len()),
        });
    }
    out.validate()
}

/// What [`decode_split`] leaves in the blob: the centres, and Γ when the slot holds none.
#[derive(Clone, Debug)]
pub struct SplitBlob<'a> {
    /// The RBF centres.
    pub centres: CentreReader<'a>,
    /// Γ (every entry 0 when the slot holds Γ itself).
    pub gamma: GammaReader<'a>,
}

/// [`decode_into`] for a model of up to `K` centres that leaves the centres, and Γ when `M` is
/// 0, in `bytes`: every other field is parsed into `head` (which holds no centres), and the
/// centres come back as a [`CentreReader`] over the blob, checked as [`decode_into`] checks
/// them (count against the header and `K`, every number within its bound, [`Centre::check`]),
/// Γ as a [`GammaReader`], checked as [`ModelParams::validate`] checks it. With these a device
/// loads a model ([`crate::Compensator::reload_blob`]) with one centre at a time on its stack
/// and no Γ, instead of a whole [`ModelParams`].
pub fn decode_split<'a, const K: usize, const M: usize>(
    bytes: &'a [u8],
    head: &mut ModelParams<f32, 0, M>,
) -> Result<SplitBlob<'a>, Error> {
    let parsed = decode_checked::<K, 0, M>(bytes, head, false)?;
    let reader = parsed.centres;
    if reader.remaining() != usize::from(parsed.header.centres) {
        return Err(Error::WrongDims {
            field: "centres",
            found: parsed.header.centres,
            expected: saturate_u16(reader.remaining()),
        });
    }
    head.validate()?;
    parsed.gamma.check(&head.memory, &head.dims)?;
    reader.checked?;
    Ok(SplitBlob { centres: reader, gamma: parsed.gamma })
}

/// What [`decode_checked`] found.
struct Parsed<'a> {
    header: Header,
    centres: CentreReader<'a>,
    gamma: GammaReader<'a>,
}

/// Steps 1–4 of [`decode`] and the memory-term check of step 5 (not the centre count or the
/// parameter ranges): the centres go into `out` when `store`, else only the reader sees them.
fn decode_checked<'a, const K: usize, const K2: usize, const M: usize>(
    bytes: &'a [u8],
    out: &mut ModelParams<f32, K2, M>,
    store: bool,
) -> Result<Parsed<'a>, Error> {
    // A signed model is a blob followed by its signature trailer: the blob is what is decoded.
    let bytes = crate::container::strip(bytes);
    let header = Header::read(bytes)?;
    header.check_version()?;
    let (head, body) = bytes.split_at_checked(HEADER_LEN).ok_or(Error::Truncated { part: "header" })?;
    // Guarded subtraction: `body` may be shorter than the trailer.
    let payload_len = body.len().checked_sub(CRC_LEN).ok_or(Error::Truncated { part: "payload" })?;
    let (payload, trailer) = body.split_at_checked(payload_len).ok_or(Error::Truncated { part: "payload" })?;
    let crc_ok = crc_of(head, payload) == le_u32(trailer);
    if crc_ok {
        header.check_dims()?;
        header.check_capacity::<K>()?;
    }
    // One parse site: the signed payload when the CRC holds, otherwise everything after the
    // header, to tell a truncated or padded blob from a corrupted one. Parsing unauthenticated
    // bytes is no extra exposure: anyone can write a valid CRC, so the parser is hardened
    // against arbitrary payloads anyway.
    let parsed = parse_into(&header, if crc_ok { payload } else { body }, out, store);
    if !crc_ok {
        return Err(diagnose_crc_mismatch(bytes.len(), header, head, body, parsed.as_ref().map(|r| r.0)));
    }
    // With a valid CRC these bytes are what the writer wrote: a payload that does not decode
    // (including one that claims more bytes than it has) is malformed, not truncated.
    let (rest, centres, gamma) = parsed.map_err(|e| match e {
        ParseError::Dims(e) => e,
        ParseError::Postcard => Error::BadPayload,
    })?;
    if !rest.is_empty() {
        return Err(Error::TrailingBytes { extra: rest.len() });
    }
    if out.dims.memory_len() != usize::from(header.memory_terms) {
        return Err(Error::WrongDims {
            field: "memory_terms",
            found: header.memory_terms,
            expected: saturate_u16(out.dims.memory_len()),
        });
    }
    Ok(Parsed { header, centres, gamma })
}

/// Why a payload did not parse.
#[derive(Clone, Copy, Debug)]
enum ParseError {
    /// Not the postcard layout (or it ran out).
    Postcard,
    /// The output kinds make no valid dims.
    Dims(Error),
}

impl From<postcard::Error> for ParseError {
    fn from(_: postcard::Error) -> Self {
        ParseError::Postcard
    }
}

/// Parse a payload into `out`, one field at a time in the order `encode` writes, with the
/// vector lengths of the header's dims, returning the unread rest. Every capacity-sized array
/// is cleared first, so entries beyond the dims are 0.
#[allow(clippy::type_complexity)]
fn parse_into<'a, const K: usize, const M: usize>(
    header: &Header,
    bytes: &'a [u8],
    out: &mut ModelParams<f32, K, M>,
    store: bool,
) -> Result<(&'a [u8], CentreReader<'a>, GammaReader<'a>), ParseError> {
    fn rows<const C: usize>(
        b: &mut &[u8],
        out: &mut [[f32; C]; MAX_OUTPUTS],
        m: usize,
        n: usize,
    ) -> Result<(), postcard::Error> {
        for row in out.iter_mut() {
            *row = [0.0; C];
        }
        for row in crate::layout::head_mut(out, m) {
            floats(b, crate::layout::head_mut(row, n))?;
        }
        Ok(())
    }
    fn vector<const C: usize>(b: &mut &[u8], out: &mut [f32; C], n: usize) -> Result<(), postcard::Error> {
        *out = [0.0; C];
        floats(b, crate::layout::head_mut(out, n))
    }
    let mut b = bytes;
    let m = usize::from(header.measurands).min(MAX_OUTPUTS);
    let mut kinds = [Output::default(); MAX_OUTPUTS];
    for k in crate::layout::head_mut(&mut kinds, m) {
        let (code, index): (u8, u8) = take(&mut b)?;
        let quantity =
            Quantity::from_code(code).ok_or(ParseError::Dims(Error::BadParameter { field: "dims.outputs" }))?;
        *k = Output { quantity, index };
    }
    let d = Dims::new(usize::from(header.gratings), header.ambient == 1, head(&kinds, m)).map_err(ParseError::Dims)?;
    out.dims = d;
    let (s1, np, nz, ne, nm) = (d.stage1_len(), d.poly_len(), d.z_len(), d.envelope_len(), d.memory_len());
    out.hyper = take(&mut b)?;
    rows(&mut b, &mut out.stage1, m, s1)?;
    vector(&mut b, &mut out.guess_mean, m)?;
    vector(&mut b, &mut out.guess_std, m)?;
    rows(&mut b, &mut out.poly, m, np)?;
    let mem = &mut out.memory;
    *mem = crate::memory::MemorySpec::off();
    floats(&mut b, &mut mem.grating_tau_s)?;
    if d.ambient() {
        floats(&mut b, &mut mem.ambient_tau_s)?;
    }
    floats(&mut b, &mut mem.play_half_width_pm)?;
    if d.has_observer() {
        mem.observer_lag_s = take(&mut b)?;
        mem.observer_smooth_s = take(&mut b)?;
        floats(&mut b, crate::layout::head_mut(&mut mem.observer_row, s1))?;
    }
    // Row by row: a whole-Γ temporary would double the parser's stack frame on the device. A
    // slot without Γ leaves it in the blob (postcard's f32 is its 4 little-endian bytes).
    let gamma = if M == 0 {
        let (g, rest) = b.split_at_checked(m * nm * 4).ok_or(ParseError::Postcard)?;
        b = rest;
        GammaReader { bytes: g, m, n: nm }
    } else {
        rows(&mut b, &mut out.gamma, m, nm)?;
        GammaReader { bytes: &[], m: 0, n: 0 }
    };
    vector(&mut b, &mut out.z_mean, nz)?;
    vector(&mut b, &mut out.z_std, nz)?;
    let n: u32 = take(&mut b)?;
    out.centres.clear();
    let mut centres = CentreReader { bytes: b, left: 0, nz, m, checked: Ok(()) };
    for _ in 0..n {
        let mut c = Centre::<f32>::default();
        b = parse_centre(b, &mut c, nz, m)?;
        centres.left += 1;
        if store {
            out.centres.push(c).map_err(|_| ParseError::Postcard)?;
        } else if centres.checked.is_ok() {
            centres.checked = c.check();
        }
    }
    floats(&mut b, &mut out.var_inv_g)?;
    out.var_inv_g_tail = take(&mut b)?;
    vector(&mut b, &mut out.resid_var, m)?;
    vector(&mut b, &mut out.resid_var_growth, m)?;
    out.t_cal_end_s = take(&mut b)?;
    vector(&mut b, &mut out.band_k, m)?;
    vector(&mut b, &mut out.envelope_lo, ne)?;
    vector(&mut b, &mut out.envelope_hi, ne)?;
    out.fitted = [false; MAX_OUTPUTS];
    for f in crate::layout::head_mut(&mut out.fitted, m) {
        *f = take(&mut b)?;
    }
    out.provenance = take(&mut b)?;
    let fc = &mut out.field;
    *fc = crate::field::FieldContext::unknown();
    let n_g = d.gratings();
    for nm in crate::layout::head_mut(&mut fc.lambda_ref_nm, n_g) {
        *nm = take(&mut b)?;
    }
    for src in crate::layout::head_mut(&mut fc.lambda_ref_source, n_g) {
        let code: u8 = take(&mut b)?;
        *src = crate::field::ZeroSource::from_code(code)
            .ok_or(ParseError::Dims(Error::BadParameter { field: "field.lambda_ref_source" }))?;
    }
    fc.lambda_ref_tol_pm = take(&mut b)?;
    fc.cal_end_unix_s = take(&mut b)?;
    fc.lead_max_s = take(&mut b)?;
    floats(&mut b, crate::layout::head_mut(&mut fc.output_lo, m))?;
    floats(&mut b, crate::layout::head_mut(&mut fc.output_hi, m))?;
    floats(&mut b, crate::layout::head_mut(&mut fc.band_max, m))?;
    let tr = &mut out.trust;
    *tr = crate::trust::TrustSpec::off();
    floats(&mut b, crate::layout::head_mut(&mut tr.rate_max, ne))?;
    floats(&mut b, crate::layout::head_mut(&mut tr.quiet_max_s, n_g))?;
    floats(&mut b, crate::layout::head_mut(&mut tr.fallback_var, m))?;
    floats(&mut b, crate::layout::head_mut(&mut tr.fallback_var_growth, m))?;
    floats(&mut b, crate::layout::head_mut(&mut tr.swing_rms_max, ne))?;
    floats(&mut b, crate::layout::head_mut(&mut tr.speed_rms_max, ne))?;
    floats(&mut b, crate::layout::head_mut(&mut tr.swing_rms_min, ne))?;
    Ok((b, centres, gamma))
}

fn crc_of(head: &[u8], payload: &[u8]) -> u32 {
    let mut digest = Crc32c::new();
    digest.update(head);
    digest.update(payload);
    digest.finish()
}

/// Little-endian u32 of the first four bytes (0 when shorter; callers pass four).
fn le_u32(b: &[u8]) -> u32 {
    let mut t = [0u8; CRC_LEN];
    for (o, &v) in t.iter_mut().zip(b.iter()) {
        *o = v;
    }
    u32::from_le_bytes(t)
}

/// Name a CRC mismatch over the whole input. `parsed` is the remainder after parsing a
/// payload from everything after the header (trailer included).
///
/// - The payload parses and the 4 bytes after it are its valid CRC, with more bytes after
///   them: a complete blob with something appended ([`Error::TrailingBytes`]).
/// - The input is shorter than the smallest blob with the header's dims and centre count and
///   the payload or its CRC runs out: a cut blob ([`Error::Truncated`]). A payload byte flip
///   can also make the parse run out, so longer inputs are never called truncated.
/// - Anything else is corruption ([`Error::BadCrc`]).
fn diagnose_crc_mismatch(
    len: usize,
    header: Header,
    head: &[u8],
    body: &[u8],
    parsed: Result<&[u8], &ParseError>,
) -> Error {
    let (lo, hi) = header.memory_range();
    let observer = usize::from(header.memory_terms) == hi && hi > lo;
    let short = len
        < min_len_of(
            usize::from(header.gratings),
            header.ambient == 1,
            usize::from(header.measurands),
            observer,
            usize::from(header.centres),
        );
    match parsed {
        Ok(rest) => {
            let used = body.len().saturating_sub(rest.len());
            match (body.get(..used), rest.get(..CRC_LEN)) {
                (Some(payload), Some(trailer)) if rest.len() > CRC_LEN && crc_of(head, payload) == le_u32(trailer) => {
                    Error::TrailingBytes { extra: rest.len().saturating_sub(CRC_LEN) }
                }
                (_, None) if short => Error::Truncated { part: "crc" },
                _ => Error::BadCrc,
            }
        }
        Err(_) if short => Error::Truncated { part: "payload" },
        Err(_) => Error::BadCrc,
    }
}

/// Bytes of postcard's varint encoding of `v` (canonical, as the encoder writes it).
const fn varint_len(mut v: usize) -> usize {
    let mut n = 1;
    while v >= 0x80 {
        v >>= 7;
        n += 1;
    }
    n
}

/// Exact length of the shortest blob with these dims (`observer`: the memory vector has the
/// drift observer's slot) and `centres` centres: every f32 is 4 bytes in postcard; the
/// feature-set tag, the output kinds, seed, date, sample count and both string lengths take one
/// byte each with empty strings; the centre count is a varint. Saturates instead of
/// overflowing for absurd `centres`.
pub const fn min_len_of(gratings: usize, ambient: bool, m: usize, observer: bool, centres: usize) -> usize {
    let amb = ambient as usize;
    let s1 = gratings + amb + 1;
    let poly = crate::layout::poly_len(m);
    let z = 2 * gratings + amb + 1;
    let env = gratings + amb;
    let mem_terms = gratings * (N_GRATING_TAUS + N_PLAYS) + amb * N_AMBIENT_TAUS + observer as usize;
    let spec = N_GRATING_TAUS + amb * N_AMBIENT_TAUS + N_PLAYS + if observer { 2 + s1 } else { 0 };
    let hyper = 1 + 7 * 4;
    let fixed_f32 = m * s1 + 2 * m + m * poly + spec + m * mem_terms + 2 * z + VAR_RANK + 1 + m + m + 1 + m + 2 * env;
    let per_centre = 4 * (z + m + VAR_RANK);
    // Field context: λ_ref (8 bytes per grating) and its source (1), the tolerance and the
    // largest lead (4 each), the end of calibration (1 byte when absent), the output envelope
    // and largest band (M f32 each).
    let field = 9 * gratings + 4 + 1 + 4 + 4 * 3 * m;
    // Trust ([`crate::trust::TrustSpec`]): a rate limit per envelope input, a quiet time per
    // grating, the fallback band and its growth (M each), the largest swing and speed and the
    // smallest swing per envelope input, all f32.
    let trust = 4 * (env + gratings + 2 * m + 3 * env);
    // Output kinds: two bytes each; `fitted`: one byte per output; provenance: five one-byte
    // minimums.
    let bytes = 2 * m + m + 5 + field + trust;
    let fixed = HEADER_LEN + hyper + 4 * fixed_f32 + bytes + CRC_LEN;
    fixed.saturating_add(varint_len(centres)).saturating_add(per_centre.saturating_mul(centres))
}

/// [`min_len_of`] for a model's dims.
pub fn min_len(dims: &Dims, centres: usize) -> usize {
    min_len_of(dims.gratings(), dims.ambient(), dims.n_outputs(), dims.has_observer(), centres)
}

/// Extra bytes of the longest provenance over the shortest: a 10-byte seed varint (+9), 5-byte
/// date and sample-count varints (+4 each) and full provenance strings (24 + 16 bytes; their
/// length varints stay one byte); and a known end of calibration (+8).
const LONG_PROVENANCE: usize = 9 + 4 + 4 + 24 + 16 + 8;

/// Exact length of the longest blob [`encode`] writes for `centres` centres at any dims within
/// the capacity (for sizing buffers): [`min_len_of`] at the capacity (every grating, ambient,
/// every output, the observer) plus the longest provenance.
pub const fn max_len(centres: usize) -> usize {
    min_len_of(MAX_GRATINGS, true, MAX_OUTPUTS, true, centres).saturating_add(LONG_PROVENANCE)
}

/// Exact length of the longest blob of these dims with `centres` centres.
pub fn max_len_for(dims: &Dims, centres: usize) -> usize {
    min_len(dims, centres).saturating_add(LONG_PROVENANCE)
}
