//! `fbg-trainer`: simulate FBG installations, fit and evaluate the hybrid compensator, export
//! models for the `fbg-shared` inference.
//!
//! The modules follow the data, in layers: a module uses only modules of earlier layers
//! (`tests/layout.rs` checks it), so there is no import cycle (and none among the files
//! inside a module, `tests/modules.rs`):
//!
//! 1. `error`, `progress`, `rng`, `stats`, `warning`: used by all;
//! 2. `data`: the dataset and its CSV, the import of interrogator exports, safe output files;
//! 3. `sim` (scenarios, the simulator, its `.meta.json` sidecar) and `fit` (Model-P and
//!    Model-H, the `--features` choice, field recalibration, the sensitivities);
//! 4. `eval`: scores, f32-vs-f64 parity, the studies, the `metrics.json` schema, the tables,
//!    the evaluation's warnings; `sign`: signing keys, the serial per key and signed blobs
//!    (the trailer itself is `fbg_shared::signature`);
//! 5. `export`: the `.fbgm` blob, `coefficients.json`, a trained model's files together,
//!    golden vectors;
//! 6. `report`, `fleet`, `stream`, `benchmark`: the audit report and the operations built on
//!    the pipeline.
//!
//! The command line (`src/cli/`) is the binary and uses this library only; its argument types
//! (clap), terminal progress bars (indicatif) and error chains (anyhow) stay there
//! (`tests/cli_apart.rs`): the library takes plain option structs, reports progress through
//! [`progress`] and returns [`TrainerError`].

// Foundations.
pub mod error;
pub mod progress;
pub mod rng;
pub mod stats;
pub mod warning;

// The pipeline.
pub mod data;
pub mod eval;
pub mod export;
pub mod fit;
pub mod report;
pub mod sign;
pub mod sim;

// Operations built on the pipeline.
pub mod benchmark;
pub mod compensate;
pub mod fleet;
pub mod stream;

pub use error::TrainerError;
