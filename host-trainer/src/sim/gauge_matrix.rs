//! The gratings' forward physics (paper Eq. 2-3): Δλ = K·Δm + cross-terms, with each gauge
//! entry dispersed by manufacturing, and its exact inverse (Newton for a square gauge matrix,
//! Gauss–Newton least squares for more gratings than measurands).

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::data::measurand::Measurand;
use crate::rng::{Rng, Stream};
use crate::sim::scenario::Gratings;

/// The true physics of one installation (after dispersion): N gratings, M measurands.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GaugePhysics {
    /// The measurands, in the gauge matrix's column order.
    pub measurands: Vec<Measurand>,
    /// Gauge matrix rows per grating, one entry per measurand (pm/°C, pm/µε, pm/kPa).
    pub k: Vec<Vec<f64>>,
    /// Cross-terms per grating on the first T, ε and p (zero where absent).
    pub c_tt: Vec<f64>,
    pub c_te: Vec<f64>,
    pub c_tp: Vec<f64>,
    pub c_ee: Vec<f64>,
    pub c_pp: Vec<f64>,
    pub c_ep: Vec<f64>,
    /// Reference point of the Δ's, per measurand.
    pub reference: Vec<f64>,
    /// Column of T, ε, p (the first of each kind) among the measurands.
    #[serde(skip)]
    tep: [Option<usize>; 3],
}

impl GaugePhysics {
    /// The configured gauge matrix with every entry × (1 + N(0, dispersion)), seeded (row by
    /// row, so the paper's 3 × 3 draws what it always did).
    pub fn dispersed(cfg: &Gratings, measurands: &[Measurand], seed: u64) -> Self {
        let mut rng = Rng::new(seed, Stream::GaugeDispersion);
        let mut k = cfg.gauge.clone();
        for row in k.iter_mut() {
            for v in row.iter_mut() {
                *v *= 1.0 + cfg.dispersion * rng.normal();
            }
        }
        let n = k.len();
        let cross = |v: &Vec<f64>| if v.is_empty() { vec![0.0; n] } else { v.clone() };
        let reference = measurands
            .iter()
            .map(|m| match m.kind {
                crate::data::Kind::Temperature => cfg.ref_t_c,
                crate::data::Kind::Strain => cfg.ref_strain_ue,
                crate::data::Kind::Pressure => cfg.ref_p_kpa,
            })
            .collect();
        GaugePhysics {
            measurands: measurands.to_vec(),
            k,
            c_tt: cross(&cfg.c_tt),
            c_te: cross(&cfg.c_te),
            c_tp: cross(&cfg.c_tp),
            c_ee: cross(&cfg.c_ee),
            c_pp: cross(&cfg.c_pp),
            c_ep: cross(&cfg.c_ep),
            reference,
            tep: Measurand::PAPER.map(|p| measurands.iter().position(|m| *m == p)),
        }
    }

    /// Number of gratings.
    pub fn n_gratings(&self) -> usize {
        self.k.len()
    }

    /// Shifts \[pm\] of the gratings for the measurands `m` (in [`measurands`](Self::measurands)
    /// order).
    pub fn forward(&self, m: &[f64]) -> Vec<f64> {
        let d = self.delta(m);
        (0..self.k.len()).map(|i| self.linear_row(i, &d) + self.cross_row(i, &d)).collect()
    }

    /// The shift \[pm\] of grating `i` alone for the measurands `m` (the same arithmetic as
    /// [`forward`](Self::forward)): a grating whose package lags or creeps sees its own `m`.
    pub(crate) fn forward_row(&self, i: usize, m: &[f64]) -> f64 {
        let d = self.delta(m);
        self.linear_row(i, &d) + self.cross_row(i, &d)
    }

    /// Only the cross-term part of `forward` \[pm\].
    pub fn cross_terms(&self, m: &[f64]) -> Vec<f64> {
        let d = self.delta(m);
        (0..self.k.len()).map(|i| self.cross_row(i, &d)).collect()
    }

    fn delta(&self, m: &[f64]) -> Vec<f64> {
        m.iter().zip(&self.reference).map(|(x, r)| x - r).collect()
    }

    fn linear_row(&self, i: usize, d: &[f64]) -> f64 {
        // Left to right from the first product (no leading 0.0): the paper's 3 × 3 sums
        // exactly as it always did.
        let mut terms = self.k[i].iter().zip(d).map(|(k, d)| k * d);
        let first = terms.next().unwrap_or(0.0);
        terms.fold(first, |a, t| a + t)
    }

    /// (ΔT, Δε, Δp) of the first T, ε, p; 0 where absent.
    fn tep(&self, d: &[f64]) -> [f64; 3] {
        self.tep.map(|c| c.map_or(0.0, |c| d[c]))
    }

    fn cross_row(&self, i: usize, d: &[f64]) -> f64 {
        let [dt, de, dp] = self.tep(d);
        self.c_tt[i] * dt * dt
            + self.c_te[i] * dt * de
            + self.c_tp[i] * dt * dp
            + self.c_ee[i] * de * de
            + self.c_pp[i] * dp * dp
            + self.c_ep[i] * de * dp
    }

    /// ∂Δλ_i/∂m_j.
    fn jacobian_entry(&self, i: usize, j: usize, d: &[f64]) -> f64 {
        let [dt, de, dp] = self.tep(d);
        let mut x = self.k[i][j];
        if self.tep[0] == Some(j) {
            x += 2.0 * self.c_tt[i] * dt + self.c_te[i] * de + self.c_tp[i] * dp;
        }
        if self.tep[1] == Some(j) {
            x += self.c_te[i] * dt + 2.0 * self.c_ee[i] * de + self.c_ep[i] * dp;
        }
        if self.tep[2] == Some(j) {
            x += self.c_tp[i] * dt + self.c_ep[i] * de + 2.0 * self.c_pp[i] * dp;
        }
        x
    }

    /// Exact inverse of `forward`: the measurands for shifts `dl_pm`, by Newton's method from
    /// the linear solution (least squares, Gauss–Newton, when there are more gratings than
    /// measurands). Falls back to the best iterate if the Jacobian becomes singular (not seen
    /// with physical parameters); NaN when the gauge matrix itself is.
    pub(crate) fn invert(&self, dl_pm: &[f64]) -> Vec<f64> {
        if self.k.len() == 3 && self.measurands.len() == 3 {
            return self.invert3([dl_pm[0], dl_pm[1], dl_pm[2]]).to_vec();
        }
        let (n, m) = (self.k.len(), self.measurands.len());
        let k = DMatrix::from_fn(n, m, |i, j| self.k[i][j]);
        let target = DVector::from_column_slice(dl_pm);
        let Ok(mut d) = k.svd(true, true).solve(&target, 1e-12) else {
            return vec![f64::NAN; m];
        };
        for _ in 0..20 {
            let dd: Vec<f64> = d.iter().copied().collect();
            let f = DVector::from_fn(n, |i, _| self.linear_row(i, &dd) + self.cross_row(i, &dd) - dl_pm[i]);
            let j = DMatrix::from_fn(n, m, |i, c| self.jacobian_entry(i, c, &dd));
            let Ok(step) = j.svd(true, true).solve(&f, 1e-12) else { break };
            d -= &step;
            if step.amax() < 1e-12 * (1.0 + d.amax()) {
                break;
            }
        }
        d.iter().zip(&self.reference).map(|(x, r)| x + r).collect()
    }

    /// The paper's 3 × 3 Newton inverse (kept exactly as it was, for identical oracles).
    fn invert3(&self, dl_pm: [f64; 3]) -> [f64; 3] {
        let k = Matrix3::from_fn(|i, j| self.k[i][j]);
        let target = Vector3::from(dl_pm);
        let Some(k_inv) = k.try_inverse() else {
            return [f64::NAN; 3];
        };
        let mut d = k_inv * target;
        for _ in 0..20 {
            let dd = [d[0], d[1], d[2]];
            let mut f = [0.0; 3];
            for (i, fi) in f.iter_mut().enumerate() {
                *fi = self.linear_row(i, &dd) + self.cross_row(i, &dd) - dl_pm[i];
            }
            let Some(j_inv) = Matrix3::from_fn(|i, j| self.jacobian_entry(i, j, &dd)).try_inverse() else { break };
            let step = j_inv * Vector3::from(f);
            d -= step;
            if step.amax() < 1e-12 * (1.0 + d.amax()) {
                break;
            }
        }
        [d[0] + self.reference[0], d[1] + self.reference[1], d[2] + self.reference[2]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scenario::Preset;

    #[test]
    fn newton_inverts_forward_exactly() {
        let g = GaugePhysics::dispersed(&Gratings::default(), &Measurand::PAPER, 3);
        for m in [[20.0, 0.0, 150.0], [35.0, -140.0, 190.0], [5.0, 160.0, 100.0]] {
            let back = g.invert(&g.forward(&m));
            for (a, b) in back.iter().zip(m.iter()) {
                assert!((a - b).abs() < 1e-9, "{back:?} vs {m:?}");
            }
        }
    }

    #[test]
    fn every_preset_inverts_exactly() {
        for p in Preset::ALL {
            let c = p.config();
            let g = GaugePhysics::dispersed(&c.gratings, &c.measurands, 5);
            let m: Vec<f64> = c
                .measurands
                .iter()
                .map(|m| match m.kind {
                    crate::data::Kind::Temperature => 31.0,
                    crate::data::Kind::Strain => -120.0,
                    crate::data::Kind::Pressure => 170.0,
                })
                .collect();
            let back = g.invert(&g.forward(&m));
            for (a, b) in back.iter().zip(&m) {
                assert!((a - b).abs() < 1e-8, "{}: {back:?} vs {m:?}", p.name());
            }
        }
    }

    #[test]
    fn dispersion_is_seeded_and_small() {
        let cfg = Gratings::default();
        let a = GaugePhysics::dispersed(&cfg, &Measurand::PAPER, 1);
        assert_eq!(a, GaugePhysics::dispersed(&cfg, &Measurand::PAPER, 1));
        assert_ne!(a, GaugePhysics::dispersed(&cfg, &Measurand::PAPER, 2));
        for (ra, rc) in a.k.iter().zip(cfg.gauge.iter()) {
            for (x, y) in ra.iter().zip(rc.iter()) {
                assert!((x / y - 1.0).abs() < 0.2);
            }
        }
    }
}
