//! Evaluation (DESIGN §5): scoring a model on the hold-out ([`score`]), the f32 device path
//! against the f64 reference ([`parity`]), the studies that retrain or re-simulate
//! ([`studies`]), the schema of `metrics.json` they fill ([`metrics`]), and the tables that
//! render it ([`tables`]), and what of it deserves a warning ([`warnings`]).

pub mod glitch;
pub mod metrics;
pub mod pace;
pub mod parity;
pub mod score;
pub mod streamed;
pub mod studies;
pub mod tables;
pub mod warnings;
