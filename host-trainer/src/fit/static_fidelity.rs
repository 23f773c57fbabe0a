//! Static fidelity (DESIGN §4): the gain of a model's settled reading against the truth.
//!
//! Once every input has been constant long enough, the model's high-pass memory terms
//! (Δλ − EMA_τ, T_amb − EMA_τ) are 0; what remains — the polynomial core, the stop terms (the
//! branch of a hysteresis loop, which a constant input keeps), the drift observer and the RBF
//! residual — is the model's static response. Its gain against the truth must be 1: a model
//! whose memory terms carry part of the measurand reads wrong at any pace but its calibration
//! week's.
//!
//! Two measures: [`static_gain`], from any record with references (the calibration batch, for
//! the audit: the settled model run over it, the truth regressed on its settled reading — the
//! gain the settled reading would need to read right, 1 for a least-squares fit's own reading,
//! far from 1 when memory terms carry part of the measurand), and [`settled_slope`], from a
//! steps record (the mean reading over the settled part of each hold against the held level).
//! The audit regresses the truth on the reading, not the reading on the truth: over the
//! calibration batch a fitted reading's errors are uncorrelated with the reading, not with the
//! truth, so the reading's slope on the truth is R² (the regression dilution of an inverse fit),
//! not a gain error; on a steps record the levels are exact and the reading's slope is the gain.

use fbg_shared::MemoryGroup;

use super::design::run;
use super::host::HostParams;
use crate::data::Dataset;
use crate::error::TrainerError;

/// Per output, a line fitted by least squares: `truth = offset + gain·reading` for
/// [`static_gain`], `reading = offset + gain·level` for [`settled_slope`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StaticGain {
    /// Slope per output (NaN without a reference).
    pub gain: Vec<f64>,
    /// Intercept, per output, in the output's unit.
    pub offset: Vec<f64>,
    /// Rows the line was fitted on, per output.
    pub rows: Vec<usize>,
}

/// `p` with every high-pass memory term (grating and ambient) switched off: the reading it
/// gives once the inputs have settled.
pub fn settled_model(p: &HostParams) -> HostParams {
    let mut s = p.clone();
    for k in 0..p.dims.memory_len() {
        let settles = p
            .memory
            .term(&p.dims, k)
            .is_some_and(|t| matches!(t.group, MemoryGroup::GratingHighPass | MemoryGroup::AmbientHighPass));
        if settles {
            for row in s.gamma.iter_mut() {
                row[k] = 0.0;
            }
        }
    }
    s
}

/// Least-squares line of `reading` on `truth` over the pairs where both are finite.
fn line(truth: impl Iterator<Item = (f64, f64)>) -> (f64, f64, usize) {
    let pts: Vec<(f64, f64)> = truth.filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
    let n = pts.len();
    if n < 2 {
        return (f64::NAN, f64::NAN, n);
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 {
        return (f64::NAN, f64::NAN, n);
    }
    let g = sxy / sxx;
    (g, my - g * mx, n)
}

/// The static gain of `p` over `rows` of `d` (sorted): its settled model ([`settled_model`])
/// run over the record, each output's reference regressed on its settled reading.
pub fn static_gain(p: &HostParams, d: &Dataset, rows: &[usize]) -> Result<StaticGain, TrainerError> {
    let settled = settled_model(p);
    let est = run(&settled, d, rows)?;
    let refs = d.references_of(&p.dims);
    let mut out = StaticGain { gain: Vec::new(), offset: Vec::new(), rows: Vec::new() };
    for (c, r) in refs.iter().enumerate().take(p.dims.n_outputs()) {
        let (g, a, n) = if r.is_present() {
            line(rows.iter().zip(&est).map(|(&i, e)| (e.values[c], r[i])))
        } else {
            (f64::NAN, f64::NAN, 0)
        };
        out.gain.push(g);
        out.offset.push(a);
        out.rows.push(n);
    }
    Ok(out)
}

/// RMS over the calibration rows of what each part of Model-H adds to its reading, per output:
/// the memory terms by group and the RBF residual (the audit's "what the dynamic terms
/// contribute").
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Contributions {
    /// Per memory group used (by [`MemoryGroup::name`]), per output RMS in the output's unit.
    pub memory: Vec<(&'static str, Vec<f64>)>,
    /// The RBF residual's RMS per output.
    pub rbf: Vec<f64>,
}

/// The RMS of `full − without` per output over the estimates.
fn rms_diff(full: &[fbg_shared::Estimate<f64>], without: &[fbg_shared::Estimate<f64>], m: usize) -> Vec<f64> {
    let n = full.len().max(1) as f64;
    (0..m)
        .map(|c| (full.iter().zip(without).map(|(a, b)| (a.values[c] - b.values[c]).powi(2)).sum::<f64>() / n).sqrt())
        .collect()
}

/// What each part of `p` contributes over `rows` of `d` (each part is additive: the model
/// without it, subtracted from the model).
pub(crate) fn contributions(p: &HostParams, d: &Dataset, rows: &[usize]) -> Result<Contributions, TrainerError> {
    let m = p.dims.n_outputs();
    let full = run(p, d, rows)?;
    let mut memory = Vec::new();
    for g in MemoryGroup::ALL {
        let terms: Vec<usize> = (0..p.dims.memory_len())
            .filter(|&k| p.memory.term(&p.dims, k).is_some_and(|t| t.group == g && t.parameter > 0.0))
            .filter(|&k| p.gamma.iter().take(m).any(|row| row[k] != 0.0))
            .collect();
        if terms.is_empty() {
            continue;
        }
        let mut without = p.clone();
        for row in without.gamma.iter_mut() {
            for &k in &terms {
                row[k] = 0.0;
            }
        }
        memory.push((g.name(), rms_diff(&full, &run(&without, d, rows)?, m)));
    }
    let mut no_rbf = p.clone();
    for c in no_rbf.centres.iter_mut() {
        c.w = [0.0; fbg_shared::layout::MAX_OUTPUTS];
    }
    let rbf = rms_diff(&full, &run(&no_rbf, d, rows)?, m);
    Ok(Contributions { memory, rbf })
}

/// The static-fidelity audit of a trained pair over its calibration batch.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StaticAudit {
    /// Model-P's static gain per output.
    pub model_p: StaticGain,
    /// Model-H's static gain per output (its settled reading: high-passes at 0).
    pub model_h: StaticGain,
    /// What Model-H's memory groups and RBF residual add, RMS per output.
    pub contributions: Contributions,
}

/// Calibration rows the audit runs over at most (the first ones): the models run from the
/// first sample to the last audited one once per part, which on a very long batch would cost
/// more than the fit; a month of one-minute samples determines a gain and an RMS well enough.
pub const AUDIT_MAX_ROWS: usize = 50_000;

/// Largest relative difference between the two models' static gains that `train` accepts
/// without a warning.
pub const STATIC_GAIN_TOLERANCE: f64 = 0.01;

impl StaticAudit {
    /// The audit of `model_p` and `model_h` over the calibration rows `cal` of `d` (sorted; the
    /// first [`AUDIT_MAX_ROWS`] of them).
    pub fn of(model_p: &HostParams, model_h: &HostParams, d: &Dataset, cal: &[usize]) -> Result<Self, TrainerError> {
        let cal = &cal[..cal.len().min(AUDIT_MAX_ROWS)];
        Ok(StaticAudit {
            model_p: static_gain(model_p, d, cal)?,
            model_h: static_gain(model_h, d, cal)?,
            contributions: contributions(model_h, d, cal)?,
        })
    }

    /// The outputs whose two static gains differ by more than [`STATIC_GAIN_TOLERANCE`]
    /// (relative), with both gains.
    pub fn disagreements(&self) -> Vec<(usize, f64, f64)> {
        self.model_h
            .gain
            .iter()
            .zip(&self.model_p.gain)
            .enumerate()
            .filter(|(_, (h, p))| h.is_finite() && p.is_finite() && (*h / *p - 1.0).abs() > STATIC_GAIN_TOLERANCE)
            .map(|(c, (h, p))| (c, *h, *p))
            .collect()
    }
}

/// One hold of a steps record: output `output` held at `level` (its unit) over `rows`, the
/// settled part of the hold.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldLevel {
    pub output: usize,
    pub level: f64,
    pub rows: std::ops::Range<usize>,
}

/// The settled slope of `p` on a steps record: per output, the mean reading over each of its
/// holds regressed on the held level (NaN for an output with fewer than two holds). The model
/// runs over every row from the first, as a device would.
pub fn settled_slope(p: &HostParams, d: &Dataset, holds: &[HeldLevel]) -> Result<StaticGain, TrainerError> {
    let all: Vec<usize> = (0..d.len()).collect();
    let est = run(p, d, &all)?;
    let mut out = StaticGain { gain: Vec::new(), offset: Vec::new(), rows: Vec::new() };
    for c in 0..p.dims.n_outputs() {
        let means = holds.iter().filter(|h| h.output == c && !h.rows.is_empty()).map(|h| {
            let v: Vec<f64> = h.rows.clone().map(|i| est[i].values[c]).filter(|v| v.is_finite()).collect();
            (h.level, if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 })
        });
        let (g, a, n) = line(means);
        out.gain.push(g);
        out.offset.push(a);
        out.rows.push(n);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_recovers_slope_and_offset() {
        let (g, a, n) = line([(1.0, 3.0), (2.0, 5.0), (3.0, 7.0), (f64::NAN, 1.0)].into_iter());
        assert_eq!(n, 3);
        assert!((g - 2.0).abs() < 1e-12 && (a - 1.0).abs() < 1e-12);
        assert!(line([(1.0, 1.0)].into_iter()).0.is_nan());
    }

    #[test]
    fn disagreements_skip_missing_outputs() {
        let g = |gain: Vec<f64>| StaticGain { offset: vec![0.0; gain.len()], rows: vec![1; gain.len()], gain };
        let a = StaticAudit {
            model_p: g(vec![1.0, 1.0, 1.0]),
            model_h: g(vec![1.0, 0.5, f64::NAN]),
            contributions: Contributions { memory: vec![], rbf: vec![] },
        };
        assert_eq!(a.disagreements(), [(1, 0.5, 1.0)]);
    }
}
