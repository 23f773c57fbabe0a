//! A model run sample by sample in the host's f64 or in the device's f32 through `fbg-shared`
//! (inputs rounded to f32 as the device receives them, estimates read back in f64): one
//! engine for `compensate`, its whole-record `estimates` and the Python package's stream.
//! `batch.rs` runs it over many samples at once.

use fbg_shared::{Compensator, Estimate, Sample, StreamClock};

use super::host::{HostCompensator, HostParams, HOST_CAP};

mod batch;

/// Which arithmetic runs the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// The host's f64 path (as `evaluate`).
    F64,
    /// The device's f32 path.
    F32,
}

/// A model run over a stream of rows in one arithmetic ([`Precision`]).
pub enum Engine {
    /// The host's f64 compensator.
    F64(Box<HostCompensator>),
    /// The device's f32 compensator.
    F32(Box<Compensator<f32, HOST_CAP>>),
}

impl Engine {
    /// A compensator of `params` in `precision` on `clock`. A model that cannot be loaded is
    /// refused with the arithmetic it was loaded for (`the host's f64`, `the device's f32`)
    /// and the reason.
    pub fn load(
        params: &HostParams,
        precision: Precision,
        clock: StreamClock,
    ) -> Result<Engine, (&'static str, fbg_shared::Error)> {
        Ok(match precision {
            Precision::F64 => {
                let mut c = Box::new(HostCompensator::new(params).map_err(|e| ("the host's f64", e))?);
                c.set_clock(clock);
                Engine::F64(c)
            }
            Precision::F32 => {
                let p32 = params.convert::<f32, HOST_CAP>().map_err(|e| ("the device's f32", e))?;
                let mut c = Box::new(Compensator::<f32, HOST_CAP>::new(&p32).map_err(|e| ("the device's f32", e))?);
                c.set_clock(clock);
                Engine::F32(c)
            }
        })
    }

    /// One sample's estimate, in f64 whatever the arithmetic.
    pub fn step(&mut self, s: &Sample<f64>) -> Estimate<f64> {
        match self {
            Engine::F64(c) => c.step(s),
            Engine::F32(c) => c.step(&s.cast::<f32>()).cast(),
        }
    }
}
