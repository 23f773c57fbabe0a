//! Quality flags of one detected peak.

use crate::flags::Flags;

/// Bit set of a peak's quality flags. `PeakFlags::OK` (no bit) is a clean peak.
///
/// [`PeakFlags::FAULTS`] are the bits that make the wavelength itself suspect (nothing found,
/// clipped, a neighbour in the window, at the window's edge); the others describe a peak whose
/// wavelength is usable but whose shape or level is off what the detector expects.
///
/// A window without a peak gives a NaN wavelength, so a reading built from it raises the
/// compensator's [`crate::Flags::NON_FINITE`]: that is how [`PeakFlags::NO_PEAK`] reaches the
/// compensator's flags without a bit of its own.
///
/// ```
/// use fbg_shared::spectrum::PeakFlags;
/// let mut f = PeakFlags::OK;
/// f.insert(PeakFlags::LOW_SNR);
/// assert!(!f.is_ok() && !f.is_fault());
/// f.insert(PeakFlags::SECOND_PEAK);
/// assert!(f.is_fault());
/// assert_eq!(f.to_string(), "low-snr|second-peak");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PeakFlags(pub u8);

impl PeakFlags {
    /// No flag raised.
    pub const OK: PeakFlags = PeakFlags(0);
    /// No peak: the window holds fewer than three samples of the spectrum, a sample in it is
    /// not finite, or its maximum does not rise above the noise floor by the detector's
    /// `no_peak_snr`. The wavelength is NaN.
    pub const NO_PEAK: PeakFlags = PeakFlags(1 << 0);
    /// The peak's SNR (height above the floor over the noise σ) is below the detector's
    /// `min_snr`.
    pub const LOW_SNR: PeakFlags = PeakFlags(1 << 1);
    /// A sample of the window reaches the detector's full scale: the top is clipped.
    pub const SATURATED: PeakFlags = PeakFlags(1 << 2);
    /// The FWHM is above the detector's `max_fwhm_nm`.
    pub const TOO_WIDE: PeakFlags = PeakFlags(1 << 3);
    /// The FWHM is below the detector's `min_fwhm_nm`.
    pub const TOO_NARROW: PeakFlags = PeakFlags(1 << 4);
    /// The half-widths left and right of the centre at half maximum differ by more than the
    /// detector's `max_asymmetry` ratio.
    pub const ASYMMETRIC: PeakFlags = PeakFlags(1 << 5);
    /// Another peak in the window: samples apart from the main peak rise above the detector's
    /// `second_peak_fraction` of its height (plus three noise σ).
    pub const SECOND_PEAK: PeakFlags = PeakFlags(1 << 6);
    /// The maximum is the window's first or last sample: the peak may lie outside the window.
    pub const AT_EDGE: PeakFlags = PeakFlags(1 << 7);
    /// The bits that make the wavelength suspect (no peak, saturated, second peak, at edge).
    pub const FAULTS: PeakFlags = PeakFlags(0b1100_0101);
    /// Every bit.
    pub const ALL: PeakFlags = PeakFlags(0xFF);

    /// True when no flag is raised.
    pub const fn is_ok(self) -> bool {
        self.0 == 0
    }
    /// True when a bit of [`PeakFlags::FAULTS`] is raised.
    pub const fn is_fault(self) -> bool {
        self.0 & PeakFlags::FAULTS.0 != 0
    }
    /// True when every bit of `other` is raised.
    pub const fn contains(self, other: PeakFlags) -> bool {
        self.0 & other.0 == other.0
    }
    /// Raise the bits of `other`.
    pub fn insert(&mut self, other: PeakFlags) {
        self.0 |= other.0;
    }
    /// Raise `other` when `cond` holds.
    pub fn set_if(&mut self, other: PeakFlags, cond: bool) {
        if cond {
            self.insert(other);
        }
    }
    /// Union of two flag sets.
    pub const fn union(self, other: PeakFlags) -> PeakFlags {
        PeakFlags(self.0 | other.0)
    }

    /// What these peak flags add to the estimate of a sample made from the peak: a fault bit
    /// raises [`Flags::PEAK_FAULT`] (a fault: it drives the alarm), any other bit
    /// [`Flags::PEAK_QUALITY`] (not a fault). [`PeakFlags::NO_PEAK`] also leaves a NaN
    /// wavelength, which the compensator flags [`Flags::NON_FINITE`].
    ///
    /// ```
    /// use fbg_shared::spectrum::PeakFlags;
    /// use fbg_shared::Flags;
    /// assert_eq!(PeakFlags::OK.estimate_flags(), Flags::OK);
    /// assert_eq!(PeakFlags::SATURATED.estimate_flags(), Flags::PEAK_FAULT);
    /// assert_eq!(PeakFlags::LOW_SNR.estimate_flags(), Flags::PEAK_QUALITY);
    /// ```
    pub const fn estimate_flags(self) -> Flags {
        let fault = if self.is_fault() { Flags::PEAK_FAULT.0 } else { 0 };
        let quality = if self.0 & !PeakFlags::FAULTS.0 != 0 { Flags::PEAK_QUALITY.0 } else { 0 };
        Flags(fault | quality)
    }
}

impl core::fmt::Display for PeakFlags {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.is_ok() {
            return f.write_str("ok");
        }
        let mut first = true;
        for (bit, name) in [
            (PeakFlags::NO_PEAK, "no-peak"),
            (PeakFlags::LOW_SNR, "low-snr"),
            (PeakFlags::SATURATED, "saturated"),
            (PeakFlags::TOO_WIDE, "too-wide"),
            (PeakFlags::TOO_NARROW, "too-narrow"),
            (PeakFlags::ASYMMETRIC, "asymmetric"),
            (PeakFlags::SECOND_PEAK, "second-peak"),
            (PeakFlags::AT_EDGE, "at-edge"),
        ] {
            if self.contains(bit) {
                if !first {
                    f.write_str("|")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}
