//! The statistics of the bench: medians of repeated runs, growth exponents, figures per output.

/// Median of the finite values (mean of the middle two for an even count); NaN when none.
pub fn median(xs: &[f64]) -> f64 {
    let mut v: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Least-squares slope of ln y against ln x.
pub fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

/// Largest |a − b| / b over the channels (NaN when a value is missing).
pub fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    if a.len() != b.len() || a.iter().chain(b).any(|v| v.is_nan()) {
        return f64::NAN;
    }
    a.iter().zip(b).map(|(x, y)| ((x - y) / y).abs()).fold(0.0, f64::max)
}

/// Value `c` of a per-channel list, NaN when it is missing.
pub fn at(v: &[f64], c: usize) -> f64 {
    v.get(c).copied().unwrap_or(f64::NAN)
}

/// Mean, NaN when there is no value.
pub fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// Smallest / largest of `v` by `f`, NaN when any value is NaN or there is none.
pub fn fold_nan(v: impl Iterator<Item = f64>, f: fn(f64, f64) -> f64) -> f64 {
    v.fold(None, |acc: Option<f64>, x| {
        Some(match acc {
            Some(a) if a.is_nan() || x.is_nan() => f64::NAN,
            Some(a) => f(a, x),
            None => x,
        })
    })
    .unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_slopes() {
        assert_eq!(median(&[3.0, f64::NAN, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[f64::NAN]).is_nan());
        assert!((log_slope(&[1.0, 10.0, 100.0], &[2.0, 20.0, 200.0]) - 1.0).abs() < 1e-12);
    }
}
