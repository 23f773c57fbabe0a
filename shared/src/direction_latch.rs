//! The hysteresis-aware feature: per grating, the direction in which the measured wavelength
//! last moved by more than a dead band.
//!
//! A play-operator-style detector: the latch remembers the running extreme in its current
//! direction and flips only when the signal retreats from that extreme by more than the dead
//! band, so noise smaller than the band never toggles it. O(1) state, identical on host and
//! device.

use crate::layout::N_GRATINGS;
use crate::real::Real;

/// Direction latch of one grating.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DirectionLatch<F> {
    /// Running extreme of the current direction [pm].
    anchor_pm: F,
    /// −1 falling, +1 rising, 0 before the first move beyond the dead band.
    dir: i8,
    primed: bool,
}

impl<F: Real> DirectionLatch<F> {
    /// A latch that has seen no sample yet.
    pub const fn new() -> Self {
        DirectionLatch { anchor_pm: F::ZERO, dir: 0, primed: false }
    }

    /// Feed one measured shift `dl_pm` and return the latch value (−1, 0 or +1) after it.
    /// `dead_band_pm` is the move needed to flip the direction. Non-finite input must not be
    /// passed (the compensator screens it); the state is then left unchanged.
    #[inline]
    pub fn update(&mut self, dl_pm: F, dead_band_pm: F) -> F {
        if !dl_pm.is_finite() {
            return self.value();
        }
        if !self.primed {
            self.anchor_pm = dl_pm;
            self.primed = true;
            return self.value();
        }
        let a = self.anchor_pm;
        match self.dir {
            1 => {
                if dl_pm > a {
                    self.anchor_pm = dl_pm;
                } else if dl_pm < a - dead_band_pm {
                    self.dir = -1;
                    self.anchor_pm = dl_pm;
                }
            }
            -1 => {
                if dl_pm < a {
                    self.anchor_pm = dl_pm;
                } else if dl_pm > a + dead_band_pm {
                    self.dir = 1;
                    self.anchor_pm = dl_pm;
                }
            }
            _ => {
                if dl_pm > a + dead_band_pm {
                    self.dir = 1;
                    self.anchor_pm = dl_pm;
                } else if dl_pm < a - dead_band_pm {
                    self.dir = -1;
                    self.anchor_pm = dl_pm;
                }
            }
        }
        self.value()
    }

    /// Current latch value: −1, 0 or +1.
    #[inline]
    pub fn value(&self) -> F {
        match self.dir {
            1 => F::ONE,
            -1 => -F::ONE,
            _ => F::ZERO,
        }
    }

    /// Forget the stream (a new acquisition starts).
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

/// One latch per grating.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LatchBank<F> {
    latches: [DirectionLatch<F>; N_GRATINGS],
}

impl<F: Real> LatchBank<F> {
    /// Latches that have seen no sample.
    pub const fn new() -> Self {
        LatchBank { latches: [DirectionLatch::new(); N_GRATINGS] }
    }
    /// Feed one sample's shifts [pm] and return the three latch values.
    #[inline]
    pub fn update(&mut self, dl_pm: &[F; N_GRATINGS], dead_band_pm: F) -> [F; N_GRATINGS] {
        let mut out = [F::ZERO; N_GRATINGS];
        for ((o, l), &d) in out.iter_mut().zip(self.latches.iter_mut()).zip(dl_pm.iter()) {
            *o = l.update(d, dead_band_pm);
        }
        out
    }
    /// Current values without feeding a sample.
    pub fn values(&self) -> [F; N_GRATINGS] {
        let mut out = [F::ZERO; N_GRATINGS];
        for (o, l) in out.iter_mut().zip(self.latches.iter()) {
            *o = l.value();
        }
        out
    }
    /// Forget the stream.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_inside_the_dead_band_never_flips() {
        let mut l = DirectionLatch::<f64>::new();
        let db = 3.0;
        assert_eq!(l.update(0.0, db), 0.0);
        for k in 0..100 {
            let v = if k % 2 == 0 { 1.4 } else { -1.4 };
            assert_eq!(l.update(v, db), 0.0);
        }
    }

    #[test]
    fn follows_direction_with_dead_band() {
        let mut l = DirectionLatch::<f64>::new();
        let db = 2.0;
        l.update(0.0, db);
        assert_eq!(l.update(2.5, db), 1.0);
        assert_eq!(l.update(10.0, db), 1.0);
        // A retreat smaller than the band from the extreme (10) keeps rising.
        assert_eq!(l.update(8.5, db), 1.0);
        assert_eq!(l.update(7.9, db), -1.0);
        assert_eq!(l.update(3.0, db), -1.0);
        assert_eq!(l.update(4.9, db), -1.0);
        assert_eq!(l.update(5.1, db), 1.0);
    }

    #[test]
    fn non_finite_input_leaves_state() {
        let mut l = DirectionLatch::<f32>::new();
        l.update(0.0, 1.0);
        l.update(5.0, 1.0);
        let before = l;
        assert_eq!(l.update(f32::NAN, 1.0), 1.0);
        assert_eq!(l, before);
        l.reset();
        assert_eq!(l.value(), 0.0);
    }
}
