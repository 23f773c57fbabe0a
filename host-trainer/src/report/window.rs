//! Choosing the zoomed windows of the figures by a stated rule (never by hand), so that the
//! caption can say how each window was chosen.

/// Indices of the turning points of `y`: the extremes after which `y` moved back by more than
/// `dead_band`. Non-finite samples are skipped.
pub fn turning_points(y: &[f64], dead_band: f64) -> Vec<usize> {
    let mut out = Vec::new();
    let mut it = (0..y.len()).filter(|&i| y[i].is_finite());
    let Some(first) = it.next() else { return out };
    let (mut lo, mut hi) = (first, first);
    let mut dir = 0i8;
    let mut ext = first;
    for i in it {
        let v = y[i];
        match dir {
            0 => {
                if v < y[lo] {
                    lo = i;
                }
                if v > y[hi] {
                    hi = i;
                }
                if v - y[lo] > dead_band {
                    dir = 1;
                    ext = i;
                } else if y[hi] - v > dead_band {
                    dir = -1;
                    ext = i;
                }
            }
            1 => {
                if v >= y[ext] {
                    ext = i;
                } else if y[ext] - v > dead_band {
                    out.push(ext);
                    dir = -1;
                    ext = i;
                }
            }
            _ => {
                if v <= y[ext] {
                    ext = i;
                } else if v - y[ext] > dead_band {
                    out.push(ext);
                    dir = 1;
                    ext = i;
                }
            }
        }
    }
    out
}

/// The window `[a, a + len)` of `0..n` with the largest sum of `weight` (earliest on ties).
pub fn best_window(weight: &[f64], len: usize) -> (usize, usize) {
    let n = weight.len();
    let len = len.clamp(1.min(n), n);
    if len == n {
        return (0, n);
    }
    let w = |i: usize| if weight[i].is_finite() { weight[i] } else { 0.0 };
    let mut s: f64 = (0..len).map(w).sum();
    let (mut best, mut at) = (s, 0);
    for a in 1..=(n - len) {
        s += w(a + len - 1) - w(a - 1);
        if s > best + 1e-12 * best.abs() {
            best = s;
            at = a;
        }
    }
    (at, at + len)
}

/// Length of a window that holds about `target` turning points of `tp` (indices into a series
/// of `n` samples), at least `min_len` samples; the whole series when it has fewer than two.
pub fn window_len_for(tp: &[usize], n: usize, target: usize, min_len: usize) -> usize {
    if tp.len() < 2 {
        return n;
    }
    let spacing = (tp[tp.len() - 1] - tp[0]) as f64 / (tp.len() - 1) as f64;
    ((spacing * target as f64).round() as usize).clamp(min_len.min(n), n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turning_points_of_a_sine_ignore_small_wiggles() {
        let y: Vec<f64> = (0..1000)
            .map(|i| {
                let t = i as f64 / 100.0;
                (t * std::f64::consts::PI).sin() + 0.05 * (t * 40.0).sin()
            })
            .collect();
        let tp = turning_points(&y, 0.5);
        // Peaks and troughs near t = 0.5, 1.5, ..., 9.5.
        assert_eq!(tp.len(), 10, "{tp:?}");
        for (k, &i) in tp.iter().enumerate() {
            let want = 50.0 + 100.0 * k as f64;
            assert!((i as f64 - want).abs() < 10.0, "{i} vs {want}");
        }
    }

    #[test]
    fn best_window_finds_the_heaviest_stretch() {
        let mut w = vec![0.0; 100];
        w[60] = 1.0;
        w[62] = 1.0;
        w[10] = 1.5;
        assert_eq!(best_window(&w, 5), (58, 63));
        assert_eq!(best_window(&w, 100), (0, 100));
        assert_eq!(best_window(&w, 500), (0, 100));
    }

    #[test]
    fn window_len_scales_with_spacing() {
        let tp: Vec<usize> = (0..20).map(|k| 10 + 50 * k).collect();
        assert_eq!(window_len_for(&tp, 1000, 6, 10), 300);
        assert_eq!(window_len_for(&[3], 1000, 6, 10), 1000);
    }
}
