//! One measured sample, the input of a step.

use heapless::Vec;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::Error;
use crate::layout::{head, MAX_GRATINGS};
use crate::real::Real;

/// One measured sample: the shifts of its gratings, the ambient temperature and the time.
///
/// `dl_pm` holds up to [`MAX_GRATINGS`] shifts of which the first `gratings` are the sample's
/// (the rest are 0); a model answers a sample with another grating count as non-finite. A model
/// without an ambient input ignores `t_amb_c` (send NaN); a model with one needs it finite.
///
/// On the link (postcard, [`crate::protocol`]) a sample is its `gratings` shifts (a length and
/// the values), then T_amb and t: the model's N values, not the capacity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample<F> {
    /// Measured wavelength shifts Δλ_1..N \[pm\] (the rest 0).
    pub dl_pm: [F; MAX_GRATINGS],
    /// N, the number of shifts in `dl_pm`.
    pub gratings: u8,
    /// Ambient reference temperature T_amb [°C] (NaN, and ignored, without an ambient input).
    pub t_amb_c: F,
    /// Time on the calibration clock \[s\] (used by feature sets with time, by a band that
    /// grows after calibration and by the memory terms).
    pub t_s: F,
}

impl<F: Real> Sample<F> {
    /// A sample of `N` gratings (at most [`MAX_GRATINGS`], checked at compile time).
    ///
    /// ```
    /// use fbg_shared::Sample;
    /// let s = Sample::new([0.1f64, 2.0, -3.0], 20.0, 60.0);
    /// assert_eq!((s.gratings, s.dl(), s.dl_pm[3]), (3, &[0.1, 2.0, -3.0][..], 0.0));
    /// ```
    pub fn new<const N: usize>(dl_pm: [F; N], t_amb_c: F, t_s: F) -> Self {
        const { assert!(N <= MAX_GRATINGS, "more gratings than MAX_GRATINGS") };
        Sample { dl_pm: crate::layout::pad(&dl_pm), gratings: N as u8, t_amb_c, t_s }
    }

    /// A sample from a slice of shifts; more than [`MAX_GRATINGS`] is
    /// [`Error::OverCapacity`].
    pub fn from_slice(dl_pm: &[F], t_amb_c: F, t_s: F) -> Result<Self, Error> {
        if dl_pm.len() > MAX_GRATINGS {
            return Err(Error::OverCapacity {
                field: "gratings",
                found: u16::try_from(dl_pm.len()).unwrap_or(u16::MAX),
                capacity: MAX_GRATINGS as u16,
            });
        }
        let mut d = [F::ZERO; MAX_GRATINGS];
        for (o, &v) in d.iter_mut().zip(dl_pm.iter()) {
            *o = v;
        }
        Ok(Sample { dl_pm: d, gratings: dl_pm.len() as u8, t_amb_c, t_s })
    }

    /// Whether the shifts and the ambient temperature are finite: what a model with an ambient
    /// input reads (one that reads time also needs a finite `t_s`; one without ambient ignores
    /// `t_amb_c`).
    #[inline(always)]
    pub fn inputs_finite(&self) -> bool {
        self.dl().iter().all(|v| v.is_finite()) && self.t_amb_c.is_finite()
    }

    /// The sample's shifts (the first `gratings` of `dl_pm`).
    pub fn dl(&self) -> &[F] {
        head(&self.dl_pm, usize::from(self.gratings))
    }

    /// The sample in another precision: exact from f32 to f64 (how a host replays what a
    /// device received), rounded to nearest from f64 to f32 (what a device receives).
    ///
    /// ```
    /// use fbg_shared::Sample;
    /// let host = Sample::new([0.1f64, 2.0, -3.0], 20.0, 60.0);
    /// let device: Sample<f32> = host.cast();
    /// assert_eq!(device.dl_pm[0], 0.1f32);
    /// assert_eq!(device.cast::<f64>().dl_pm[0], f64::from(0.1f32));
    /// ```
    pub fn cast<G: Real>(&self) -> Sample<G> {
        Sample {
            dl_pm: self.dl_pm.map(G::from_real),
            gratings: self.gratings,
            t_amb_c: G::from_real(self.t_amb_c),
            t_s: G::from_real(self.t_s),
        }
    }
}

impl<F: Real + Serialize> Serialize for Sample<F> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.dl(), self.t_amb_c, self.t_s).serialize(s)
    }
}

impl<'de, F: Real + Deserialize<'de>> Deserialize<'de> for Sample<F> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (dl, t_amb_c, t_s): (Vec<F, MAX_GRATINGS>, F, F) = Deserialize::deserialize(d)?;
        let mut dl_pm = [F::ZERO; MAX_GRATINGS];
        for (o, &v) in dl_pm.iter_mut().zip(dl.iter()) {
            *o = v;
        }
        Ok(Sample { dl_pm, gratings: dl.len() as u8, t_amb_c, t_s })
    }
}
