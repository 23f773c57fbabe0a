//! The play (backlash) operator and its stop complement.

use crate::real::Real;

/// The play operator of half-width r: its output follows the input only once the input has
/// pushed it to one end of a band of width 2r, so after a reversal it holds still until the
/// input has travelled 2r. The stop complement `x − play_r(x)` lies in [−r, r] and tells where
/// the input sits inside the band: a Prandtl–Ishlinskii hysteresis basis function, level-free.
///
/// `p ← clamp(p, x − r, x + r)`; the state is one scalar (the operator's position, in the
/// input's unit), kept by the caller. Independent of the clock.
///
/// ```
/// use fbg_shared::memory::Play;
/// let op = Play::new(2.0f64);
/// let mut p = 0.0;
/// assert_eq!(op.stop(&mut p, 5.0), 2.0); // pushed up: play at 3, stop at +r
/// assert_eq!(op.stop(&mut p, 4.0), 1.0); // reversal inside the band: play holds at 3
/// assert_eq!(op.stop(&mut p, 0.0), -2.0); // pushed down: play at 2
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Play<F> {
    half_width: F,
}

impl<F: Real> Play<F> {
    /// An unused slot (half-width 0: the play output is the input).
    pub const fn off() -> Self {
        Play { half_width: F::ZERO }
    }

    /// A play operator of half-width `half_width` (>= 0, in the input's unit).
    pub fn new(half_width: F) -> Self {
        Play { half_width: if half_width > F::ZERO { half_width } else { F::ZERO } }
    }

    /// The half-width r.
    pub fn half_width(&self) -> F {
        self.half_width
    }

    /// Move the operator's position `state` with input `x` and return the play output.
    #[inline(always)]
    pub fn update(&self, state: &mut F, x: F) -> F {
        let lo = x - self.half_width;
        let hi = x + self.half_width;
        if *state < lo {
            *state = lo;
        } else if *state > hi {
            *state = hi;
        }
        *state
    }

    /// Move the operator with input `x` and return the stop complement `x − play_r(x)`.
    #[inline(always)]
    pub fn stop(&self, state: &mut F, x: F) -> F {
        x - self.update(state, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_testkit::Rng;
    use std::vec::Vec;

    fn ulp(v: f64) -> f64 {
        f64::from_bits(v.abs().to_bits() + 1) - v.abs()
    }

    #[test]
    fn a_reversal_inside_the_band_holds_the_output() {
        let op = Play::new(5.0f64);
        let mut p = 0.0;
        for k in 0..=50 {
            op.update(&mut p, f64::from(k)); // rising: pushed, p = x − r
        }
        assert_eq!(p, 45.0);
        // Any input in [p − r, p + r] = [40, 50] leaves it where it is, in any order.
        for x in [49.0, 47.5, 40.0, 44.0, 50.0, 41.25, 40.0] {
            assert_eq!(op.update(&mut p, x), 45.0, "x = {x}");
            assert_eq!(op.stop(&mut p, x), x - 45.0);
        }
        // Leaving the band at the bottom drags it down.
        assert_eq!(op.update(&mut p, 39.0), 44.0);
        assert_eq!(op.stop(&mut p, 30.0), -5.0);
        assert_eq!(p, 35.0);
        // r = 0 (an unused slot) is the identity, and a negative r is taken as 0.
        for r in [0.0, -3.0] {
            let op = Play::new(r);
            assert_eq!(op.half_width(), 0.0);
            let mut q = 7.0;
            assert_eq!(op.stop(&mut q, 2.5), 0.0);
            assert_eq!(q, 2.5);
        }
    }

    #[test]
    fn the_stop_term_stays_within_the_half_width() {
        let mut r = Rng(3);
        // On a dyadic grid (Δλ in 1/1024 pm, r a short binary fraction) every operation is
        // exact: |x − play(x)| <= r holds exactly.
        for &hw in &[0.75f64, 2.5, 10.0, 37.125] {
            let op = Play::new(hw);
            let mut p = 0.0;
            let mut x = 0.0f64;
            for _ in 0..20_000 {
                x = (x + (r.uniform(-8.0, 8.0) * 1024.0).round() / 1024.0).clamp(-500.0, 500.0);
                let s = op.stop(&mut p, x);
                assert!((-hw..=hw).contains(&s), "r = {hw}, x = {x}: stop {s}");
                assert_eq!(s, x - p);
            }
        }
        // Arbitrary values: x − r is rounded, so the stop can exceed r by the rounding of x,
        // never more (one ulp of max(|x|, r)).
        for _ in 0..200 {
            let hw = r.uniform(0.01, 50.0);
            let op = Play::new(hw);
            let op32 = Play::new(hw as f32);
            let (mut p, mut p32) = (r.uniform(-100.0, 100.0), 0.0f32);
            let mut x = 0.0;
            for _ in 0..500 {
                x += r.uniform(-3.0 * hw, 3.0 * hw);
                let s = op.stop(&mut p, x);
                assert!(s.abs() <= hw + ulp(x.abs().max(hw)), "r = {hw}, x = {x}: stop {s}");
                let x32 = x as f32;
                let s32 = op32.stop(&mut p32, x32);
                let tol32 =
                    f64::from(f32::from_bits(x32.abs().max(hw as f32).to_bits() + 1) - x32.abs().max(hw as f32));
                assert!(f64::from(s32.abs()) <= f64::from(hw as f32) + tol32, "f32 r = {hw}, x = {x32}: stop {s32}");
            }
        }
    }

    #[test]
    fn a_closed_minor_loop_returns_to_the_same_output() {
        let mut r = Rng(11);
        for &hw in &[1.0f64, 4.0, 12.5] {
            let op = Play::new(hw);
            for _ in 0..100 {
                // Return-point memory: once a rise has pushed the operator to the turning point
                // x_max, any excursion that stays at or below x_max and comes back to it leaves
                // the play output exactly where it was (likewise for a fall to x_min).
                let mut p = r.uniform(-20.0, 20.0);
                let x_max = r.uniform(-10.0, 10.0);
                let start = x_max - 2.0 * hw - r.uniform(0.0, 5.0);
                let n = 8;
                for k in 0..n {
                    op.update(&mut p, start + (x_max - start) * f64::from(k) / f64::from(n));
                }
                let at_turn = op.update(&mut p, x_max);
                assert_eq!(at_turn, x_max - hw);
                for _ in 0..30 {
                    op.update(&mut p, x_max - r.uniform(0.0, 6.0 * hw));
                }
                assert_eq!(op.update(&mut p, x_max), at_turn, "r = {hw}: loop below {x_max} not closed");
                let x_min = x_max - r.uniform(2.0 * hw, 8.0 * hw);
                let at_bottom = op.update(&mut p, x_min);
                assert_eq!(at_bottom, x_min + hw, "a fall of more than 2r pushes the operator");
                for _ in 0..30 {
                    op.update(&mut p, x_min + r.uniform(0.0, 6.0 * hw));
                }
                assert_eq!(op.update(&mut p, x_min), at_bottom, "r = {hw}: loop above {x_min} not closed");
            }
            // A periodic input (one path between two extremes, repeated) gives a periodic output
            // from the first cycle on: the hysteresis loop closes.
            let path: Vec<f64> = (0..40).map(|_| r.uniform(-6.0 * hw, 6.0 * hw)).collect();
            let mut p = 3.0 * hw;
            let cycle = |p: &mut f64| path.iter().map(|&x| op.update(p, x).to_bits()).collect::<Vec<_>>();
            let _first = cycle(&mut p);
            let second = cycle(&mut p);
            for _ in 0..3 {
                assert_eq!(cycle(&mut p), second);
            }
        }
    }
}
