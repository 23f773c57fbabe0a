//! What the RBF layer learns from a training set before any weight: its inputs z (DESIGN
//! §4), their mean and spread, and the centres k-means++ places among them.

use fbg_shared::layout::{Dims, FeatureSet, MAX_GRATINGS, MAX_Z};

use super::design;
use super::host::HostParams;
use super::kmeans;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::rng::{Rng, Stream};

/// At most this many points go into k-means (an even stride through the training set).
pub(crate) const KMEANS_MAX_POINTS: usize = 20_000;

/// The RBF inputs [Δλ_1..N, T_amb (with ambient), t, latch_1..N] of sample `i` with its latch
/// values (0 beyond [`Dims::z_len`]).
pub(crate) fn z_of(dims: &Dims, d: &Dataset, i: usize, latch: &[f64; MAX_GRATINGS]) -> [f64; MAX_Z] {
    let n = dims.gratings();
    let mut z = [0.0; MAX_Z];
    for (o, c) in z.iter_mut().zip(&d.dl_pm).take(n) {
        *o = c[i];
    }
    if dims.ambient() {
        z[n] = d.ambient()[i];
    }
    z[dims.z_time()] = d.t_s[i];
    z[dims.z_latch()..dims.z_latch() + n].copy_from_slice(&latch[..n]);
    z
}

/// What the RBF layer learns from a training set before any centre exists: the mean and
/// standard deviation of every RBF input over the training rows, and the raw inputs of the
/// rows k-means clusters (every `stride`-th training row, at most [`KMEANS_MAX_POINTS`]).
#[derive(Clone, Debug)]
pub(crate) struct ZSample {
    /// The inputs' layout.
    pub(crate) dims: Dims,
    pub(crate) mean: [f64; MAX_Z],
    /// Population standard deviation (1 where an input is constant or beyond the inputs).
    pub(crate) std: [f64; MAX_Z],
    pub(crate) points: Vec<[f64; MAX_Z]>,
}

/// [`ZSample`] of the training rows `src` (sorted), the latches moved by `stream` (a model
/// with the dead band in question) over every sample from the first, exactly as the
/// compensator moves them (or taken from a [`design::CoreStream`] of that stream).
pub(crate) fn z_sample(stream: &HostParams, d: &Dataset, src: design::Rows<'_>) -> Result<ZSample, TrainerError> {
    let train = src.rows();
    let stride = train.len().div_ceil(KMEANS_MAX_POINTS).max(1);
    // Per stretch: count, mean and sum of squared deviations (combined below in stretch order
    // by Chan's formula), and the k-means points.
    type Part = (f64, [f64; MAX_Z], [f64; MAX_Z], Vec<[f64; MAX_Z]>);
    let dims = stream.dims;
    let parts: Vec<Part> = design::map_rows(stream, d, src, |o| {
        let p0 = train.partition_point(|&i| i < o.rows[0]);
        let zs: Vec<[f64; MAX_Z]> = o.rows.iter().zip(o.latches).map(|(&i, l)| z_of(&dims, d, i, l)).collect();
        let n = zs.len() as f64;
        let mean: [f64; MAX_Z] = std::array::from_fn(|k| zs.iter().map(|z| z[k]).sum::<f64>() / n);
        let m2: [f64; MAX_Z] = std::array::from_fn(|k| zs.iter().map(|z| (z[k] - mean[k]).powi(2)).sum::<f64>());
        let pts = zs.iter().enumerate().filter(|(r, _)| (p0 + r) % stride == 0).map(|(_, z)| *z).collect();
        (n, mean, m2, pts)
    })?;
    let (mut n, mut mean, mut m2) = (0.0f64, [0.0; MAX_Z], [0.0; MAX_Z]);
    let mut points = Vec::new();
    for (nb, mb, m2b, pts) in parts {
        let tot = n + nb;
        for k in 0..dims.z_len() {
            let delta = mb[k] - mean[k];
            mean[k] += delta * nb / tot;
            m2[k] += m2b[k] + delta * delta * n * nb / tot;
        }
        n = tot;
        points.extend(pts);
    }
    let std = std::array::from_fn(|k| if m2[k] > 0.0 { (m2[k] / n).sqrt() } else { 1.0 });
    Ok(ZSample { dims, mean, std, points })
}

/// Centres by k-means++ (seeded) over the standardised k-means points of `zs`, on the inputs
/// the feature set uses.
pub(crate) fn centres(zs: &ZSample, fs: FeatureSet, k: usize, seed: u64) -> Vec<[f64; MAX_Z]> {
    let active = zs.dims.z_active(fs);
    let used: Vec<usize> = (0..MAX_Z).filter(|&d| active[d]).collect();
    let mut rng = Rng::new(seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15), Stream::Kmeans);
    // k-means on the used inputs only, packed in order (the unused ones would only add exact
    // zeros to every distance): a paper-shaped model clusters in 8 dimensions, not MAX_Z.
    if used.len() <= 8 {
        packed_centres::<8>(zs, &used, k, &mut rng)
    } else if used.len() <= 12 {
        packed_centres::<12>(zs, &used, k, &mut rng)
    } else {
        packed_centres::<MAX_Z>(zs, &used, k, &mut rng)
    }
}

/// [`centres`] with the `used` inputs packed into `D` dimensions, unpacked into the model's
/// layout afterwards.
fn packed_centres<const D: usize>(zs: &ZSample, used: &[usize], k: usize, rng: &mut Rng) -> Vec<[f64; MAX_Z]> {
    let pts: Vec<[f64; D]> = zs
        .points
        .iter()
        .map(|z| {
            let mut p = [0.0; D];
            for (o, &d) in p.iter_mut().zip(used) {
                *o = (z[d] - zs.mean[d]) / zs.std[d];
            }
            p
        })
        .collect();
    kmeans::kmeans_pp(&pts, k.min(pts.len()), rng, 100)
        .into_iter()
        .map(|c| {
            let mut full = [0.0; MAX_Z];
            for (&v, &d) in c.iter().zip(used) {
                full[d] = v;
            }
            full
        })
        .collect()
}

/// Median (the upper one for an even count) distance from each centre to its nearest other
/// centre (standardised units).
pub(crate) fn median_nn_distance(cs: &[[f64; MAX_Z]]) -> f64 {
    if cs.len() < 2 {
        return 1.0;
    }
    let nn: Vec<f64> = cs
        .iter()
        .enumerate()
        .map(|(i, a)| {
            cs.iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, b)| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let m = crate::stats::upper_median(&nn);
    if m > 0.0 {
        m
    } else {
        1.0
    }
}
