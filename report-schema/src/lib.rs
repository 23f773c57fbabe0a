//! `fbg-report`: the JSON reports of `fbg-trainer`, typed once. The trainer writes them
//! (`evaluate --json` and `metrics.json`, the pace and glitch studies inside it, `bench-fit
//! --json`, `bench-spectrum`'s rows, the warnings of `coefficients.json`); xtask's bench and the trainer's own report read
//! them back with the same types, so a key renamed on one side cannot go unnoticed on the other.
//!
//! Numbers are written as serde_json writes them (NaN and ±∞ as `null`) and read leniently
//! ([`nan`]): `null` reads as NaN, and a key that an older file lacks reads as NaN, an empty list
//! or `None` where the field says so.
//!
//! serde and serde_json only: xtask depends on this crate, and every `cargo xtask` call
//! compiles it first on a fresh clone.

pub mod fit_bench;
pub mod metrics;
pub mod nan;
pub mod pace;
pub mod spectrum;
pub mod warning;

pub use fit_bench::{Chosen, FitBench, HoldoutFigures};
pub use metrics::{
    AblationRow, BudgetRow, ChannelMetrics, DriftSweep, Metrics, ModelEval, ParityReport, RecalStudy, Skipped,
    StaticFidelity, Table2,
};
pub use pace::{gain_pct, GlitchRow, PaceRow, PaceStudy, PACED_RMSE_RATIO_MAX, REST_RMSE_RATIO_MAX};
pub use spectrum::AccuracyRow;
pub use warning::Warning;
