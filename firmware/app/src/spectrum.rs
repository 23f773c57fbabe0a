//! Spectrum frames in, samples out: the device's side of [`fbg_shared::protocol`]'s spectrum
//! messages.
//!
//! The host sets the detector up ([`HostMsg::SpectrumGrid`](fbg_shared::protocol::HostMsg),
//! then one `SpectrumGrating` per grating of the model), then sends each channel's frame as a
//! `SpectrumBegin` and in-order `SpectrumPixels` chunks. The device keeps no frame buffer: of
//! each chunk it copies only the pixels inside the windows of the gratings on the frame's
//! channel into [`KEPT_PIXELS`] u16 (the windows of one channel together). When a frame's last
//! pixel arrives, each of its gratings' peaks is found in f32 by cross-correlation (the
//! default method, the only one the device runs: a set-up naming another is refused)
//! ([`DetectorConfig::detect_with`] on a [`Spectrum::part`] holding the window's pixels: the very
//! peak the whole frame gives) and turned into a shift Δλ = (λ − λ_ref)·1000 pm
//! ([`ShiftRef`]). Once every grating has a peak from frames of one `t_s`, the frame that
//! completed them yields the [`Sample`] (with that frame's T_amb) and the peaks' flags for the
//! estimate ([`PeakFlags::estimate_flags`]).
//!
//! The set-up is held in RAM only: a reset forgets it (the host sends it again, as it resets
//! the stream after connecting). It is not a calibration: nothing the device measures depends
//! on it but through the peaks, and keeping it in flash would cost a write per set-up.
//!
//! No heap, no panicking paths.

use fbg_shared::layout::MAX_GRATINGS;
use fbg_shared::protocol::{SpectrumError, SpectrumRefusal, SpectrumStatus, MAX_FRAME_PIXELS};
use fbg_shared::spectrum::correlation::cross_correlation;
use fbg_shared::spectrum::{DetectorConfig, Grid, Method, PeakFlags, ShiftRef, Span, Spectrum, Window, POLY_COEFFS};
use fbg_shared::{Flags, Sample};

/// Pixels the device keeps of one channel's frame: the windows of the gratings on one channel
/// together (2 bytes each). At 0.166 nm per pixel (512 pixels over 85 nm) a ±2 nm window is
/// 25 pixels.
pub const KEPT_PIXELS: usize = 128;

/// Most pixels of one window (detection converts them to f32 on the stack, 4 bytes each).
pub const MAX_WINDOW_PIXELS: usize = 64;

/// The grid part of the set-up, as `SpectrumGrid` carries it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSetup {
    /// The model's gratings (1 to 8).
    pub gratings: u8,
    /// Pixels per frame.
    pub pixels: u16,
    /// Uniform (c₀ + c₁·p) or polynomial.
    pub uniform: bool,
    /// c₀ … c₅ \[nm/pixelᵏ\].
    pub coefficients: [f32; POLY_COEFFS],
    /// [`Method::code`].
    pub method: u8,
    /// Full scale \[counts\].
    pub full_scale: f32,
}

/// One grating of the set-up, as `SpectrumGrating` carries it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GratingSetup {
    /// Position among the model's gratings.
    pub index: u8,
    /// Spectrometer channel.
    pub channel: u8,
    /// Search window \[nm\].
    pub window: Window<f32>,
    /// λ_ref.
    pub shift: ShiftRef<f32>,
}

/// A grating as kept: its channel, its window's pixels (the span found at set-up), λ_ref and
/// where its pixels go.
#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    channel: u8,
    /// First pixel of the window on the grid.
    first: u16,
    /// Pixels of the window (0: not set up).
    len: u16,
    /// Where the window's pixels start in the kept pixels.
    at: u16,
    shift: ShiftRef<f32>,
}

/// The frame being received.
#[derive(Clone, Copy, Debug, Default)]
struct Frame {
    active: bool,
    channel: u8,
    seq: u32,
    t_s: f32,
    t_amb_c: f32,
    received: u16,
}

/// What one spectrum message came to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// The set-up was taken; gratings still missing.
    Set(u8),
    /// Pixels of the frame received so far (no reading complete).
    Ack(u16),
    /// A reading is complete: compensate this sample and add these flags to its estimate.
    Reading {
        /// The frame's `seq`.
        seq: u32,
        /// The shifts of every grating, T_amb and t.
        sample: Sample<f32>,
        /// From the peaks' quality flags.
        flags: Flags,
    },
    /// Refused.
    Refused(SpectrumRefusal),
}

/// The device's spectrum state: set-up, the frame in progress, the kept pixels and the peaks
/// of the reading being assembled.
#[derive(Clone, Debug)]
pub struct SpectrumFront {
    config: DetectorConfig<f32>,
    grid: Grid<f32>,
    pixels: u16,
    gratings: u8,
    /// Bit g: grating g is set up.
    set: u8,
    slots: [Slot; MAX_GRATINGS],
    frame: Frame,
    kept: [u16; KEPT_PIXELS],
    /// The reading being assembled: its time, which gratings have a peak, their shifts and
    /// flags.
    reading_t_s: f32,
    have: u8,
    shifts: [f32; MAX_GRATINGS],
    peak_flags: PeakFlags,
    status: SpectrumStatus,
}

impl Default for SpectrumFront {
    fn default() -> Self {
        Self::new()
    }
}

fn refuse(reason: SpectrumError, detail: u16) -> Outcome {
    Outcome::Refused(SpectrumRefusal::new(reason, detail))
}

fn mask(n: u8) -> u8 {
    u8::try_from((1u16 << n.min(8)) - 1).unwrap_or(u8::MAX)
}

impl SpectrumFront {
    /// Nothing set up.
    pub fn new() -> Self {
        SpectrumFront {
            config: DetectorConfig::default(),
            grid: Grid::Uniform { start_nm: 0.0, step_nm: 0.0 },
            pixels: 0,
            gratings: 0,
            set: 0,
            slots: [Slot { channel: 0, first: 0, len: 0, at: 0, shift: ShiftRef { hi_nm: 0.0, lo_nm: 0.0 } };
                MAX_GRATINGS],
            frame: Frame { active: false, channel: 0, seq: 0, t_s: 0.0, t_amb_c: 0.0, received: 0 },
            kept: [0; KEPT_PIXELS],
            reading_t_s: f32::NAN,
            have: 0,
            shifts: [0.0; MAX_GRATINGS],
            peak_flags: PeakFlags::OK,
            status: SpectrumStatus { frames: 0, frames_dropped: 0, refused: 0, last_refusal: None },
        }
    }

    /// The counters.
    pub fn status(&self) -> SpectrumStatus {
        self.status
    }

    /// Count a refusal.
    fn counted(&mut self, out: Outcome) -> Outcome {
        if let Outcome::Refused(r) = out {
            self.status.refused = self.status.refused.wrapping_add(1);
            self.status.last_refusal = Some(r);
        }
        out
    }

    /// `SpectrumGrid`: a new set-up (every grating, frame and peak forgotten).
    pub fn grid(&mut self, g: &GridSetup) -> Outcome {
        let out = self.grid_inner(g);
        self.counted(out)
    }

    fn grid_inner(&mut self, g: &GridSetup) -> Outcome {
        self.drop_frame();
        self.gratings = 0;
        self.set = 0;
        self.have = 0;
        if g.gratings == 0 || usize::from(g.gratings) > MAX_GRATINGS {
            return refuse(SpectrumError::BadGrid, 1);
        }
        if g.pixels == 0 || g.pixels > MAX_FRAME_PIXELS {
            return refuse(SpectrumError::BadGrid, 2);
        }
        let [c0, c1, ..] = g.coefficients;
        if !g.coefficients.iter().all(|c| c.is_finite()) || c1 == 0.0 {
            return refuse(SpectrumError::BadGrid, 3);
        }
        // The device runs the default method only (the others' code would not fit the board's
        // flash): any other is refused like an unknown one.
        if Method::from_code(g.method) != Some(Method::CrossCorrelation) {
            return refuse(SpectrumError::BadGrid, 4);
        }
        let method = Method::CrossCorrelation;
        if g.full_scale.is_nan() || g.full_scale <= 0.0 {
            return refuse(SpectrumError::BadGrid, 5);
        }
        self.grid = if g.uniform { Grid::uniform(c0, c1) } else { Grid::polynomial(g.coefficients) };
        self.config = DetectorConfig { method, full_scale: g.full_scale, ..DetectorConfig::default() };
        self.pixels = g.pixels;
        self.gratings = g.gratings;
        Outcome::Set(g.gratings)
    }

    /// `SpectrumGrating`: one grating's channel, window and λ_ref.
    pub fn grating(&mut self, g: &GratingSetup) -> Outcome {
        let out = self.grating_inner(g);
        self.counted(out)
    }

    fn grating_inner(&mut self, g: &GratingSetup) -> Outcome {
        self.drop_frame();
        self.have = 0;
        let bad = refuse(SpectrumError::BadGrating, u16::from(g.index));
        if g.index >= self.gratings || !(g.shift.hi_nm.is_finite() && g.shift.lo_nm.is_finite()) {
            return bad;
        }
        let Some(span) = g.window.span_of(&self.grid, 0, usize::from(self.pixels)) else { return bad };
        let len = span.last.saturating_sub(span.first).saturating_add(1);
        if len > MAX_WINDOW_PIXELS {
            return refuse(SpectrumError::OverCapacity, u16::try_from(len).unwrap_or(u16::MAX));
        }
        let bit = 1u8 << g.index;
        self.set &= !bit;
        // The kept pixels are laid out per channel: this grating goes after the others of
        // its channel.
        let at: usize = self
            .slots
            .iter()
            .enumerate()
            .filter(|&(k, s)| self.set & (1 << k) != 0 && s.channel == g.channel)
            .map(|(_, s)| usize::from(s.len))
            .sum();
        if at + len > KEPT_PIXELS {
            return refuse(SpectrumError::OverCapacity, u16::try_from(at + len).unwrap_or(u16::MAX));
        }
        let Some(slot) = self.slots.get_mut(usize::from(g.index)) else { return bad };
        // Within MAX_FRAME_PIXELS and KEPT_PIXELS, so every value fits a u16.
        *slot = Slot {
            channel: g.channel,
            first: u16::try_from(span.first).unwrap_or(u16::MAX),
            len: u16::try_from(len).unwrap_or(0),
            at: u16::try_from(at).unwrap_or(0),
            shift: g.shift,
        };
        self.set |= bit;
        Outcome::Set(self.missing())
    }

    /// Gratings not set up yet.
    fn missing(&self) -> u8 {
        (mask(self.gratings) & !self.set).count_ones() as u8
    }

    fn drop_frame(&mut self) {
        if self.frame.active {
            self.status.frames_dropped = self.status.frames_dropped.wrapping_add(1);
        }
        self.frame.active = false;
    }

    /// `SpectrumBegin`: a channel's frame starts (one in progress is dropped).
    pub fn begin(&mut self, seq: u32, channel: u8, t_s: f32, t_amb_c: f32) -> Outcome {
        self.drop_frame();
        let missing = self.missing();
        if self.gratings == 0 || missing != 0 {
            let out = refuse(SpectrumError::NotSetUp, u16::from(if self.gratings == 0 { 8 } else { missing }));
            return self.counted(out);
        }
        self.frame = Frame { active: true, channel, seq, t_s, t_amb_c, received: 0 };
        Outcome::Ack(0)
    }

    /// `SpectrumPixels`: the next pixels of the frame (little-endian u16). The last one
    /// detects the frame's peaks; see [`Outcome`].
    pub fn pixels(&mut self, first_pixel: u16, data: &[u8]) -> Outcome {
        let out = self.pixels_inner(first_pixel, data);
        self.counted(out)
    }

    fn pixels_inner(&mut self, first_pixel: u16, data: &[u8]) -> Outcome {
        if !self.frame.active {
            return refuse(SpectrumError::NoFrame, 0);
        }
        if first_pixel != self.frame.received {
            let expected = self.frame.received;
            self.drop_frame();
            return refuse(SpectrumError::OutOfOrder, expected);
        }
        let n = data.len() / 2;
        let end = usize::from(first_pixel) + n;
        if !data.len().is_multiple_of(2) || end > usize::from(self.pixels) {
            self.drop_frame();
            return refuse(SpectrumError::Overrun, u16::try_from(end).unwrap_or(u16::MAX));
        }
        self.keep(usize::from(first_pixel), data);
        // end ≤ pixels ≤ MAX_FRAME_PIXELS.
        self.frame.received = u16::try_from(end).unwrap_or(u16::MAX);
        if self.frame.received < self.pixels {
            return Outcome::Ack(self.frame.received);
        }
        self.frame.active = false;
        self.status.frames = self.status.frames.wrapping_add(1);
        self.complete()
    }

    /// Copy the pixels of `data` (pixels `first ..`) that lie in a window of the frame's
    /// channel.
    fn keep(&mut self, first: usize, data: &[u8]) {
        let end = first + data.len() / 2;
        let channel = self.frame.channel;
        for (k, s) in self.slots.iter().enumerate() {
            if self.set & (1 << k) == 0 || s.channel != channel {
                continue;
            }
            let (w0, w1) = (usize::from(s.first), usize::from(s.first) + usize::from(s.len));
            let (a, b) = (w0.max(first), w1.min(end));
            if a >= b {
                continue;
            }
            let dst_at = usize::from(s.at) + (a - w0);
            let src = data.get(2 * (a - first)..2 * (b - first)).unwrap_or(&[]);
            let dst = self.kept.get_mut(dst_at..dst_at + (b - a)).unwrap_or(&mut []);
            for (d, px) in dst.iter_mut().zip(src.chunks_exact(2)) {
                if let [lo, hi] = *px {
                    *d = u16::from_le_bytes([lo, hi]);
                }
            }
        }
    }

    /// The frame is complete: detect its gratings' peaks, and form the reading when every
    /// grating has one from this `t_s`.
    fn complete(&mut self) -> Outcome {
        let t_s = self.frame.t_s;
        if t_s.to_bits() != self.reading_t_s.to_bits() {
            self.reading_t_s = t_s;
            self.have = 0;
            self.peak_flags = PeakFlags::OK;
        }
        let channel = self.frame.channel;
        for k in 0..MAX_GRATINGS {
            let Some(&s) = self.slots.get(k) else { break };
            if self.set & (1 << k) == 0 || s.channel != channel {
                continue;
            }
            let (dl, flags) = self.detect(&s);
            if let Some(v) = self.shifts.get_mut(k) {
                *v = dl;
            }
            self.peak_flags.insert(flags);
            self.have |= 1 << k;
        }
        let all = mask(self.gratings);
        if self.have & all != all {
            return Outcome::Ack(self.frame.received);
        }
        self.have = 0;
        let n = usize::from(self.gratings);
        let shifts = self.shifts.get(..n).unwrap_or(&[]);
        let Ok(sample) = Sample::from_slice(shifts, self.frame.t_amb_c, t_s) else {
            return Outcome::Ack(self.frame.received);
        };
        let flags = self.peak_flags.estimate_flags();
        self.peak_flags = PeakFlags::OK;
        Outcome::Reading { seq: self.frame.seq, sample, flags }
    }

    /// One grating's shift \[pm\] and peak flags, from its kept pixels. Never inlined: the
    /// window's f32 copy and the detector's frames are gone before the step runs.
    #[inline(never)]
    fn detect(&self, s: &Slot) -> (f32, PeakFlags) {
        let mut buf = [0f32; MAX_WINDOW_PIXELS];
        let at = usize::from(s.at);
        let len = usize::from(s.len);
        let src = self.kept.get(at..at + len).unwrap_or(&[]);
        for (d, &v) in buf.iter_mut().zip(src) {
            *d = f32::from(v);
        }
        let samples = buf.get(..src.len()).unwrap_or(&[]);
        let part = Spectrum::part(samples, self.grid, usize::from(s.first));
        // The span the window's set-up found (`grating`), not found again per frame.
        let span = Span { first: usize::from(s.first), last: (usize::from(s.first) + len).saturating_sub(1) };
        let peak = self.config.detect_span(&part, span, cross_correlation);
        (s.shift.shift_pm(peak.wavelength_nm), peak.flags)
    }
}
