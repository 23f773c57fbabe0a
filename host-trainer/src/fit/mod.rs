//! Fitting Model-P and Model-H (DESIGN §4) with hyper-parameter selection by blocked
//! time-series cross-validation inside the calibration batch.
//!
//! All predictions go through `fbg_shared::Compensator<f64, _>`, the same code the device runs
//! in f32: the trainer never implements inference a second time. The design matrix Ψ is
//! collected from that code too (`Compensator::core_and_activations`, see [`design`]).
//!
//! The files follow the fit, and import only files listed before them (no cycle):
//!
//! 1. what a fit is asked and gives: [`host`] (the model types), `grid` (the hyper-parameters
//!    cross-validation tries), `options` (checked [`TrainOptions`]), `provenance`;
//! 2. the numerics: [`linalg`], [`kmeans`], `par`;
//! 3. the model's parts: [`poly_core`], [`memory_core`], [`design`] (a model run over a
//!    record), `envelope`, `rbf_inputs` (RBF inputs and centres), `residual` (the RBF layer's
//!    targets), `variance`, [`band`], `skeleton` (a model but for its weights);
//! 4. the choice: [`select`] (cross-validation), [`sensitivity`], [`field`],
//!    [`static_fidelity`], [`outcome`];
//! 5. the entry: `refusals` (batches refused before any work), `trained` ([`Trained`]),
//!    `train` ([`train`]); then what works on trained models: [`recalibrate`], [`features`].

pub mod band;
pub mod design;
mod envelope;
pub mod features;
pub mod field;
mod grid;
pub mod host;
pub(crate) mod kmeans;
pub(crate) mod linalg;
pub mod memory_core;
mod options;
pub mod outcome;
mod par;
pub mod poly_core;
mod provenance;
mod rbf_inputs;
pub mod recalibrate;
mod refusals;
mod residual;
pub mod select;
pub mod sensitivity;
mod skeleton;
pub mod static_fidelity;
mod train;
mod trained;
mod variance;

pub use band::VarModel;
pub use design::{design_matrix, run, run_on_clock, CheckpointCache, Checkpoints, Gram};
pub use features::FeatureChoice;
pub use grid::{Config, CvGrid};
pub use host::{HostCompensator, HostParams, HOST_CAP};
pub use options::{TrainOptions, TrainOptionsBuilder};
pub use outcome::Chosen;
pub(crate) use par::par_map;
pub use poly_core::PolyCore;
pub(crate) use provenance::today_yyyymmdd;
pub use provenance::Origin;
pub use select::{CvRow, Selection};
pub use train::{train, train_source};
pub use trained::Trained;
