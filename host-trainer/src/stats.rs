//! Error statistics (paper Eq. 10 and friends).

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
