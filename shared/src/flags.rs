//! Per-sample fault flags (DESIGN §4): the estimate is always returned; flags say how far to
//! trust it.

/// Bit set of sample flags. `Flags::OK` (no bit) means a normal, in-envelope estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags(pub u8);

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
    /// Every bit this version defines.
    pub const ALL: Flags = Flags(0b111);

    /// True when no flag is raised.
    pub const fn is_ok(self) -> bool {
        self.0 == 0
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
