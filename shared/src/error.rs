//! Errors of the shared crate: everything a blob or a parameter set can get wrong.

/// What went wrong while decoding, validating or loading a model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// The input ended before the named part was complete.
    Truncated {
        /// Part being read ("header", "payload", "crc"). Only reported when the input is
        /// shorter than the smallest blob with its header's centre count; a longer input that
        /// fails its CRC is [`Error::BadCrc`].
        part: &'static str,
    },
    /// The first four bytes are not `FBGM`.
    BadMagic,
    /// A format version this build does not read.
    UnsupportedVersion {
        /// Version found in the header.
        found: u16,
        /// The version this build reads and writes.
        supported: u16,
    },
    /// A header dimension differs from what this build computes with.
    WrongDims {
        /// Which dimension ("ambient", "poly_terms", "memory_terms", "centres", or a payload
        /// dimension that contradicts the header).
        field: &'static str,
        /// Value in the blob.
        found: u16,
        /// Value expected. For "centres": the capacity `K` when the header's count exceeds
        /// it, otherwise the payload's own centre count, which the header contradicts.
        expected: u16,
    },
    /// A model dimension exceeds this build's capacity (gratings, measurands), or a model's
    /// dimensions do not fit the receiving type.
    OverCapacity {
        /// Which dimension ("gratings", "measurands").
        field: &'static str,
        /// Value in the model.
        found: u16,
        /// This build's capacity.
        capacity: u16,
    },
    /// The CRC-32 trailer does not match header and payload.
    BadCrc,
    /// The payload does not decode as model parameters.
    BadPayload,
    /// Bytes the payload does not account for: appended after a complete blob and its valid
    /// CRC, or, under a CRC that covers them, between the end of the payload and the trailer.
    TrailingBytes {
        /// How many.
        extra: usize,
    },
    /// More centres than the target's capacity.
    TooManyCentres {
        /// Centres in the model.
        found: usize,
        /// Capacity `K` of the receiving type.
        capacity: usize,
    },
    /// A parameter is non-finite or out of its range: the range a field admits (a positive
    /// scale, an ordered envelope) or its plausibility bound ([`crate::model::bounds`]), or an
    /// output index beyond the capacity ("dims.outputs").
    BadParameter {
        /// The parameter's field path ("stage1", "centres.v", "field.output_envelope", …).
        field: &'static str,
    },
    /// The output buffer is too small for the encoded blob.
    BufferTooSmall,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Truncated { part } => write!(f, "model blob truncated in the {part}"),
            Error::BadMagic => f.write_str("not a model blob (magic is not FBGM)"),
            Error::UnsupportedVersion { found, supported } => {
                write!(
                    f,
                    "model blob format version {found} is not readable by this build, which reads version {supported}"
                )
            }
            Error::WrongDims { field, found, expected } => {
                write!(f, "model blob dimension {field} is {found}, this build needs {expected}")
            }
            Error::OverCapacity { field, found, capacity } => {
                write!(f, "model has {found} {field}, this build holds at most {capacity}")
            }
            Error::BadCrc => f.write_str("model blob CRC-32 mismatch (corrupted)"),
            Error::BadPayload => f.write_str("model blob payload does not decode"),
            Error::TrailingBytes { extra } => {
                write!(f, "model blob has {extra} unexpected bytes after its payload")
            }
            Error::TooManyCentres { found, capacity } => {
                write!(f, "model has {found} RBF centres, this target holds at most {capacity}")
            }
            Error::BadParameter { field } => {
                write!(f, "model parameter {field} is non-finite or out of range")
            }
            Error::BufferTooSmall => f.write_str("output buffer too small for the model blob"),
        }
    }
}

impl core::error::Error for Error {}
