//! The instrument's memory: causal operators with O(1) state per input whose outputs, the
//! memory terms m, enter Model-H linearly (ŷ = Bφ + Γm + Wψ).
//!
//! Every term is *level-free*: a difference that stays bounded however far the inputs move, so
//! a term learned on the calibration batch does not extrapolate a level into a later hold-out.
//!
//! - [`LowPass`]: first-order low-pass (EMA) with time constant τ \[s\] and the sample's own Δt;
//!   the terms are input − EMA (high-passes) of each Δλ and of T_amb;
//! - [`Play`]: the play (backlash) operator of half-width r \[pm\]; the term is its stop
//!   complement x − play_r(x), a Prandtl–Ishlinskii hysteresis basis function;
//! - [`DriftObserver`]: a smoothed difference between the temperature the gratings imply and
//!   the thermometer, which follows the interrogator's common drift;
//! - [`MemorySpec`]: which operators a model uses (its coefficients, in the blob);
//! - [`MemoryOperators`]: all of them in per-sample form, stepped over a stream's
//!   [`MemoryState`], which can be saved and resumed;
//! - [`MemoryBank`]: the operators with the state of one stream.
//!
//! Coefficients (τ, r, the observer's row) are kept apart from the state, as idsp does: one
//! spec can drive any number of streams.

mod bank;
mod drift_observer;
mod low_pass;
mod operators;
mod play;
mod spec;
mod state;

pub use bank::MemoryBank;
pub use drift_observer::DriftObserver;
pub use low_pass::{smoothing_factor, LowPass};
pub use operators::MemoryOperators;
pub use play::Play;
pub use spec::{MemoryGroup, MemorySpec, TermInfo};
pub use state::MemoryState;
