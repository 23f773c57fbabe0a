//! Spectrum frames over the link: the detector's set-up, frames sent in chunks, and the host's
//! own reading of the same frames (what a device must answer, bit for bit in f32).

use fbg_shared::protocol::{DeviceEstimate, DeviceMsg, HostMsg, SpectrumRefusal, MAX_PIXELS_PER_CHUNK};
use fbg_shared::spectrum::{DetectorConfig, Grid, Method, PeakFlags, ShiftRef, Spectrum, Window, POLY_COEFFS};
use fbg_shared::{Compensator, Estimate, Flags, Sample};

use crate::client::{LinkClient, LinkError};

/// One grating of a spectrum set-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GratingSpec {
    /// Spectrometer channel.
    pub channel: u8,
    /// Search window \[nm\].
    pub window: Window<f32>,
    /// λ_ref \[nm\] (the model's, [`fbg_shared::FieldContext::lambda_ref`]).
    pub lambda_ref_nm: f64,
}

/// The detector's set-up, as the host sends it ([`LinkClient::setup_spectrum`]) and applies it
/// itself ([`SpectrumSetup::reading`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumSetup {
    /// The pixel-to-wavelength grid.
    pub grid: Grid<f32>,
    /// Pixels per frame.
    pub pixels: u16,
    /// The method.
    pub method: Method,
    /// Full scale \[counts\].
    pub full_scale: f32,
    /// The model's gratings, in its order.
    pub gratings: Vec<GratingSpec>,
}

/// A device's answer to one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrameAnswer {
    /// The frame was taken; the reading needs more channels.
    Pending,
    /// The frame completed a reading: its estimate.
    Estimate(DeviceEstimate),
}

/// Why a spectrum exchange failed.
#[derive(Debug)]
pub enum SpectrumLinkError {
    /// The link failed.
    Link(LinkError),
    /// The device refused a message.
    Refused(SpectrumRefusal),
}

impl core::fmt::Display for SpectrumLinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SpectrumLinkError::Link(e) => write!(f, "{e}"),
            SpectrumLinkError::Refused(r) => write!(f, "the device refused a spectrum message: {r:?}"),
        }
    }
}

impl std::error::Error for SpectrumLinkError {}

impl From<LinkError> for SpectrumLinkError {
    fn from(e: LinkError) -> Self {
        SpectrumLinkError::Link(e)
    }
}

fn unexpected(expected: &'static str, got: DeviceMsg) -> SpectrumLinkError {
    match got {
        DeviceMsg::SpectrumRefused(r) => SpectrumLinkError::Refused(r),
        got => SpectrumLinkError::Link(LinkError::Unexpected { expected, got: Box::new(got) }),
    }
}

impl SpectrumSetup {
    /// The set-up's messages: the grid, then each grating.
    pub fn messages(&self) -> Vec<HostMsg<'static>> {
        let (uniform, coefficients) = match self.grid {
            Grid::Uniform { start_nm, step_nm } => {
                let mut c = [0.0f32; POLY_COEFFS];
                c[0] = start_nm;
                c[1] = step_nm;
                (true, c)
            }
            Grid::Polynomial { coefficients } => (false, coefficients),
        };
        let mut out = vec![HostMsg::SpectrumGrid {
            gratings: self.gratings.len() as u8,
            pixels: self.pixels,
            uniform,
            coefficients,
            method: self.method.code(),
            full_scale: self.full_scale,
        }];
        for (k, g) in self.gratings.iter().enumerate() {
            let r = ShiftRef::<f32>::from_nm(g.lambda_ref_nm);
            out.push(HostMsg::SpectrumGrating {
                index: k as u8,
                channel: g.channel,
                lo_nm: g.window.lo_nm,
                hi_nm: g.window.hi_nm,
                ref_hi_nm: r.hi_nm,
                ref_lo_nm: r.lo_nm,
            });
        }
        out
    }

    /// The detector settings the device uses with this set-up.
    pub fn config(&self) -> DetectorConfig<f32> {
        DetectorConfig { method: self.method, full_scale: self.full_scale, ..DetectorConfig::default() }
    }

    /// The host's reading of one acquisition — `frames[c]` the frame of channel `c` — as the
    /// device forms it: each grating's peak in f32 on the whole frame, its shift from λ_ref
    /// ([`ShiftRef`]), the sample with `t_amb_c` and `t_s`, and the peaks' flags for the
    /// estimate. A channel without a frame gives its gratings NaN shifts.
    pub fn reading(&self, frames: &[&[u16]], t_amb_c: f32, t_s: f32) -> (Sample<f32>, Flags) {
        let config = self.config();
        let mut shifts = Vec::with_capacity(self.gratings.len());
        let mut flags = PeakFlags::OK;
        for g in &self.gratings {
            let Some(frame) = frames.get(usize::from(g.channel)) else {
                shifts.push(f32::NAN);
                continue;
            };
            let samples: Vec<f32> = frame.iter().map(|&v| f32::from(v)).collect();
            let peak = config.detect(&Spectrum::new(&samples, self.grid), &g.window);
            flags.insert(peak.flags);
            shifts.push(ShiftRef::<f32>::from_nm(g.lambda_ref_nm).shift_pm(peak.wavelength_nm));
        }
        let sample = Sample::from_slice(&shifts, t_amb_c, t_s).unwrap_or(Sample::new([f32::NAN], t_amb_c, t_s));
        (sample, flags.estimate_flags())
    }

    /// The host's estimate of one acquisition: [`SpectrumSetup::reading`] stepped through
    /// `comp` (f32, like the device), the peaks' flags added.
    pub fn estimate<const K: usize>(
        &self,
        comp: &mut Compensator<f32, K>,
        frames: &[&[u16]],
        t_amb_c: f32,
        t_s: f32,
    ) -> Estimate<f32> {
        let (sample, flags) = self.reading(frames, t_amb_c, t_s);
        let mut e = comp.step(&sample);
        e.flags.insert(flags);
        e
    }
}

impl<S: std::io::Read + std::io::Write> LinkClient<S> {
    /// Send the detector's set-up; every message must be taken.
    pub fn setup_spectrum(&mut self, setup: &SpectrumSetup) -> Result<(), SpectrumLinkError> {
        let msgs = setup.messages();
        let last = msgs.len().saturating_sub(1);
        for (k, m) in msgs.iter().enumerate() {
            match self.request(m)? {
                DeviceMsg::SpectrumSet { missing } if k < last || missing == 0 => {}
                got => return Err(unexpected("SpectrumSet", got)),
            }
        }
        Ok(())
    }

    /// Send one channel's frame (`SpectrumBegin`, then chunks of at most `chunk` ≤
    /// [`MAX_PIXELS_PER_CHUNK`] pixels) and return what its last message was answered with.
    pub fn send_frame(
        &mut self,
        seq: u32,
        channel: u8,
        t_s: f32,
        t_amb_c: f32,
        pixels: &[u16],
        chunk: usize,
    ) -> Result<FrameAnswer, SpectrumLinkError> {
        match self.request(&HostMsg::SpectrumBegin { seq, channel, t_s, t_amb_c })? {
            DeviceMsg::SpectrumAck { received: 0 } => {}
            got => return Err(unexpected("SpectrumAck after SpectrumBegin", got)),
        }
        let chunk = chunk.clamp(1, MAX_PIXELS_PER_CHUNK);
        let mut bytes = Vec::with_capacity(2 * chunk);
        let mut answer = FrameAnswer::Pending;
        for (k, part) in pixels.chunks(chunk).enumerate() {
            bytes.clear();
            bytes.extend(part.iter().flat_map(|v| v.to_le_bytes()));
            let first_pixel = u16::try_from(k * chunk).map_err(|_| LinkError::TooLarge)?;
            answer = match self.request(&HostMsg::SpectrumPixels { first_pixel, data: &bytes })? {
                DeviceMsg::SpectrumAck { .. } => FrameAnswer::Pending,
                DeviceMsg::Estimate(e) if e.seq == seq => FrameAnswer::Estimate(e),
                got => return Err(unexpected("SpectrumAck or Estimate", got)),
            };
        }
        Ok(answer)
    }
}

/// A 16-bit detector's full scale \[counts\].
pub const FULL_SCALE_COUNTS: f64 = 65_535.0;

/// A frame's counts: each pixel's `signal` above the `floor`, plus the `noise` drawn for it,
/// rounded to the nearest count and clamped to 0..=[`FULL_SCALE_COUNTS`] (a saturated pixel
/// reads full scale). Every simulated frame, the trainer's and the tests', is exposed here.
pub fn expose(signal: impl IntoIterator<Item = f64>, floor: f64, mut noise: impl FnMut() -> f64, out: &mut Vec<u16>) {
    out.clear();
    out.extend(signal.into_iter().map(|s| (floor + s + noise()).round().clamp(0.0, FULL_SCALE_COUNTS) as u16));
}

/// A simulated spectrometer frame for tests: Gaussian peaks `(λ nm, FWHM nm, height counts)` on
/// a `floor` \[counts\], white noise of σ `noise` \[counts\] from `seed` (deterministic: a
/// 64-bit LCG, the sum of four uniforms as the normal deviate), rounded and clipped to u16.
pub fn synthetic_frame(
    grid: &Grid<f32>,
    pixels: u16,
    peaks: &[(f64, f64, f64)],
    floor: f64,
    noise: f64,
    seed: u64,
) -> Vec<u16> {
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
    let mut uniform = move || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let signal = (0..pixels).map(|p| {
        let lambda = f64::from(grid.wavelength(f32::from(p)));
        peaks
            .iter()
            .map(|&(c, fwhm, h)| {
                let z = (lambda - c) / (fwhm / 2.354_820_045);
                h * (-0.5 * z * z).exp()
            })
            .sum::<f64>()
    });
    // Four uniforms: mean 2, variance 1/3.
    let deviate = move || noise * (((uniform() + uniform() + uniform() + uniform()) - 2.0) * 3.0f64.sqrt());
    let mut out = Vec::with_capacity(usize::from(pixels));
    expose(signal, floor, deviate, &mut out);
    out
}
