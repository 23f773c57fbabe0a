//! Host/device parity: the exported f32 model run through `fbg_shared` in f32 against
//! the trainer's f64 model, on the inputs a device receives (f32), plus the gap between the
//! device's leverage (kept eigen-directions) and the exact ψᵀ(ΨᵀΨ + αI)⁻¹ψ.

use nalgebra::DMatrix;

use fbg_shared::Compensator;

use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::score::ModelEval;
use crate::fit::{design_matrix, HostCompensator, HostParams, HOST_CAP};

pub use fbg_report::ParityReport;

/// Run the f32 device path and the f64 reference side by side over the whole record and
/// compare on the hold-out.
pub fn check(model_h: &HostParams, d: &Dataset, eval_h: &ModelEval) -> Result<ParityReport, TrainerError> {
    let p32 = model_h.convert::<f32, HOST_CAP>().map_err(|e| TrainerError::fit(e.to_string()))?;
    let mut dev = Compensator::<f32, HOST_CAP>::new(&p32).map_err(|e| TrainerError::fit(e.to_string()))?;
    let mut reference = HostCompensator::new(model_h).map_err(|e| TrainerError::fit(e.to_string()))?;
    let hold = d.holdout_indices();
    let first = hold.first().copied().unwrap_or(0);
    let m = model_h.dims.n_outputs();
    let mut max_abs = vec![0.0f64; m];
    let mut max_band = vec![0.0f64; m];
    let mut mismatches = 0;
    let mut n = 0;
    for i in 0..d.len() {
        // The input as the device receives it (rounded to f32), and exactly that in f64.
        let x32 = d.sample(i).cast::<f32>();
        let a = dev.step(&x32);
        let b = reference.step(&x32.cast());
        if i < first || d.split[i] != crate::data::Split::Holdout {
            continue;
        }
        n += 1;
        if a.flags != b.flags {
            mismatches += 1;
        }
        for c in 0..m {
            max_abs[c] = max_abs[c].max((f64::from(a.values[c]) - b.values[c]).abs());
            if b.band95[c].is_finite() && b.band95[c] > 0.0 {
                max_band[c] = max_band[c].max((f64::from(a.band95[c]) / b.band95[c] - 1.0).abs());
            }
        }
    }
    let (gap, hmax) = leverage_gap(model_h, d)?;
    Ok(ParityReport {
        samples: n,
        max_diff_over_rmse: (0..m).map(|c| max_abs[c] / eval_h.channels[c].rmse).collect(),
        max_abs_diff: max_abs,
        max_band_rel_diff: max_band,
        flag_mismatches: mismatches,
        leverage_band_gap: gap,
        leverage_max: hmax,
    })
}

/// Exact leverage against the device's on the hold-out.
fn leverage_gap(model_h: &HostParams, d: &Dataset) -> Result<(f64, f64), TrainerError> {
    let k = model_h.centres.len();
    if k == 0 {
        return Ok((0.0, 0.0));
    }
    let all: Vec<usize> = (0..d.len()).collect();
    let (psi, _) = design_matrix(model_h, d, &all)?;
    let cal = d.cal_indices();
    let psi_c = DMatrix::from_fn(cal.len(), k, |r, c| psi[(cal[r], c)]);
    let g = psi_c.tr_mul(&psi_c) + DMatrix::identity(k, k) * model_h.hyper.alpha;
    let m = g.try_inverse().ok_or_else(|| TrainerError::fit("ΨᵀΨ + αI is singular"))?;
    let inv_g = model_h.var_inv_g;
    let tail = model_h.var_inv_g_tail;
    let (mut gap, mut hmax) = (0.0f64, 0.0f64);
    for i in d.holdout_indices() {
        let p = psi.row(i).transpose();
        let exact = (p.transpose() * &m * &p)[(0, 0)];
        // The device's value: projections on the kept eigenvectors.
        let mut dev = p.norm_squared() * tail;
        for (r, ig) in inv_g.iter().enumerate() {
            let proj: f64 = model_h.centres.iter().zip(p.iter()).map(|(c, v)| c.v[r] * v).sum();
            dev += proj * proj * (ig - tail).max(0.0);
        }
        gap = gap.max(((1.0 + exact) / (1.0 + dev)).sqrt() - 1.0);
        hmax = hmax.max(exact);
    }
    Ok((gap, hmax))
}
