//! One compensated estimate, the output of a step.

use heapless::Vec;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::flags::Flags;
use crate::layout::{head, MAX_OUTPUTS};
use crate::real::Real;

/// One compensated estimate: the model's M values and bands (in its output order and units)
/// and the flags. Entries beyond M are 0 (use [`Estimate::values`] and [`Estimate::band`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate<F> {
    /// One value per output (unit of the output).
    pub values: [F; MAX_OUTPUTS],
    /// Half-width of the 95 % band, same units (infinite for non-finite input).
    pub band95: [F; MAX_OUTPUTS],
    /// M, the number of outputs.
    pub outputs: u8,
    /// Fault flags.
    pub flags: Flags,
}

impl<F: Real> Estimate<F> {
    /// The M values.
    pub fn values(&self) -> &[F] {
        head(&self.values, usize::from(self.outputs))
    }
    /// The M band half-widths.
    pub fn band(&self) -> &[F] {
        head(&self.band95, usize::from(self.outputs))
    }
    /// The estimate in another precision: exact from f32 to f64 (how a host reads what a
    /// device answered), rounded to nearest from f64 to f32, as [`crate::Sample::cast`].
    pub fn cast<G: Real>(&self) -> Estimate<G> {
        Estimate {
            values: self.values.map(G::from_real),
            band95: self.band95.map(G::from_real),
            outputs: self.outputs,
            flags: self.flags,
        }
    }
    /// The answer to a sample the model cannot read: NaN values, infinite band, `flags`.
    pub(crate) fn refused(outputs: u8, flags: Flags) -> Self {
        let mut e = Estimate { values: [F::ZERO; MAX_OUTPUTS], band95: [F::ZERO; MAX_OUTPUTS], outputs, flags };
        let m = usize::from(outputs);
        for (v, b) in e.values.iter_mut().zip(e.band95.iter_mut()).take(m) {
            *v = F::NAN;
            *b = F::INFINITY;
        }
        e
    }
}

impl<F: Real + Serialize> Serialize for Estimate<F> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.values(), self.band(), self.flags).serialize(s)
    }
}

impl<'de, F: Real + Deserialize<'de>> Deserialize<'de> for Estimate<F> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (v, b, flags): (Vec<F, MAX_OUTPUTS>, Vec<F, MAX_OUTPUTS>, Flags) = Deserialize::deserialize(d)?;
        let mut e = Estimate::refused(v.len() as u8, flags);
        for (o, &x) in e.values.iter_mut().zip(v.iter()) {
            *o = x;
        }
        for (o, &x) in e.band95.iter_mut().zip(b.iter()) {
            *o = x;
        }
        Ok(e)
    }
}
