//! The glitch study (DESIGN §4, the second rule (a)): one bad sample in one input, and what it
//! does to every later reading.
//!
//! A record's hold-out is compensated twice by Model-H: clean, and with a single sample of one
//! input replaced by a glitch (a DS18B20's 85 °C power-on value, its −127 °C read error, 1e300,
//! NaN). The glitch row must be flagged as a fault; no later row may differ from the clean
//! record's by more than that row's band (the memory state must not eat the glitch).

use crate::data::Dataset;
use crate::error::TrainerError;
use crate::fit::{run, HostParams};

/// The glitch values: label and value.
pub const GLITCHES: [(&str, f64); 4] = [("85", 85.0), ("-127", -127.0), ("1e300", 1e300), ("NaN", f64::NAN)];

/// Where in the hold-out the glitch goes (fraction of its rows).
pub const GLITCH_AT: f64 = 0.25;

pub use fbg_report::GlitchRow;

/// Run every glitch of [`GLITCHES`] in every input of `model` on `d`'s hold-out.
pub fn glitch_study(model: &HostParams, d: &Dataset) -> Result<Vec<GlitchRow>, TrainerError> {
    let idx: Vec<usize> = d.holdout_indices().into_iter().filter(|&i| d.usable(i)).collect();
    if idx.len() < 8 {
        return Ok(Vec::new());
    }
    let clean = run(model, d, &idx)?;
    let at = ((idx.len() as f64 * GLITCH_AT) as usize).min(idx.len() - 1);
    let row = idx[at];
    let mut inputs: Vec<String> = (0..d.dl_pm.len()).map(|g| format!("dl{}_pm", g + 1)).collect();
    if model.dims.ambient() && d.t_amb_c.is_some() {
        inputs.push("T_amb_C".into());
    }
    let mut cases = Vec::new();
    for (k, name) in inputs.iter().enumerate() {
        for (label, v) in GLITCHES {
            cases.push((k, name.clone(), label, v));
        }
    }
    crate::fit::par_map(&cases, |(k, name, label, v)| {
        let mut g = d.clone();
        match g.dl_pm.get_mut(*k) {
            Some(col) => col[row] = *v,
            None => {
                if let Some(a) = g.t_amb_c.as_mut() {
                    a[row] = *v;
                }
            }
        }
        let est = run(model, &g, &idx)?;
        let m = model.dims.n_outputs();
        let mut beyond = 0;
        let mut worst: f64 = 0.0;
        for (e, c) in est.iter().zip(&clean).skip(at + 1) {
            let mut out = false;
            for o in 0..m {
                let diff = (e.values[o] - c.values[o]).abs();
                let ratio = if c.band95[o] > 0.0 { diff / c.band95[o] } else { f64::INFINITY };
                let ratio = if ratio.is_nan() { f64::INFINITY } else { ratio };
                worst = worst.max(ratio);
                out |= ratio > 1.0;
            }
            beyond += usize::from(out);
        }
        Ok(GlitchRow {
            input: name.clone(),
            value: (*label).to_string(),
            t_s: Some(d.t_s[row]),
            flagged: est[at].flags.is_fault(),
            later_rows: Some(idx.len() - at - 1),
            rows_beyond_band: beyond,
            worst_ratio: Some(worst),
        })
    })
    .into_iter()
    .collect()
}
