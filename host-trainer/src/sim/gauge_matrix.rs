//! The gratings' forward physics (paper Eq. 2-3): Δλ = K·Δm + cross-terms, with each gauge
//! entry dispersed by manufacturing, and its exact inverse by Newton's method.

use nalgebra::{Matrix3, Vector3};

use crate::rng::{Rng, Stream};
use crate::sim::scenario::Gratings;

/// The true physics of one installation (after dispersion).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GaugePhysics {
    /// Gauge matrix rows per grating: [pm/°C, pm/µε, pm/kPa].
    pub k: [[f64; 3]; 3],
    pub c_tt: [f64; 3],
    pub c_te: [f64; 3],
    pub c_tp: [f64; 3],
    pub c_ee: [f64; 3],
    pub c_pp: [f64; 3],
    pub c_ep: [f64; 3],
    /// Reference point (T °C, ε µε, p kPa) of the Δ's.
    pub reference: [f64; 3],
}

impl GaugePhysics {
    /// The configured gauge matrix with every entry × (1 + N(0, dispersion)), seeded.
    pub fn dispersed(cfg: &Gratings, seed: u64) -> Self {
        let mut rng = Rng::new(seed, Stream::GaugeDispersion);
        let mut k = cfg.gauge;
        for row in k.iter_mut() {
            for v in row.iter_mut() {
                *v *= 1.0 + cfg.dispersion * rng.normal();
            }
        }
        GaugePhysics {
            k,
            c_tt: cfg.c_tt,
            c_te: cfg.c_te,
            c_tp: cfg.c_tp,
            c_ee: cfg.c_ee,
            c_pp: cfg.c_pp,
            c_ep: cfg.c_ep,
            reference: [cfg.ref_t_c, cfg.ref_strain_ue, cfg.ref_p_kpa],
        }
    }

    /// Shifts \[pm\] of the three gratings for measurands (T °C, ε µε, p kPa).
    pub fn forward(&self, m: [f64; 3]) -> [f64; 3] {
        let d = self.delta(m);
        let mut out = [0.0; 3];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.linear_row(i, d) + self.cross_row(i, d);
        }
        out
    }

    /// Only the cross-term part of `forward` \[pm\].
    pub fn cross_terms(&self, m: [f64; 3]) -> [f64; 3] {
        let d = self.delta(m);
        let mut out = [0.0; 3];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.cross_row(i, d);
        }
        out
    }

    fn delta(&self, m: [f64; 3]) -> [f64; 3] {
        [m[0] - self.reference[0], m[1] - self.reference[1], m[2] - self.reference[2]]
    }

    fn linear_row(&self, i: usize, d: [f64; 3]) -> f64 {
        self.k[i][0] * d[0] + self.k[i][1] * d[1] + self.k[i][2] * d[2]
    }

    fn cross_row(&self, i: usize, [dt, de, dp]: [f64; 3]) -> f64 {
        self.c_tt[i] * dt * dt
            + self.c_te[i] * dt * de
            + self.c_tp[i] * dt * dp
            + self.c_ee[i] * de * de
            + self.c_pp[i] * dp * dp
            + self.c_ep[i] * de * dp
    }

    fn jacobian(&self, [dt, de, dp]: [f64; 3]) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| {
            let k = self.k[i][j];
            k + match j {
                0 => 2.0 * self.c_tt[i] * dt + self.c_te[i] * de + self.c_tp[i] * dp,
                1 => self.c_te[i] * dt + 2.0 * self.c_ee[i] * de + self.c_ep[i] * dp,
                _ => self.c_tp[i] * dt + self.c_ep[i] * de + 2.0 * self.c_pp[i] * dp,
            }
        })
    }

    /// Exact inverse of `forward` by Newton's method from the linear solution; returns the
    /// measurands (T °C, ε µε, p kPa). Falls back to the best iterate if the Jacobian becomes
    /// singular (not seen with physical parameters).
    pub fn invert(&self, dl_pm: [f64; 3]) -> [f64; 3] {
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
                *fi = self.linear_row(i, dd) + self.cross_row(i, dd) - dl_pm[i];
            }
            let Some(j_inv) = self.jacobian(dd).try_inverse() else { break };
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

    #[test]
    fn newton_inverts_forward_exactly() {
        let g = GaugePhysics::dispersed(&Gratings::default(), 3);
        for m in [[20.0, 0.0, 150.0], [35.0, -140.0, 190.0], [5.0, 160.0, 100.0]] {
            let back = g.invert(g.forward(m));
            for (a, b) in back.iter().zip(m.iter()) {
                assert!((a - b).abs() < 1e-9, "{back:?} vs {m:?}");
            }
        }
    }

    #[test]
    fn dispersion_is_seeded_and_small() {
        let cfg = Gratings::default();
        let a = GaugePhysics::dispersed(&cfg, 1);
        assert_eq!(a, GaugePhysics::dispersed(&cfg, 1));
        assert_ne!(a, GaugePhysics::dispersed(&cfg, 2));
        for (ra, rc) in a.k.iter().zip(cfg.gauge.iter()) {
            for (x, y) in ra.iter().zip(rc.iter()) {
                assert!((x / y - 1.0).abs() < 0.2);
            }
        }
    }
}
