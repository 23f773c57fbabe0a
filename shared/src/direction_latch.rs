//! The hysteresis-aware feature: per grating, the direction in which the measured wavelength
//! last moved by more than a dead band.
//!
//! A play-operator-style detector: the latch remembers the running extreme in its current
//! direction and flips only when the signal retreats from that extreme by more than the dead
//! band, so noise smaller than the band never toggles it. O(1) state, identical on host and
//! device.
//!
//! Decisions are taken on integer ticks of 1/1024 pm ([`ticks`]): a wavelength representable
//! in f32 converts to the same tick count in f32 and f64, so the device and the host reference
//! flip their latches on exactly the same samples (a float comparison against the dead band
//! could round differently in the two precisions and let the streams diverge).

use crate::layout::MAX_GRATINGS;
use crate::real::Real;

/// Ticks per picometre of the latch arithmetic.
pub const TICKS_PER_PM: f64 = 1024.0;

/// A wavelength shift \[pm\] in latch ticks (1/1024 pm), rounded to nearest and saturating at
/// ±2³¹ ticks (±2 µm); NaN gives 0 (callers screen non-finite input first).
#[inline]
pub fn ticks<F: Real>(pm: F) -> i32 {
    pm.round_to_i32_scaled(TICKS_PER_PM)
}

/// Direction latch of one grating.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DirectionLatch {
    /// Running extreme of the current direction [ticks].
    anchor: i32,
    /// −1 falling, +1 rising, 0 before the first move beyond the dead band.
    dir: i8,
    primed: bool,
}

impl DirectionLatch {
    /// A latch that has seen no sample yet.
    pub const fn new() -> Self {
        DirectionLatch { anchor: 0, dir: 0, primed: false }
    }

    /// Feed one measured shift `dl_pm` and return the latch value (−1, 0 or +1) after it.
    /// `dead_band` is the move needed to flip the direction, in [`ticks`]. Non-finite input
    /// leaves the state unchanged (the compensator screens it before).
    #[inline]
    pub fn update<F: Real>(&mut self, dl_pm: F, dead_band: i32) -> F {
        if !dl_pm.is_finite() {
            return self.value();
        }
        let x = ticks(dl_pm);
        if !self.primed {
            self.anchor = x;
            self.primed = true;
            return self.value();
        }
        // Saturating: a limit beyond the i32 range is one no tick count crosses, as in exact
        // arithmetic (one `qadd`/`qsub` each on a Cortex-M4).
        let a = self.anchor;
        let rise = x > a.saturating_add(dead_band);
        let fall = x < a.saturating_sub(dead_band);
        match self.dir {
            1 if x > a => self.anchor = x,
            -1 if x < a => self.anchor = x,
            1 | 0 if fall => {
                self.dir = -1;
                self.anchor = x;
            }
            -1 | 0 if rise => {
                self.dir = 1;
                self.anchor = x;
            }
            _ => {}
        }
        self.value()
    }

    /// Current latch value: −1, 0 or +1.
    #[inline]
    pub fn value<F: Real>(&self) -> F {
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LatchBank {
    latches: [DirectionLatch; MAX_GRATINGS],
}

impl LatchBank {
    /// Latches that have seen no sample.
    pub const fn new() -> Self {
        LatchBank { latches: [DirectionLatch::new(); MAX_GRATINGS] }
    }
    /// Feed the first `gratings` shifts \[pm\] of a sample and return their latch values (the
    /// rest 0); `dead_band` in [`ticks`].
    #[inline]
    pub fn update<F: Real>(&mut self, dl_pm: &[F; MAX_GRATINGS], gratings: usize, dead_band: i32) -> [F; MAX_GRATINGS] {
        let mut out = [F::ZERO; MAX_GRATINGS];
        for ((o, l), &d) in out.iter_mut().zip(self.latches.iter_mut()).zip(dl_pm.iter()).take(gratings) {
            *o = l.update(d, dead_band);
        }
        out
    }
    /// Current values without feeding a sample.
    pub fn values<F: Real>(&self) -> [F; MAX_GRATINGS] {
        let mut out = [F::ZERO; MAX_GRATINGS];
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
        let mut l = DirectionLatch::new();
        let db = ticks(3.0f64);
        assert_eq!(l.update(0.0f64, db), 0.0);
        for k in 0..100 {
            let v: f64 = if k % 2 == 0 { 1.4 } else { -1.4 };
            assert_eq!(l.update(v, db), 0.0);
        }
    }

    #[test]
    fn follows_direction_with_dead_band() {
        let mut l = DirectionLatch::new();
        let db = ticks(2.0f64);
        let mut up = |v: f64| -> f64 { l.update(v, db) };
        up(0.0);
        assert_eq!(up(2.5), 1.0);
        assert_eq!(up(10.0), 1.0);
        // A retreat smaller than the band from the extreme (10) keeps rising.
        assert_eq!(up(8.5), 1.0);
        assert_eq!(up(7.9), -1.0);
        assert_eq!(up(3.0), -1.0);
        assert_eq!(up(4.9), -1.0);
        assert_eq!(up(5.1), 1.0);
    }

    #[test]
    fn non_finite_input_leaves_state() {
        let mut l = DirectionLatch::new();
        let db = ticks(1.0f32);
        l.update(0.0f32, db);
        l.update(5.0f32, db);
        let before = l;
        assert_eq!(l.update(f32::NAN, db), 1.0f32);
        assert_eq!(l, before);
        l.reset();
        assert_eq!(l.value::<f32>(), 0.0);
    }

    #[test]
    fn f32_and_f64_decide_identically_on_f32_inputs() {
        // Values that sit right at anchor ± dead band in one precision.
        let mut a = DirectionLatch::new();
        let mut b = DirectionLatch::new();
        let db = ticks(2.0f32);
        let mut x = 0.1f32;
        for k in 0..20_000u32 {
            x += if (k / 37) % 2 == 0 { 0.337 } else { -0.291 };
            let va: f32 = a.update(x, db);
            let vb: f64 = b.update(x as f64, db);
            assert_eq!(va as f64, vb, "step {k}");
        }
    }

    #[test]
    fn ticks_saturate_and_round() {
        assert_eq!(ticks(1.0f64), 1024);
        assert_eq!(ticks(-0.5f32), -512);
        assert_eq!(ticks(1e12f64), i32::MAX);
        assert_eq!(ticks(-1e12f32), i32::MIN);
    }
}
