//! Per-sample fault flags: the estimate is always returned; flags say how far to
//! trust it.

/// Bit set of sample flags. `Flags::OK` (no bit) means a normal, in-envelope estimate.
///
/// On the wire (the link's estimates) it is one byte; deserialising refuses a byte with a bit
/// this version does not define ([`UnknownFlags`]), so a newer device's flag is never silently
/// read as a known one or dropped.
///
/// ```
/// use fbg_shared::Flags;
/// let mut f = Flags::OK;
/// f.insert(Flags::OUT_OF_ENVELOPE);
/// assert!(f.contains(Flags::OUT_OF_ENVELOPE) && !f.is_ok());
/// assert_eq!(f.union(Flags::WEAK_SUPPORT).to_string(), "out-of-envelope|weak-support");
/// assert_eq!(Flags::from_bits(0b1000_0000), Some(Flags::FALLBACK));
/// assert!(!Flags::LEAD_UNKNOWN.is_fault() && Flags::WEAK_SUPPORT.is_fault());
/// assert!(Flags::IMPLAUSIBLE.is_fault());
/// assert_eq!(Flags::IMPLAUSIBLE.union(Flags::LEAD_UNKNOWN).to_string(), "lead-unknown|implausible");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "u8")]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags(pub u8);

/// A flag byte with a bit [`Flags::ALL`] does not define.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UnknownFlags(pub u8);

impl core::fmt::Display for UnknownFlags {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "flag byte {:#04x} has bits this version does not define", self.0)
    }
}

impl core::error::Error for UnknownFlags {}

impl TryFrom<u8> for Flags {
    type Error = UnknownFlags;
    fn try_from(bits: u8) -> Result<Self, UnknownFlags> {
        Flags::from_bits(bits).ok_or(UnknownFlags(bits))
    }
}

impl Flags {
    /// No flag raised.
    pub const OK: Flags = Flags(0);
    /// An input the model uses was NaN or infinite (the direction latches were then not
    /// advanced), or the result overflowed: values are NaN and the band is infinite.
    pub const NON_FINITE: Flags = Flags(1 << 0);
    /// An input (Δλ or T_amb) lies outside the calibration envelope plus its margin.
    pub const OUT_OF_ENVELOPE: Flags = Flags(1 << 1);
    /// No RBF centre supports the sample (max ψ below the model's threshold): the residual
    /// correction is close to zero and the estimate is essentially Model-P's.
    pub const WEAK_SUPPORT: Flags = Flags(1 << 2);
    /// The band's lead time (absolute time since the end of calibration) is unknown: the
    /// stream has no absolute start time or the model no absolute end of calibration, so the
    /// band is taken at the largest lead the calibration validated. Not a fault: the value is
    /// as good as ever, only the band's clock is unknown ([`crate::StreamClock`]).
    pub const LEAD_UNKNOWN: Flags = Flags(1 << 3);
    /// The estimate is implausible for this model: a value outside its output's calibration
    /// envelope widened by the margins of [`crate::field`], or a band that is non-finite or far
    /// beyond the largest the calibration validated ([`crate::FieldContext::plausible`]). With
    /// the inputs inside their envelope, the model itself is wrong.
    pub const IMPLAUSIBLE: Flags = Flags(1 << 4);
    /// A sample made from a spectrum: a grating's peak carries a fault of
    /// [`crate::spectrum::PeakFlags::FAULTS`] (no peak, saturated, a second peak in its window,
    /// at the window's edge), so its wavelength, and the value, are suspect. Never raised by
    /// the compensator itself ([`crate::spectrum::PeakFlags::estimate_flags`]).
    pub const PEAK_FAULT: Flags = Flags(1 << 5);
    /// A sample made from a spectrum: a grating's peak is usable but off what the detector
    /// expects (low SNR, too wide or narrow, asymmetric). Not a fault, like
    /// [`Flags::LEAD_UNKNOWN`].
    pub const PEAK_QUALITY: Flags = Flags(1 << 6);
    /// Model-H did not trust its memory for this sample ([`crate::trust`]): beyond the
    /// calibration's quiet time (a hold longer than any it contained) or beyond its pace (the
    /// inputs moving faster than it showed; the band then also widens with the pace) what it
    /// adds to Model-P faded, partly or wholly, and the band toward Model-P's; or the gate kept the sample
    /// out of the memory state (then with [`Flags::OUT_OF_ENVELOPE`], and the value is
    /// Model-P's). Not a fault in itself: Model-P's value and band are as good as ever.
    pub const FALLBACK: Flags = Flags(1 << 7);
    /// The bits that say the value itself is suspect (non-finite, out of envelope, weak
    /// support, implausible, a peak fault): they drive a device's alarm (the compensator's
    /// band widening concerns its own bits only); [`Flags::LEAD_UNKNOWN`] and
    /// [`Flags::PEAK_QUALITY`] do neither.
    pub const FAULTS: Flags = Flags(0b011_0111);
    /// Every bit this version defines.
    pub const ALL: Flags = Flags(0b1111_1111);

    /// The flags of `bits`, `None` when a bit is not one of [`Flags::ALL`].
    pub const fn from_bits(bits: u8) -> Option<Flags> {
        if bits | Flags::ALL.0 == Flags::ALL.0 {
            Some(Flags(bits))
        } else {
            None
        }
    }
    /// True when no flag is raised.
    pub const fn is_ok(self) -> bool {
        self.0 == 0
    }
    /// True when a fault bit ([`Flags::FAULTS`]) is raised.
    pub const fn is_fault(self) -> bool {
        self.0 & Flags::FAULTS.0 != 0
    }
    /// True when every bit of `other` is raised.
    pub const fn contains(self, other: Flags) -> bool {
        self.0 & other.0 == other.0
    }
    /// Raise the bits of `other`.
    pub fn insert(&mut self, other: Flags) {
        self.0 |= other.0;
    }
    /// Union of two flag sets.
    pub const fn union(self, other: Flags) -> Flags {
        Flags(self.0 | other.0)
    }
}

impl core::fmt::Display for Flags {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.is_ok() {
            return f.write_str("ok");
        }
        let mut first = true;
        for (bit, name) in [
            (Flags::NON_FINITE, "non-finite"),
            (Flags::OUT_OF_ENVELOPE, "out-of-envelope"),
            (Flags::WEAK_SUPPORT, "weak-support"),
            (Flags::LEAD_UNKNOWN, "lead-unknown"),
            (Flags::IMPLAUSIBLE, "implausible"),
            (Flags::PEAK_FAULT, "peak-fault"),
            (Flags::PEAK_QUALITY, "peak-quality"),
            (Flags::FALLBACK, "fallback"),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_defined_byte_round_trips_and_no_other_deserialises() {
        // Every bit of the byte is defined since FALLBACK; the refusal path stays for a wider
        // flag set.
        for bits in 0..=u8::MAX {
            let got = postcard::from_bytes::<Flags>(&[bits]);
            if Flags::from_bits(bits).is_some() {
                assert_eq!(got, Ok(Flags(bits)));
                let mut buf = [0u8; 1];
                assert_eq!(postcard::to_slice(&Flags(bits), &mut buf).unwrap(), &[bits]);
            } else {
                assert!(got.is_err(), "{bits:#04x}");
                assert_eq!(Flags::try_from(bits), Err(UnknownFlags(bits)));
            }
        }
        assert_eq!(Flags::ALL.0, u8::MAX);
    }
}
