//! The statistics every stage uses: RMSE (paper Eq. 10) and its friends, medians, the
//! least-squares line. One place, so that "median" means one thing per name.

/// Root mean square of errors (NaN for an empty iterator).
pub fn rmse(err: impl Iterator<Item = f64>) -> f64 {
    rms(err)
}

/// Root mean square.
pub fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in x {
        s += v * v;
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        (s / n as f64).sqrt()
    }
}

/// Mean.
pub fn mean(x: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in x {
        s += v;
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// Population standard deviation (two-pass).
pub fn std_dev(x: impl Iterator<Item = f64> + Clone) -> f64 {
    let m = mean(x.clone());
    rms(x.map(|v| v - m))
}

/// Median of a sample (mean of the middle two for an even count); NaN when empty.
pub fn median(xs: &[f64]) -> f64 {
    median_in_place(&mut xs.to_vec())
}

/// [`median`] of a buffer it sorts in place (no allocation: for the many small windows of a
/// running median).
pub fn median_in_place(v: &mut [f64]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    sorted_median(v)
}

/// [`median`] of a sorted sample.
fn sorted_median(v: &[f64]) -> f64 {
    let n = v.len();
    match (v.get(n.wrapping_sub(1) / 2), v.get(n / 2)) {
        (Some(_), Some(&b)) if n % 2 == 1 => b,
        (Some(&a), Some(&b)) => 0.5 * (a + b),
        _ => f64::NAN,
    }
}

/// The upper median: the middle element of the sorted sample, the higher of the two middle ones
/// for an even count (an element of the sample, never a mean); NaN when empty.
pub fn upper_median(xs: &[f64]) -> f64 {
    let mut v: Vec<f64> = xs.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// (intercept, slope) of the least-squares line.
pub fn linear_fit(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (my - slope * mx, slope)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_of_odd_even_and_empty() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
        assert_eq!(upper_median(&[4.0, 1.0, 3.0, 2.0]), 3.0);
        assert_eq!(upper_median(&[3.0, 1.0, 2.0]), 2.0);
        assert!(upper_median(&[]).is_nan());
        let mut buf = [5.0, -1.0, 3.0, 0.0];
        assert_eq!(median_in_place(&mut buf), 1.5);
        assert_eq!(buf, [-1.0, 0.0, 3.0, 5.0], "sorted in place");
        assert!(median_in_place(&mut []).is_nan());
    }

    #[test]
    fn line_through_points() {
        let (a, b) = linear_fit(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0]);
        assert!((a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12);
        assert_eq!(linear_fit(&[1.0, 1.0], &[2.0, 4.0]), (3.0, 0.0));
    }
}
