//! Rate-independent Bouc–Wen hysteresis, in the form used for piezo-driven actuators such as a
//! tunable filter's: the reading is y = x − h, with the hysteretic state h \[pm\] driven by the
//! increments of the physical shift x \[pm\]:
//!
//! dh = a·dx − β·|dx|·|h|^(n−1)·h − γ·dx·|h|^n.
//!
//! Over one increment dx the sign of dx is fixed, so h follows the ordinary differential
//! equation dh/dx = a − β·sgn(dx)·|h|^(n−1)·h − γ·|h|^n in x: solved exactly for n = 1 (linear
//! on either side of h = 0), otherwise by RK4 in sub-steps of at most 1/100 of the approach
//! length h_s/a. The result depends on the path of x, not on how fast it is sampled. The
//! parameters are in [`BoucWen`].

use crate::sim::scenario::BoucWen;

/// Hysteresis contribution \[pm\] (−h) on the shift series `x` \[pm\], starting from h = 0.
pub fn contribution(x: &[f64], p: &BoucWen) -> Vec<f64> {
    let mut h = 0.0;
    let mut prev = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&xt| {
            h = advance(h, xt - prev, p);
            prev = xt;
            -h
        })
        .collect()
}

/// Saturation of h \[pm\]: (a/(β+γ))^(1/n).
pub(crate) fn saturation_pm(p: &BoucWen) -> f64 {
    libm::pow(p.a / (p.beta + p.gamma), 1.0 / p.n)
}

/// dh/dx for an increment of sign `sgn`.
fn slope(h: f64, sgn: f64, p: &BoucWen) -> f64 {
    let hn = libm::pow(h.abs(), p.n);
    p.a - p.beta * sgn * hn * h.signum() - p.gamma * hn
}

/// h after the increment `dx`.
fn advance(h: f64, dx: f64, p: &BoucWen) -> f64 {
    if dx == 0.0 || !dx.is_finite() {
        return h;
    }
    if p.n == 1.0 {
        // A fall is a rise of −h: the equation is symmetric under (h, dx) → (−h, −dx).
        let sgn = dx.signum();
        return sgn * rise_n1(sgn * h, dx.abs(), p);
    }
    let approach = saturation_pm(p) / p.a;
    let max_step = if approach.is_finite() && approach > 0.0 { approach / 100.0 } else { dx.abs() };
    // A bound on the work for an absurd jump; beyond it the state is saturated anyway.
    let k = (dx.abs() / max_step).ceil().clamp(1.0, 100_000.0) as usize;
    let s = dx / k as f64;
    let sgn = dx.signum();
    let mut h = h;
    for _ in 0..k {
        let k1 = slope(h, sgn, p);
        let k2 = slope(h + 0.5 * s * k1, sgn, p);
        let k3 = slope(h + 0.5 * s * k2, sgn, p);
        let k4 = slope(h + s * k3, sgn, p);
        h += s / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    h
}

/// n = 1, rising by `s` > 0 from `h`: dh/dx = a − c·h with c = β − γ below h = 0 and
/// c = β + γ above it, solved exactly on each side.
fn rise_n1(h: f64, s: f64, p: &BoucWen) -> f64 {
    // h(s) for dh/dx = a − c·h from h0.
    let run = |h0: f64, c: f64, s: f64| {
        if c == 0.0 {
            h0 + p.a * s
        } else {
            let eq = p.a / c;
            eq + (h0 - eq) * libm::exp(-c * s)
        }
    };
    let (below, above) = (p.beta - p.gamma, p.beta + p.gamma);
    if h >= 0.0 {
        return run(h, above, s);
    }
    // Distance to reach h = 0 from below (a > 0 and β ≥ |γ|: it rises and gets there).
    let to_zero = if below == 0.0 { -h / p.a } else { libm::log((p.a / below - h) / (p.a / below)) / below };
    if s <= to_zero {
        run(h, below, s).min(0.0)
    } else {
        run(0.0, above, s - to_zero)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::hysteresis::paths::{branches, triangle};

    #[test]
    fn draws_a_loop_of_twice_the_saturation() {
        let p = BoucWen::default();
        let hs = saturation_pm(&p);
        assert!((hs - 3.0).abs() < 1e-12);
        let x = triangle(150.0, 3, 1.0);
        let y = contribution(&x, &p);
        for at in [-50.0, 0.0, 50.0] {
            let (rise, fall) = branches(&x, &y, at);
            assert!(rise < fall - 0.5, "at {at}: rising {rise}, falling {fall}");
        }
        // Long runs saturate: reading 3 pm low rising, 3 pm high falling.
        let (rise, fall) = branches(&x, &y, 140.0);
        assert!((rise + hs).abs() < 0.05 && fall > rise + 1.0, "rising {rise}, falling {fall}");
        let (rise, fall) = branches(&x, &y, -140.0);
        assert!((fall - hs).abs() < 0.05 && rise < fall - 1.0, "rising {rise}, falling {fall}");
        assert!(y.iter().all(|v| v.abs() <= hs + 1e-9));
        // A small reversal draws a minor loop, narrower than the major one.
        let x = triangle(10.0, 3, 0.5);
        let y = contribution(&x, &p);
        let (rise, fall) = branches(&x, &y, 0.0);
        assert!(rise < fall && fall - rise < 2.0 * hs, "rising {rise}, falling {fall}");
    }

    #[test]
    fn rate_independent() {
        for p in [BoucWen::default(), BoucWen { n: 2.0, beta: 0.004, gamma: 0.002, ..BoucWen::default() }] {
            let fast = triangle(90.0, 3, 3.0);
            let slow = triangle(90.0, 3, 0.75);
            let (yf, ys) = (contribution(&fast, &p), contribution(&slow, &p));
            // Exact for n = 1; RK4 sub-steps of another size otherwise.
            let tol = if p.n == 1.0 { 1e-9 } else { 1e-5 };
            for (k, &v) in yf.iter().enumerate() {
                assert!((v - ys[4 * k]).abs() < tol, "n {}: sample {k}: {v} vs {}", p.n, ys[4 * k]);
            }
        }
    }
}
