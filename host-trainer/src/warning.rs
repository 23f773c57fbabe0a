//! Warnings as data: what `train`, `evaluate`, `compensate` and `recalibrate` find worth a
//! user's attention, with a stable code, the channel it concerns and the numbers behind it
//! ([`Warning`], in `fbg-report` with the other report types that carry it).

pub use fbg_report::Warning;
