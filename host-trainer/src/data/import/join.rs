//! Joining reference readings onto peak times: linear interpolation in time between the two
//! neighbouring valid readings, missing when they are further apart than a maximum gap or when
//! the time lies outside the readings.

/// The valid (finite) readings of one reference column, time-ordered.
#[derive(Clone, Debug)]
pub(crate) struct Series {
    t: Vec<f64>,
    v: Vec<f64>,
}

impl Series {
    /// `t` must increase; non-finite values are left out.
    pub fn new(t: &[f64], v: &[f64]) -> Self {
        let (t, v) = t.iter().zip(v).filter(|(_, v)| v.is_finite()).map(|(&t, &v)| (t, v)).unzip();
        Series { t, v }
    }

    /// The value at `t`, or NaN.
    pub fn at(&self, t: f64, max_gap_s: f64) -> f64 {
        let i = self.t.partition_point(|&x| x < t);
        if i < self.t.len() && self.t[i] == t {
            return self.v[i];
        }
        if i == 0 || i == self.t.len() {
            return f64::NAN;
        }
        let (t0, t1) = (self.t[i - 1], self.t[i]);
        if t1 - t0 > max_gap_s {
            return f64::NAN;
        }
        let w = (t - t0) / (t1 - t0);
        self.v[i - 1] + w * (self.v[i] - self.v[i - 1])
    }
}

/// Median spacing of increasing times (0 for fewer than two).
pub(crate) fn median_spacing(t: &[f64]) -> f64 {
    let d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return 0.0;
    }
    crate::stats::upper_median(&d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_within_the_gap_only() {
        let s = Series::new(&[0.0, 10.0, 20.0, 100.0], &[1.0, 2.0, f64::NAN, 5.0]);
        assert_eq!(s.at(0.0, 15.0), 1.0);
        assert!((s.at(5.0, 15.0) - 1.5).abs() < 1e-12);
        assert!(s.at(-1.0, 15.0).is_nan());
        assert!(s.at(101.0, 15.0).is_nan());
        // 20 s is missing, so 10 → 100 is one 90 s gap.
        assert!(s.at(50.0, 15.0).is_nan());
        assert!((s.at(55.0, 90.0) - 3.5).abs() < 1e-12);
        assert_eq!(median_spacing(&[0.0, 1.0, 3.0, 4.0]), 1.0);
    }
}
