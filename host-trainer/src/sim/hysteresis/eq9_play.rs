//! The default hysteresis: paper Eq. 9 followed by a play (backlash) operator.
//!
//! Eq. 9 depends on the sampling (a one-step lag and a speed term), so this model is *not*
//! rate-independent; the play operator, which draws the direction-dependent loops, is.

use crate::sim::scenario::Hysteresis;

/// Paper Eq. 9: h(x_t) = β x_t + γ x_{t−1} + ρ sgn(ẋ_t)(x_t − x_{t−1}).
///
/// Taken literally, as DESIGN §3 asks. Note that sgn(ẋ)(x_t − x_{t−1}) = |x_t − x_{t−1}|, so
/// the ρ term is a speed-dependent positive offset and β + γ = 1 makes the rest a one-step
/// lag; the direction-dependent part of the hysteresis comes from [`play_operator`].
pub(crate) fn eq9(x: &[f64], cfg: &Hysteresis) -> Vec<f64> {
    let mut prev = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&xt| {
            let dx = xt - prev;
            let sgn = if dx > 0.0 {
                1.0
            } else if dx < 0.0 {
                -1.0
            } else {
                0.0
            };
            let h = cfg.beta * xt + cfg.gamma * prev + cfg.rho * sgn * dx;
            prev = xt;
            h
        })
        .collect()
}

/// Play (backlash) operator of half-width `r`: the output stays put until the input has moved
/// `r` beyond it, then follows at distance `r`. Rising input reads `r` low, falling input reads
/// `r` high, and every turning point draws a minor loop of width 2r.
pub(crate) fn play_operator(x: &[f64], r: f64) -> Vec<f64> {
    let mut y = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&xt| {
            y = y.clamp(xt - r, xt + r);
            y
        })
        .collect()
}

/// Hysteresis contribution \[pm\]: play(Eq. 9(x)) − x.
pub fn contribution(x: &[f64], cfg: &Hysteresis) -> Vec<f64> {
    let y = play_operator(&eq9(x, cfg), cfg.play_half_width_pm);
    y.iter().zip(x).map(|(y, x)| y - x).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::hysteresis::paths::{branches, triangle};

    #[test]
    fn play_operator_reads_low_rising_high_falling() {
        let up: Vec<f64> = (0..50).map(|k| k as f64).collect();
        let mut x = up.clone();
        x.extend(up.iter().rev());
        let y = play_operator(&x, 4.0);
        // Well into the rise the output lags by r; well into the fall it leads by r.
        assert!((y[30] - (x[30] - 4.0)).abs() < 1e-12);
        assert!((y[80] - (x[80] + 4.0)).abs() < 1e-12);
        // At the turning point the output holds still while the input reverses by 2r.
        let top = y[49];
        for (k, &yk) in y.iter().enumerate().take(57).skip(50) {
            assert_eq!(yk, top, "k={k}");
        }
    }

    #[test]
    fn draws_a_loop_and_only_eq9_depends_on_the_pace() {
        let cfg = Hysteresis::default();
        let fast = triangle(60.0, 3, 2.0);
        let slow = triangle(60.0, 3, 0.5);
        let (yf, ys) = (contribution(&fast, &cfg), contribution(&slow, &cfg));
        for at in [-30.0, 0.0, 30.0] {
            let (rise, fall) = branches(&fast, &yf, at);
            assert!(rise < fall - 6.0, "at {at}: rising {rise}, falling {fall}");
        }
        // The play operator alone gives the same loop at any pace, sample for sample.
        let (pf, ps) = (play_operator(&fast, 4.0), play_operator(&slow, 4.0));
        for (k, &v) in pf.iter().enumerate() {
            assert_eq!(v, ps[4 * k], "sample {k}");
        }
        // Eq. 9's lag and speed terms scale with the step: (γ + ρ)·|dx| apart at most.
        for (k, &v) in yf.iter().enumerate() {
            assert!((v - ys[4 * k]).abs() <= (cfg.gamma + cfg.rho) * 2.0 + 1e-9, "sample {k}");
        }
    }
}
