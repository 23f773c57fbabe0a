//! The band's clock: how a stream's sample times relate to the end of calibration.
//!
//! The 95 % band grows with the lead time since the end of calibration (drift is a random
//! walk). A sample's `t_s` is on the stream's own clock, which for a field record starts at 0;
//! the lead is therefore absolute time since calibration ended, and a stream says how to get
//! it.

/// How a stream's `t_s` maps to the lead time since the end of calibration.
///
/// ```
/// use fbg_shared::StreamClock;
/// assert_eq!(StreamClock::default(), StreamClock::Unknown);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamClock {
    /// No absolute time: the band takes the largest lead the calibration validated and the
    /// estimate carries [`crate::Flags::LEAD_UNKNOWN`]. First, so that its discriminant is 0 and
    /// a compensator that has not been given a clock is all zero bytes (a device's static one
    /// stays in `.bss`, costing no flash).
    #[default]
    Unknown,
    /// `t_s` is on the calibration record's own clock (the record the model was calibrated
    /// on, e.g. its hold-out): lead = `t_s` − the model's end of calibration on that clock.
    Calibration,
    /// The stream's `t_s = 0` is at this absolute time (Unix seconds, UTC): lead =
    /// start + `t_s` − the model's absolute end of calibration. Unknown when the model has no
    /// absolute end of calibration.
    StartUnix(f64),
}
