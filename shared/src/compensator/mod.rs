//! The per-sample inference (Model-H): polynomial core + memory terms + RBF residual + band +
//! flags, in the order data flows:
//!
//! - [`Sample`] (`sample`): one measured sample, the input;
//! - `gate`: which samples may move a stream's memory state ([`crate::trust`]);
//! - [`SwingFilter`] (`swing`): how fast the inputs the gate let in have moved lately, against
//!   the calibration's pace ([`crate::trust`]);
//! - `fold`, `load`: loading folds the auditable [`crate::ModelParams`] into a per-sample
//!   form once, in the model's own precision, every folded number checked before the first is
//!   written (a refused model leaves the old one serving);
//! - [`PreparedModel`] (`prepared`, `rbf`): the result, immutable while streams run;
//! - [`StreamState`] (`state`): what a stream carries from sample to sample (direction
//!   latches, memory operators' state) and its clock;
//! - `step`: [`PreparedModel::step`]`(&self, &mut state, &sample)`, only the work that
//!   depends on the sample; [`PreparedModel::step_batch`] the same over a slice of samples,
//!   bit for bit, with the RBF pass run over several samples at once (in two parts,
//!   [`PreparedModel::begin_batch`] and [`PreparedModel::end_batch`], for a host that spreads
//!   the second over threads);
//! - [`Estimate`] (`estimate`): the output, values, band and flags;
//! - [`Compensator`] (`pair`): a model with one stream's state, for a device or a command
//!   line.

mod estimate;
mod fold;
mod gate;
mod load;
mod pair;
mod prepared;
mod rbf;
mod sample;
mod state;
mod step;
mod swing;

pub use estimate::Estimate;
pub use gate::GateState;
pub use pair::Compensator;
pub use prepared::PreparedModel;
pub use sample::Sample;
pub use state::StreamState;
pub use step::Pending;
pub use swing::{SwingFilter, PACE_WINDOW_S, SWING_FAST_TAU_S, SWING_SLOW_TAU_S};
