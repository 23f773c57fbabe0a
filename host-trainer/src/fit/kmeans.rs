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
pub(crate) const TOL: f64 = 1e-4;

#[inline]
fn d2<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut s = 0.0;
    for k in 0..D {
        let t = a[k] - b[k];
        s += t * t;
    }
    s
}

/// Cluster `points` into `k` centres. Deterministic for a given `rng` state. Empty clusters
/// are re-seeded at the point farthest from its centre.
pub(crate) fn kmeans_pp<const D: usize>(
    points: &[[f64; D]],
    k: usize,
    rng: &mut Rng,
    max_iter: usize,
) -> Vec<[f64; D]> {
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
    lloyd(points, centres, max_iter)
}

/// Lloyd iterations from `centres` until no assignment changes, the centres move by less than
/// the tolerance, or `max_iter`.
fn lloyd<const D: usize>(points: &[[f64; D]], mut centres: Vec<[f64; D]>, max_iter: usize) -> Vec<[f64; D]> {
    let tol = TOL * mean_variance(points);
    let mut bounds = Bounds::new(points.len());
    for _ in 0..max_iter {
        let (changed, sums, counts) = bounds.assign(points, &centres);
        let (reseeded, shift, moved) = update(points, &bounds.assign, &mut centres, &sums, &counts);
        if !(changed || reseeded) || shift <= tol {
            break;
        }
        bounds.follow(&moved);
    }
    centres
}

/// The assignment of every point and Hamerly's bounds (2010), which accelerate the Lloyd
/// iterations exactly: per point an upper bound on the distance to its centre and a lower
/// bound on the distance to every other; a point whose upper bound is below both its lower
/// bound and half the distance from its centre to the nearest other centre keeps its centre
/// without any distance computed.
struct Bounds {
    /// Centre of each point (`usize::MAX` before the first assignment).
    assign: Vec<usize>,
    upper: Vec<f64>,
    lower: Vec<f64>,
}

impl Bounds {
    fn new(n: usize) -> Self {
        Bounds { assign: vec![usize::MAX; n], upper: vec![f64::INFINITY; n], lower: vec![0.0; n] }
    }

    /// Assign every point to its nearest centre: whether any assignment changed, and the sum
    /// and count of the points of each centre (added over fixed blocks in block order).
    fn assign<const D: usize>(
        &mut self,
        points: &[[f64; D]],
        centres: &[[f64; D]],
    ) -> (bool, Vec<[f64; D]>, Vec<usize>) {
        let k = centres.len();
        // Half the distance from each centre to its nearest other centre.
        let half: Vec<f64> = (0..k)
            .map(|j| {
                let m = (0..k).filter(|&i| i != j).map(|i| d2(&centres[i], &centres[j])).fold(f64::INFINITY, f64::min);
                0.5 * m.sqrt()
            })
            .collect();
        // Per block: label changes, per-centre sums and counts.
        type Part<const D: usize> = (bool, Vec<[f64; D]>, Vec<usize>);
        let parts: Vec<Part<D>> = self
            .assign
            .par_chunks_mut(BLOCK)
            .zip(self.upper.par_chunks_mut(BLOCK))
            .zip(self.lower.par_chunks_mut(BLOCK))
            .zip(points.par_chunks(BLOCK))
            .map(|(((labels, up), lo), pts)| {
                let mut changed = false;
                let mut sums = vec![[0.0; D]; k];
                let mut counts = vec![0usize; k];
                for (((l, u), lb), p) in labels.iter_mut().zip(up.iter_mut()).zip(lo.iter_mut()).zip(pts) {
                    let a = *l;
                    let skip = a != usize::MAX && {
                        let m = half[a].max(*lb);
                        *u <= m || {
                            *u = d2(p, &centres[a]).sqrt();
                            *u <= m
                        }
                    };
                    if !skip {
                        // Nearest and second-nearest centre (the first on ties, as Lloyd).
                        let (mut b1, mut d1, mut d2nd) = (0usize, f64::INFINITY, f64::INFINITY);
                        for (j, c) in centres.iter().enumerate() {
                            let d = d2(p, c);
                            if d < d1 {
                                d2nd = d1;
                                d1 = d;
                                b1 = j;
                            } else if d < d2nd {
                                d2nd = d;
                            }
                        }
                        if *l != b1 {
                            *l = b1;
                            changed = true;
                        }
                        *u = d1.sqrt();
                        *lb = d2nd.sqrt();
                    }
                    counts[*l] += 1;
                    for (s, v) in sums[*l].iter_mut().zip(p) {
                        *s += v;
                    }
                }
                (changed, sums, counts)
            })
            .collect();
        let mut changed = false;
        let mut sums = vec![[0.0; D]; k];
        let mut counts = vec![0usize; k];
        for (ch, s, c) in parts {
            changed |= ch;
            for j in 0..k {
                counts[j] += c[j];
                for (a, b) in sums[j].iter_mut().zip(&s[j]) {
                    *a += b;
                }
            }
        }
        (changed, sums, counts)
    }

    /// Keep the bounds valid for centres that moved by `moved`.
    fn follow(&mut self, moved: &[f64]) {
        let (mut m1, mut j1, mut m2) = (0.0f64, usize::MAX, 0.0f64);
        for (j, &m) in moved.iter().enumerate() {
            if m > m1 {
                m2 = m1;
                m1 = m;
                j1 = j;
            } else if m > m2 {
                m2 = m;
            }
        }
        self.upper.par_iter_mut().zip(self.lower.par_iter_mut()).zip(self.assign.par_iter()).for_each(
            |((u, lb), &a)| {
                *u += moved[a];
                *lb -= if a == j1 { m2 } else { m1 };
            },
        );
    }
}

/// Move every centre to the mean of its points (`sums`, `counts` by centre; `assign` by point):
/// whether an empty cluster was re-seeded, the summed squared shift, and each centre's move.
fn update<const D: usize>(
    points: &[[f64; D]],
    assign: &[usize],
    centres: &mut [[f64; D]],
    sums: &[[f64; D]],
    counts: &[usize],
) -> (bool, f64, Vec<f64>) {
    let k = centres.len();
    // An empty cluster is re-seeded at the point farthest from its centre (exact distances:
    // the bounds are not enough to rank points).
    let far = if counts.contains(&0) {
        let (i, _) = points
            .iter()
            .zip(assign)
            .map(|(p, &a)| d2(p, &centres[a]))
            .enumerate()
            .fold((0usize, -1.0f64), |best, (i, d)| if d > best.1 { (i, d) } else { best });
        Some(i)
    } else {
        None
    };
    let mut reseeded = false;
    let mut shift = 0.0;
    let mut moved = vec![0.0f64; k];
    for j in 0..k {
        let new = match (counts[j], far) {
            (0, Some(f)) => {
                reseeded = true;
                points[f]
            }
            _ => sums[j].map(|s| s / counts[j].max(1) as f64),
        };
        let dj = d2(&new, &centres[j]);
        shift += dj;
        moved[j] = dj.sqrt();
        centres[j] = new;
    }
    (reseeded, shift, moved)
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

    /// Plain Lloyd, every distance computed every iteration: what Hamerly's bounds must
    /// reproduce.
    fn lloyd_plain<const D: usize>(points: &[[f64; D]], mut centres: Vec<[f64; D]>, max_iter: usize) -> Vec<[f64; D]> {
        let tol = TOL * mean_variance(points);
        let mut assign = vec![usize::MAX; points.len()];
        for _ in 0..max_iter {
            let mut changed = false;
            let mut sums = vec![[0.0; D]; centres.len()];
            let mut counts = vec![0usize; centres.len()];
            for (a, p) in assign.iter_mut().zip(points) {
                let (mut bj, mut bd) = (0, f64::INFINITY);
                for (j, c) in centres.iter().enumerate() {
                    if d2(p, c) < bd {
                        bd = d2(p, c);
                        bj = j;
                    }
                }
                changed |= *a != bj;
                *a = bj;
                counts[bj] += 1;
                for (s, v) in sums[bj].iter_mut().zip(p) {
                    *s += v;
                }
            }
            let mut shift = 0.0;
            for j in 0..centres.len() {
                let new = sums[j].map(|s| s / counts[j].max(1) as f64);
                shift += d2(&new, &centres[j]);
                centres[j] = new;
            }
            if !changed || shift <= tol {
                break;
            }
        }
        centres
    }

    #[test]
    fn hamerly_bounds_reproduce_plain_lloyd() {
        let mut rng = Rng::new(5, Stream::Temperature);
        // Overlapping clusters, so that many points sit near boundaries.
        let pts: Vec<[f64; 4]> = (0..5000)
            .map(|i| {
                let c = (i % 7) as f64;
                [c + rng.normal(), 0.5 * c + rng.normal(), rng.normal(), rng.uniform()]
            })
            .collect();
        let start: Vec<[f64; 4]> = pts.iter().step_by(500).copied().collect();
        let fast = lloyd(&pts, start.clone(), 200);
        let plain = lloyd_plain(&pts, start, 200);
        for (a, b) in fast.iter().zip(&plain) {
            for (x, y) in a.iter().zip(b) {
                assert!((x - y).abs() <= 1e-12 * (1.0 + y.abs()), "{fast:?}\nvs\n{plain:?}");
            }
        }
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
