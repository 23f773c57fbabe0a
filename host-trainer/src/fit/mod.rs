//! Fitting Model-P and Model-H (DESIGN §4) with hyper-parameter selection by blocked
//! time-series cross-validation inside the calibration batch.
//!
//! All predictions go through `fbg_shared::Compensator<f64, _>`, the same code the device runs
//! in f32: the trainer never implements inference a second time. The design matrix Ψ is
//! collected from that code too (`Compensator::core_and_activations`, see [`design`]).
//!
//! The files follow the fit, and each uses only files listed before it (no cycle):
//!
//! 1. the model types and the numerics: [`host`], `engine` (a model run sample by sample in
//!    the host's f64 or the device's f32, [`Engine`]), `linalg`, `kmeans`, `par`;
//! 2. the polynomial core and a model run over a record: [`poly_core`], [`design`],
//!    [`memory_core`];
//! 3. what a fit is asked: `grid` ([`CvGrid`]), `options` ([`TrainOptions`]), [`features`]
//!    (the `--features` variants), `provenance` ([`Origin`]);
//! 4. the RBF residual's parts: `envelope`, `rbf_inputs` (inputs and centres), `residual`
//!    (targets, weak support), `variance`, `random_walk` (the drift's growth), [`band`], `skeleton` (a model but for its weights);
//! 5. the choice and its checks: [`select`] (cross-validation), [`sensitivity`],
//!    [`static_fidelity`], [`field`], [`outcome`];
//! 6. the entry: `refusals`, `trained` ([`Trained`]), `train` ([`train()`]); then
//!    [`recalibrate`], which works on trained models.
//!
//! This file only declares the modules and re-exports what the rest of the crate and its
//! users name as `fit::…`.

pub mod band;
pub mod design;
mod engine;
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
mod random_walk;
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
pub mod trust;
mod variance;

pub use band::VarModel;
pub use design::{design_matrix, run, run_on_clock, CheckpointCache, Checkpoints, Gram};
pub use engine::{Engine, Precision};
pub use features::FeatureChoice;
pub use grid::{Config, CvGrid, HyperParam};
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
