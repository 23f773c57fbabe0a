//! Device vs host: the rule every comparison of a device's answers with the host's f64
//! reference follows (`fbg-trainer stream`, the golden vectors and the long memory stream of
//! the QEMU tests). Per channel, value and 95 % band each within a tolerance (by default
//! [`REL_TOL`] of the model's hold-out RMSE), NaN only against NaN, ∞ only against the same
//! ∞, and identical flags.
//!
//! ```
//! use fbg_link::parity::{compare, Mismatch};
//! use fbg_shared::protocol::DeviceEstimate;
//! use fbg_shared::{Estimate, Flags};
//!
//! let host = Estimate {
//!     values: [20.0, 100.0, f64::NAN, 0.0],
//!     band95: [0.5, 3.0, f64::INFINITY, 0.0],
//!     outputs: 3,
//!     flags: Flags::OK,
//! };
//! let device = DeviceEstimate {
//!     seq: 0,
//!     values: [20.004, 100.0, f32::NAN, 0.0],
//!     band: [0.5, 3.0, f32::INFINITY, 0.0],
//!     outputs: 3,
//!     flags: Flags::OK,
//! };
//! assert_eq!(compare(&device, &host, &[0.01; 3]), Ok(()));
//! let flagged = DeviceEstimate { flags: Flags::WEAK_SUPPORT, ..device };
//! assert!(matches!(compare(&flagged, &host, &[0.01; 3]), Err(Mismatch::Flags { .. })));
//! ```

use fbg_shared::layout::MAX_OUTPUTS;
use fbg_shared::protocol::DeviceEstimate;
use fbg_shared::{Estimate, Flags};

/// Device vs host tolerance as a fraction of the model's hold-out RMSE per channel.
pub const REL_TOL: f64 = 0.01;

/// Which number of an estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The compensated value.
    Value,
    /// The half-width of the 95 % band.
    Band,
}

/// The first difference between a device's answer and the host's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mismatch {
    /// The flags differ.
    Flags {
        /// The device's.
        device: Flags,
        /// The host's.
        host: Flags,
    },
    /// A value or band differs beyond the tolerance (or NaN/∞ against a number).
    Number {
        /// Value or band.
        part: Part,
        /// Output channel (index in the model's output order).
        channel: usize,
        /// The device's number.
        device: f64,
        /// The host's number.
        host: f64,
        /// The tolerance of the channel.
        tol: f64,
    },
}

impl core::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Mismatch::Flags { device, host } => write!(f, "flags {device} (device) vs {host} (host)"),
            Mismatch::Number { part, channel, device, host, tol } => write!(
                f,
                "{} {}: device {device} vs host {host} (|Δ| {:.3e} > {tol:.3e})",
                match part {
                    Part::Value => "value",
                    Part::Band => "band",
                },
                format_args!("output {}", channel + 1),
                (device - host).abs()
            ),
        }
    }
}

impl std::error::Error for Mismatch {}

/// Whether two numbers agree: NaN with NaN only, an infinity with the same infinity only,
/// finite numbers within `tol`.
pub fn agrees(device: f64, host: f64, tol: f64) -> bool {
    if device.is_nan() || host.is_nan() {
        device.is_nan() && host.is_nan()
    } else if device.is_infinite() || host.is_infinite() {
        device == host
    } else {
        (device - host).abs() <= tol
    }
}

/// Compare a device's answer with the host's: flags identical, then per channel value and
/// band within `tol` ([`agrees`]). Returns the first difference.
pub fn compare(device: &DeviceEstimate, host: &Estimate<f64>, tol: &[f64]) -> Result<(), Mismatch> {
    if device.flags != host.flags {
        return Err(Mismatch::Flags { device: device.flags, host: host.flags });
    }
    if device.outputs != host.outputs {
        // Another model's answer: its output count is compared as a value.
        let (device, host) = (f64::from(device.outputs), f64::from(host.outputs));
        return Err(Mismatch::Number { part: Part::Value, channel: 0, device, host, tol: 0.0 });
    }
    for channel in 0..usize::from(host.outputs).min(MAX_OUTPUTS) {
        let tol = tol.get(channel).copied().unwrap_or(0.0);
        for (part, d, h) in [
            (Part::Value, device.values[channel], host.values[channel]),
            (Part::Band, device.band[channel], host.band95[channel]),
        ] {
            let d = f64::from(d);
            if !agrees(d, h, tol) {
                return Err(Mismatch::Number { part, channel, device: d, host: h, tol });
            }
        }
    }
    Ok(())
}

/// |device − host| per channel, 0 where the difference is not finite (NaN or ∞ on a side:
/// [`compare`] judges those): what the largest differences of a stream are taken over.
pub fn abs_diff(device: &[f32; MAX_OUTPUTS], host: &[f64; MAX_OUTPUTS]) -> [f64; MAX_OUTPUTS] {
    core::array::from_fn(|c| {
        let d = (f64::from(device[c]) - host[c]).abs();
        if d.is_finite() {
            d
        } else {
            0.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dev(values: [f32; 3], band: [f32; 3], flags: Flags) -> DeviceEstimate {
        let [a, b, c] = values;
        let [d, e, f] = band;
        DeviceEstimate { seq: 0, values: [a, b, c, 0.0], band: [d, e, f, 0.0], outputs: 3, flags }
    }

    #[test]
    fn compare_applies_the_tolerance_nan_inf_and_flags() {
        let host = Estimate {
            values: [1.0, 2.0, f64::NAN, 0.0],
            band95: [0.5, f64::INFINITY, f64::INFINITY, 0.0],
            outputs: 3,
            flags: Flags::OK,
        };
        let tol = [0.01, 0.01, 0.01];
        let inf = f32::INFINITY;
        assert_eq!(compare(&dev([1.005, 2.0, f32::NAN], [0.5, inf, inf], Flags::OK), &host, &tol), Ok(()));
        let e = compare(&dev([1.02, 2.0, f32::NAN], [0.5, inf, inf], Flags::OK), &host, &tol).unwrap_err();
        assert!(matches!(e, Mismatch::Number { part: Part::Value, channel: 0, .. }), "{e:?}");
        assert!(e.to_string().starts_with("value output 1: device"), "{e}");
        let e = compare(&dev([1.0, 2.0, 0.0], [0.5, inf, inf], Flags::OK), &host, &tol).unwrap_err();
        assert!(matches!(e, Mismatch::Number { part: Part::Value, channel: 2, .. }));
        let e = compare(&dev([1.0, 2.0, f32::NAN], [0.5, 1.0, inf], Flags::OK), &host, &tol).unwrap_err();
        assert!(matches!(e, Mismatch::Number { part: Part::Band, channel: 1, .. }));
        assert!(compare(&dev([1.0, 2.0, f32::NAN], [0.5, -inf, inf], Flags::OK), &host, &tol).is_err());
        let flagged = dev([1.0, 2.0, f32::NAN], [0.5, inf, inf], Flags::OUT_OF_ENVELOPE);
        let e = compare(&flagged, &host, &tol).unwrap_err();
        assert_eq!(e.to_string(), "flags out-of-envelope (device) vs ok (host)");
    }

    #[test]
    fn abs_diff_skips_what_is_not_finite() {
        assert_eq!(abs_diff(&[1.5, f32::NAN, 3.0, 0.0], &[1.0, 2.0, f64::INFINITY, 0.0]), [0.5, 0.0, 0.0, 0.0]);
    }
}
