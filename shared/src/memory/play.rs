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
