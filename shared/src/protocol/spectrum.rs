//! Spectrum frames on the link: the detector's set-up, the frames in chunks, why a device
//! refuses one, and its counters.
//!
//! A spectrometer frame (one channel, one time, N pixels as u16: a 512-pixel frame is 1 KiB)
//! is larger than a host frame ([`super::HOST_MAX_FRAME`]), so it travels as a
//! [`super::HostMsg::SpectrumBegin`] followed by [`super::HostMsg::SpectrumPixels`] chunks of
//! at most [`super::MAX_PIXELS_PER_CHUNK`] pixels, in order. The device keeps only the pixels inside
//! its gratings' search windows. Before any frame the host sets the detector up:
//! [`super::HostMsg::SpectrumGrid`] (the pixel-to-wavelength grid, the frame's pixel count, the
//! method, the full scale, the number of gratings) and one [`super::HostMsg::SpectrumGrating`]
//! per grating of the model, in the model's order (its channel, window and λ_ref).

use serde::{Deserialize, Serialize};

/// Most pixels in a frame (the set-up's `pixels`).
pub const MAX_FRAME_PIXELS: u16 = 16_384;

/// Why a device refused a spectrum message. The order (the code on the wire) never changes;
/// new reasons go at the end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpectrumError {
    /// A frame arrived before every grating was set up (detail: the gratings still missing).
    NotSetUp,
    /// The grid message is unusable (detail: 1 no or too many gratings, 2 a pixel count of 0
    /// or above [`MAX_FRAME_PIXELS`], 3 a coefficient not finite or a zero spacing, 4 an
    /// unknown method, 5 a full scale that is not positive).
    BadGrid,
    /// A grating message is unusable: its index is not below the grid's gratings, its window
    /// or λ_ref is not finite, or the window holds fewer than three pixels of the grid
    /// (detail: the index).
    BadGrating,
    /// The windows of one channel need more pixels than the device keeps (detail: the pixels
    /// they need).
    OverCapacity,
    /// Pixels without a frame begun (or after the frame was complete).
    NoFrame,
    /// Pixels whose first pixel is not the number received so far (detail: the one expected).
    /// The frame is dropped.
    OutOfOrder,
    /// Pixels past the frame's pixel count, or an odd number of bytes (detail: the end
    /// pixel). The frame is dropped.
    Overrun,
    /// This device was built without spectrum frames (a build whose flash has no room for the
    /// detector).
    Unsupported,
}

/// A refused spectrum message: the reason and a number that says more.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SpectrumRefusal {
    /// Why.
    pub reason: SpectrumError,
    /// What, per reason.
    pub detail: u16,
}

impl SpectrumRefusal {
    /// `reason` with `detail`.
    pub const fn new(reason: SpectrumError, detail: u16) -> Self {
        SpectrumRefusal { reason, detail }
    }
}

/// The spectrum part of [`super::Status`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SpectrumStatus {
    /// Channel frames received whole (every pixel, in order).
    pub frames: u32,
    /// Frames begun but never completed (a new begin, or a refused chunk, dropped them).
    pub frames_dropped: u32,
    /// Spectrum messages refused (set-up and frames).
    pub refused: u32,
    /// The most recent refusal.
    pub last_refusal: Option<SpectrumRefusal>,
}
