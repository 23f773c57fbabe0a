//! Seeded k-means++ (Arthur & Vassilvitskii 2007) with Lloyd iterations, for the RBF centres.
//!
//! The assignment step runs in parallel over fixed blocks of points whose partial sums are
//! added in block order, so the centres do not depend on the number of threads.

use rayon::prelude::*;

use crate::rng::Rng;

/// Points per parallel block of the assignment step.
const BLOCK: usize = 2048;

/// Relative tolerance of the Lloyd iterations: they stop when the centres move by less than
/// this times the mean variance of the data (squared distance summed over the centres), as
/// scikit-learn's `KMeans(tol=1e-4)` does, or when no assignment changes.
pub const TOL: f64 = 1e-4;

#[inline]
fn d2<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut s = 0.0;
    for k in 0..D {
        let t = a[k] - b[k];
        s += t * t;
    }
    s
}

/// Index and squared distance of the centre nearest to `p` (the first on ties).
#[inline]
fn nearest<const D: usize>(p: &[f64; D], centres: &[[f64; D]]) -> (usize, f64) {
    let (mut bj, mut bd) = (0, f64::INFINITY);
    for (j, c) in centres.iter().enumerate() {
        let d = d2(p, c);
        if d < bd {
            bd = d;
            bj = j;
        }
    }
    (bj, bd)
}

/// Cluster `points` into `k` centres. Deterministic for a given `rng` state. Empty clusters
/// are re-seeded at the point farthest from its centre.
pub fn kmeans_pp<const D: usize>(points: &[[f64; D]], k: usize, rng: &mut Rng, max_iter: usize) -> Vec<[f64; D]> {
    let n = points.len();
    if n == 0 || k == 0 {
        return Vec::new();
    }
    // Seeding: first centre uniform, then proportional to squared distance.
    let mut centres: Vec<[f64; D]> = vec![points[(rng.uniform() * n as f64) as usize % n]];
    let mut best: Vec<f64> = points.par_iter().map(|p| d2(p, &centres[0])).collect();
    while centres.len() < k {
        let total: f64 = best.iter().sum();
        let next = if total > 0.0 {
            let mut u = rng.uniform() * total;
            let mut pick = n - 1;
            for (i, b) in best.iter().enumerate() {
                if u < *b {
                    pick = i;
                    break;
                }
                u -= b;
            }
            pick
        } else {
            (rng.uniform() * n as f64) as usize % n
        };
        let c = points[next];
        centres.push(c);
        best.par_iter_mut().zip(points.par_iter()).for_each(|(b, p)| *b = b.min(d2(p, &c)));
    }
    let tol = TOL * mean_variance(points);
    // Lloyd iterations.
    let mut assign = vec![usize::MAX; n];
    for _ in 0..max_iter {
        // Per block: label changes, farthest point, per-centre sums and counts.
        type Part<const D: usize> = (bool, (usize, f64), Vec<[f64; D]>, Vec<usize>);
        let parts: Vec<Part<D>> = assign
            .par_chunks_mut(BLOCK)
            .zip(points.par_chunks(BLOCK))
            .enumerate()
            .map(|(b, (labels, pts))| {
                let mut changed = false;
                let mut far = (0usize, -1.0f64);
                let mut sums = vec![[0.0; D]; k];
                let mut counts = vec![0usize; k];
                for (r, (l, p)) in labels.iter_mut().zip(pts).enumerate() {
                    let (bj, bd) = nearest(p, &centres);
                    if *l != bj {
                        *l = bj;
                        changed = true;
                    }
                    if bd > far.1 {
                        far = (b * BLOCK + r, bd);
                    }
                    counts[bj] += 1;
                    for (s, v) in sums[bj].iter_mut().zip(p) {
                        *s += v;
                    }
                }
                (changed, far, sums, counts)
            })
            .collect();
        let mut changed = false;
        let mut far = (0usize, -1.0f64);
        let mut sums = vec![[0.0; D]; k];
        let mut counts = vec![0usize; k];
        for (ch, f, s, c) in parts {
            changed |= ch;
            if f.1 > far.1 {
                far = f;
            }
            for j in 0..k {
                counts[j] += c[j];
                for (a, b) in sums[j].iter_mut().zip(&s[j]) {
                    *a += b;
                }
            }
        }
        let mut shift = 0.0;
        for j in 0..k {
            let new = if counts[j] == 0 {
                changed = true;
                points[far.0]
            } else {
                sums[j].map(|s| s / counts[j] as f64)
            };
            shift += d2(&new, &centres[j]);
            centres[j] = new;
        }
        if !changed || shift <= tol {
            break;
        }
    }
    centres
}

/// Mean over the dimensions that vary of each dimension's variance.
fn mean_variance<const D: usize>(points: &[[f64; D]]) -> f64 {
    let n = points.len() as f64;
    let mut total = 0.0;
    let mut dims = 0;
    for k in 0..D {
        let m = points.iter().map(|p| p[k]).sum::<f64>() / n;
        let v = points.iter().map(|p| (p[k] - m).powi(2)).sum::<f64>() / n;
        if v > 0.0 {
            total += v;
            dims += 1;
        }
    }
    if dims == 0 {
        0.0
    } else {
        total / dims as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    #[test]
    fn finds_separated_clusters() {
        let mut rng = Rng::new(1, Stream::Temperature);
        let mut pts = vec![];
        for c in [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]] {
            for _ in 0..100 {
                pts.push([c[0] + 0.1 * rng.normal(), c[1] + 0.1 * rng.normal()]);
            }
        }
        let mut r2 = Rng::new(2, Stream::Temperature);
        let mut cs = kmeans_pp(&pts, 3, &mut r2, 50);
        cs.sort_by(|a, b| (a[0] + 2.0 * a[1]).total_cmp(&(b[0] + 2.0 * b[1])));
        assert!((cs[0][0]).abs() < 0.1 && (cs[1][0] - 10.0).abs() < 0.1 && (cs[2][1] - 10.0).abs() < 0.1, "{cs:?}");
    }

    #[test]
    fn same_centres_on_any_pool_size() {
        let mut rng = Rng::new(3, Stream::Temperature);
        let pts: Vec<[f64; 3]> = (0..9000).map(|_| [rng.normal(), rng.normal() * 2.0, rng.uniform()]).collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| kmeans_pp(&pts, 16, &mut Rng::new(4, Stream::Kmeans), 100))
        };
        assert_eq!(run(1), run(3));
    }
}
