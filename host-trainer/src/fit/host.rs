//! The model types on the host: `fbg_shared`'s model and compensator in f64 with room for the
//! largest grid the trainer searches.

use fbg_shared::{Compensator, ModelParams, PreparedModel};

/// Centre capacity of host-side models (the device's capacity is its own const generic).
pub const HOST_CAP: usize = 128;
/// A model on the host: f64, up to [`HOST_CAP`] centres.
pub type HostParams = ModelParams<f64, HOST_CAP>;
/// A compensator on the host.
pub type HostCompensator = Compensator<f64, HOST_CAP>;
/// A host compensator's model, apart from its stream state.
pub type HostPreparedModel = PreparedModel<f64, HOST_CAP>;
