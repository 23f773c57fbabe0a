//! Seeded k-means++ (Arthur & Vassilvitskii 2007) with Lloyd iterations, for the RBF centres.

use crate::rng::Rng;

/// Cluster `points` (rows of `dim` values) into `k` centres. Deterministic for a given `rng`
/// state. Empty clusters are re-seeded at the point farthest from its centre.
pub fn kmeans_pp(points: &[Vec<f64>], k: usize, rng: &mut Rng, max_iter: usize) -> Vec<Vec<f64>> {
    let n = points.len();
    if n == 0 || k == 0 {
        return Vec::new();
    }
    let d2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    // Seeding: first centre uniform, then proportional to squared distance.
    let mut centres: Vec<Vec<f64>> = vec![points[(rng.uniform() * n as f64) as usize % n].clone()];
    let mut best: Vec<f64> = points.iter().map(|p| d2(p, &centres[0])).collect();
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
        centres.push(points[next].clone());
        let c = centres.last().cloned().unwrap_or_default();
        for (b, p) in best.iter_mut().zip(points) {
            *b = b.min(d2(p, &c));
        }
    }
    // Lloyd iterations.
    let dim = points[0].len();
    let mut assign = vec![usize::MAX; n];
    for _ in 0..max_iter {
        let mut changed = false;
        let mut far = (0usize, -1.0f64);
        for (i, p) in points.iter().enumerate() {
            let (mut bj, mut bd) = (0, f64::INFINITY);
            for (j, c) in centres.iter().enumerate() {
                let d = d2(p, c);
                if d < bd {
                    bd = d;
                    bj = j;
                }
            }
            if assign[i] != bj {
                assign[i] = bj;
                changed = true;
            }
            if bd > far.1 {
                far = (i, bd);
            }
        }
        let mut sums = vec![vec![0.0; dim]; k];
        let mut counts = vec![0usize; k];
        for (p, &a) in points.iter().zip(&assign) {
            counts[a] += 1;
            for (s, v) in sums[a].iter_mut().zip(p) {
                *s += v;
            }
        }
        for j in 0..k {
            if counts[j] == 0 {
                centres[j] = points[far.0].clone();
                changed = true;
            } else {
                for (c, s) in centres[j].iter_mut().zip(&sums[j]) {
                    *c = s / counts[j] as f64;
                }
            }
        }
        if !changed {
            break;
        }
    }
    centres
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
                pts.push(vec![c[0] + 0.1 * rng.normal(), c[1] + 0.1 * rng.normal()]);
            }
        }
        let mut r2 = Rng::new(2, Stream::Temperature);
        let mut cs = kmeans_pp(&pts, 3, &mut r2, 50);
        cs.sort_by(|a, b| (a[0] + 2.0 * a[1]).total_cmp(&(b[0] + 2.0 * b[1])));
        assert!((cs[0][0]).abs() < 0.1 && (cs[1][0] - 10.0).abs() < 0.1 && (cs[2][1] - 10.0).abs() < 0.1, "{cs:?}");
    }
}
