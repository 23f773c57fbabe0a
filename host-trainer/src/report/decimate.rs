//! Data reduction for plotting. A figure is a few hundred pixels wide; a record can hold a
//! million samples. Nothing here drops information a reader could see:
//!
//! - [`minmax_columns`] keeps, per pixel column, the smallest and the largest value (in the
//!   order they occur), so a line drawn through the result covers exactly the vertical extent
//!   the full series would have covered in that column: spikes survive;
//! - [`envelope_columns`] does the same for a band (lowest lower edge, highest upper edge);
//! - [`thin_grid`] keeps one point per occupied cell of a scatter plot, so every place where
//!   the full cloud would have put ink still gets ink;
//! - [`histogram`] counts everything, including the extremes.
//!
//! Each result says how many samples went in and how many come out, and figure captions say
//! so whenever the two differ.

/// A decimated series.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Decimated {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Samples that went in.
    pub n_in: usize,
    /// Samples that could not be drawn at all (non-finite x or y).
    pub n_nonfinite: usize,
}

impl Decimated {
    /// True when fewer points come out than finite samples went in.
    #[cfg(test)]
    fn is_decimated(&self) -> bool {
        self.x.len() < self.n_in - self.n_nonfinite
    }
    /// (x, y) pairs.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + Clone + '_ {
        self.x.iter().copied().zip(self.y.iter().copied())
    }
}

/// Column of `x` among `columns` equal columns over `[x0, x1]`.
fn column(x: f64, x0: f64, x1: f64, columns: usize) -> usize {
    if x1 > x0 {
        (((x - x0) / (x1 - x0) * columns as f64) as usize).min(columns - 1)
    } else {
        0
    }
}

fn finite_range(x: &[f64]) -> (f64, f64) {
    x.iter().filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)))
}

/// Min/max per pixel column of a series whose `x` ascends (time). Series with at most two
/// points per column are returned whole. Non-finite samples are counted, not drawn.
pub fn minmax_columns(x: &[f64], y: &[f64], columns: usize) -> Decimated {
    assert_eq!(x.len(), y.len(), "x and y differ in length");
    let n_in = x.len();
    let ok = |i: usize| x[i].is_finite() && y[i].is_finite();
    let n_nonfinite = (0..n_in).filter(|&i| !ok(i)).count();
    let columns = columns.max(1);
    if n_in - n_nonfinite <= 2 * columns {
        let (xs, ys) = (0..n_in).filter(|&i| ok(i)).map(|i| (x[i], y[i])).unzip();
        return Decimated { x: xs, y: ys, n_in, n_nonfinite };
    }
    let (x0, x1) = finite_range(x);
    let mut out =
        Decimated { x: Vec::with_capacity(2 * columns), y: Vec::with_capacity(2 * columns), n_in, n_nonfinite };
    let mut i = 0;
    while i < n_in {
        if !ok(i) {
            i += 1;
            continue;
        }
        let col = column(x[i], x0, x1, columns);
        let (mut lo, mut hi) = (i, i);
        let mut j = i + 1;
        while j < n_in && (!ok(j) || column(x[j], x0, x1, columns) == col) {
            if ok(j) {
                if y[j] < y[lo] {
                    lo = j;
                }
                if y[j] > y[hi] {
                    hi = j;
                }
            }
            j += 1;
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.x.push(x[a]);
        out.y.push(y[a]);
        if b != a {
            out.x.push(x[b]);
            out.y.push(y[b]);
        }
        i = j;
    }
    out
}

/// A band (lower and upper edge over ascending `x`) reduced to one (x, min lower, max upper)
/// per pixel column; returned whole when it has at most one point per column.
pub fn envelope_columns(x: &[f64], lo: &[f64], hi: &[f64], columns: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    assert!(x.len() == lo.len() && x.len() == hi.len(), "band edges differ in length");
    let ok = |i: usize| x[i].is_finite() && lo[i].is_finite() && hi[i].is_finite();
    let idx: Vec<usize> = (0..x.len()).filter(|&i| ok(i)).collect();
    let columns = columns.max(1);
    if idx.len() <= columns {
        return (
            idx.iter().map(|&i| x[i]).collect(),
            idx.iter().map(|&i| lo[i]).collect(),
            idx.iter().map(|&i| hi[i]).collect(),
        );
    }
    let (x0, x1) = finite_range(x);
    let (mut xs, mut ls, mut hs) = (Vec::new(), Vec::new(), Vec::new());
    let mut k = 0;
    while k < idx.len() {
        let col = column(x[idx[k]], x0, x1, columns);
        let (mut sx, mut n, mut l, mut h) = (0.0, 0usize, f64::INFINITY, f64::NEG_INFINITY);
        while k < idx.len() && column(x[idx[k]], x0, x1, columns) == col {
            let i = idx[k];
            sx += x[i];
            n += 1;
            l = l.min(lo[i]);
            h = h.max(hi[i]);
            k += 1;
        }
        xs.push(sx / n as f64);
        ls.push(l);
        hs.push(h);
    }
    (xs, ls, hs)
}

/// One point per occupied cell of an `nx × ny` grid over the given ranges (points outside
/// fall into the border cells). Clouds with no more points than cells are returned whole.
pub fn thin_grid(x: &[f64], y: &[f64], xr: (f64, f64), yr: (f64, f64), nx: usize, ny: usize) -> Decimated {
    assert_eq!(x.len(), y.len(), "x and y differ in length");
    let n_in = x.len();
    let ok = |i: usize| x[i].is_finite() && y[i].is_finite();
    let n_nonfinite = (0..n_in).filter(|&i| !ok(i)).count();
    let (nx, ny) = (nx.max(1), ny.max(1));
    if n_in - n_nonfinite <= nx * ny / 4 {
        let (xs, ys) = (0..n_in).filter(|&i| ok(i)).map(|i| (x[i], y[i])).unzip();
        return Decimated { x: xs, y: ys, n_in, n_nonfinite };
    }
    let mut seen = vec![false; nx * ny];
    let mut out = Decimated { n_in, n_nonfinite, ..Default::default() };
    for i in (0..n_in).filter(|&i| ok(i)) {
        let cx = column(x[i].clamp(xr.0, xr.1), xr.0, xr.1, nx);
        let cy = column(y[i].clamp(yr.0, yr.1), yr.0, yr.1, ny);
        let c = cy * nx + cx;
        if !seen[c] {
            seen[c] = true;
            out.x.push(x[i]);
            out.y.push(y[i]);
        }
    }
    out
}

/// Counts of `v` in `bins` equal bins over `[lo, hi]` (values equal to `hi` go in the last
/// bin, values outside are clamped into the end bins) and the number of non-finite values.
pub fn histogram(v: &[f64], lo: f64, hi: f64, bins: usize) -> (Vec<usize>, usize) {
    let bins = bins.max(1);
    let mut counts = vec![0usize; bins];
    let mut nonfinite = 0;
    for &x in v {
        if !x.is_finite() {
            nonfinite += 1;
            continue;
        }
        counts[column(x.clamp(lo, hi), lo, hi, bins)] += 1;
    }
    (counts, nonfinite)
}

/// Evenly strided subset of at most `max` indices of `0..n` (first and last kept), for paths
/// whose shape (not their envelope) matters, such as loops in a phase plot.
pub fn stride_indices(n: usize, max: usize) -> Vec<usize> {
    if n <= max || max < 2 {
        return (0..n).collect();
    }
    let step = (n - 1) as f64 / (max - 1) as f64;
    let mut v: Vec<usize> = (0..max).map(|k| ((k as f64 * step).round() as usize).min(n - 1)).collect();
    v.dedup();
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_series_are_returned_whole() {
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let y: Vec<f64> = x.iter().map(|v| v * v).collect();
        let d = minmax_columns(&x, &y, 5);
        assert_eq!(d.x, x);
        assert_eq!(d.y, y);
        assert!(!d.is_decimated());
    }

    #[test]
    fn minmax_keeps_every_columns_extremes_and_spikes() {
        let n = 1_000_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut y: Vec<f64> = x.iter().map(|v| (v / 5000.0).sin()).collect();
        y[123_457] = 50.0;
        y[876_543] = -70.0;
        let cols = 800;
        let d = minmax_columns(&x, &y, cols);
        assert!(d.is_decimated());
        assert!(d.x.len() <= 2 * cols, "{} points", d.x.len());
        assert_eq!(d.n_in, n);
        // The spikes survive.
        assert!(d.y.contains(&50.0) && d.y.contains(&-70.0));
        // Each column's min and max over the full data are present.
        for c in [0usize, 17, 400, 799] {
            let (a, b) = (c * n / cols, (c + 1) * n / cols);
            let mn = y[a..b].iter().cloned().fold(f64::INFINITY, f64::min);
            let mx = y[a..b].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let got: Vec<f64> = d.points().filter(|(xx, _)| *xx >= a as f64 && *xx < b as f64).map(|p| p.1).collect();
            assert!(got.contains(&mn) && got.contains(&mx), "column {c}");
        }
        // Time order is kept.
        assert!(d.x.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn minmax_of_a_million_samples_is_fast() {
        let n = 1_000_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = x.iter().map(|v| v.sin()).collect();
        let t = std::time::Instant::now();
        let d = minmax_columns(&x, &y, 1200);
        assert!(d.x.len() <= 2400);
        // Generous bound (debug builds, busy machines); typically a few ms in release.
        assert!(t.elapsed().as_secs_f64() < 2.0, "{:?}", t.elapsed());
    }

    #[test]
    fn non_finite_samples_are_counted_not_drawn() {
        let x: Vec<f64> = (0..100).map(f64::from).collect();
        let mut y = vec![1.0; 100];
        y[3] = f64::NAN;
        y[50] = f64::INFINITY;
        let d = minmax_columns(&x, &y, 10);
        assert_eq!(d.n_nonfinite, 2);
        assert!(d.y.iter().all(|v| v.is_finite()));
        let d = minmax_columns(&x, &y, 100);
        assert_eq!(d.x.len(), 98);
    }

    #[test]
    fn envelope_bounds_the_band() {
        let n = 10_000;
        let x: Vec<f64> = (0..n).map(f64::from).collect();
        let lo: Vec<f64> = x.iter().map(|v| (v / 300.0).sin() - 1.0).collect();
        let hi: Vec<f64> = x.iter().map(|v| (v / 300.0).sin() + 1.0).collect();
        let (xs, ls, hs) = envelope_columns(&x, &lo, &hi, 100);
        assert_eq!(xs.len(), 100);
        let mn = lo.iter().cloned().fold(f64::INFINITY, f64::min);
        let mx = hi.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(ls.iter().cloned().fold(f64::INFINITY, f64::min), mn);
        assert_eq!(hs.iter().cloned().fold(f64::NEG_INFINITY, f64::max), mx);
        // Column 0 covers samples 0..100.
        assert_eq!(ls[0], lo[..100].iter().cloned().fold(f64::INFINITY, f64::min));
    }

    #[test]
    fn thin_grid_inks_every_occupied_cell_once() {
        let n = 200_000;
        let x: Vec<f64> = (0..n).map(|i| (i % 1000) as f64 / 1000.0).collect();
        let y: Vec<f64> = (0..n).map(|i| (i / 1000) as f64 / 200.0).collect();
        let d = thin_grid(&x, &y, (0.0, 1.0), (0.0, 1.0), 50, 40);
        assert_eq!(d.x.len(), 50 * 40);
        assert_eq!(d.n_in, n);
        // A lone outlier keeps its own point.
        let mut x2 = vec![0.5; 10_000];
        let mut y2 = vec![0.5; 10_000];
        x2[7] = 0.99;
        y2[7] = 0.01;
        let d = thin_grid(&x2, &y2, (0.0, 1.0), (0.0, 1.0), 100, 100);
        assert_eq!(d.x.len(), 2);
        assert!(d.points().any(|p| p == (0.99, 0.01)));
    }

    #[test]
    fn histogram_counts_everything() {
        let v = [-1.0, 0.0, 0.5, 1.0, 2.0, f64::NAN];
        let (c, nf) = histogram(&v, 0.0, 1.0, 2);
        assert_eq!(nf, 1);
        assert_eq!(c.iter().sum::<usize>(), 5);
        assert_eq!(c, vec![2, 3]);
    }

    #[test]
    fn stride_keeps_ends() {
        let v = stride_indices(1001, 11);
        assert_eq!(v.len(), 11);
        assert_eq!(v[0], 0);
        assert_eq!(*v.last().unwrap(), 1000);
        assert_eq!(stride_indices(5, 10), vec![0, 1, 2, 3, 4]);
    }
}
