//! What the report checks before it draws anything: the CSV against its re-simulation, the
//! stored metrics against the recomputed ones, the models' provenance against the metrics.
//! A failed check is a warning at the top of the page, an omission a note; never an error.

use super::figures::{count, ChannelNames};
use super::recompute::Recomputed;
use super::{Inputs, Outcome, METRICS_REL_TOL, RESIM_TOL_PM};
use crate::data::{Dataset, Measurand};
use crate::error::TrainerError;
use crate::eval::metrics::Metrics;
use crate::eval::score::ModelEval;
use crate::export;
use crate::sim::Simulation;

/// Every check, in the order the page lists them: the re-simulation (the simulation is kept
/// only when the CSV matches it), the gaps of the hold-out, the channels without a reference,
/// metrics.json against the recomputation, the provenance, and the studies that are absent.
pub(super) fn run(
    inp: &Inputs,
    r: &mut Recomputed,
    all_hold: &[usize],
    hold: &[usize],
    out: &mut Outcome,
) -> Result<Option<Simulation>, TrainerError> {
    let d = &inp.data;
    let m = &inp.metrics;
    let sim = match r.sim.take() {
        Some(s) => match check_resim(&s, d) {
            Ok(()) => Some(s),
            Err(msg) => {
                out.warnings.push(msg);
                None
            }
        },
        None => {
            out.notes.push(
                "data.meta.json is absent, so the data cannot be re-simulated: Figure 2 (true wavelength shift) and the per-sample oracle are omitted, and the scenario is known only by the name recorded in metrics.json."
                    .into(),
            );
            None
        }
    };
    if r.est_p.len() != hold.len() || r.est_h.len() != hold.len() {
        return Err(TrainerError::Dataset {
            message: format!(
                "internal: {} / {} estimates for {} usable hold-out rows",
                r.est_p.len(),
                r.est_h.len(),
                hold.len()
            ),
        });
    }
    if hold.len() < all_hold.len() {
        out.notes.push(format!(
            "{} of the {} hold-out rows have a gap (a non-finite input or reference) and are neither evaluated nor drawn as estimates.",
            count(all_hold.len() - hold.len()),
            count(all_hold.len())
        ));
    }
    let dims = inp.model_h.dims;
    let missing: Vec<String> = (0..dims.n_outputs())
        .filter(|&c| !d.reference_of(&dims, c).is_present())
        .map(|c| ChannelNames::of(Measurand::of_output(dims.outputs()[c])).long)
        .collect();
    if !missing.is_empty() {
        out.notes.push(format!(
            "data.csv has no reference for {}: those channels are estimated but cannot be scored, so their errors, parity and histograms are empty.",
            missing.join(", ").to_lowercase()
        ));
    }
    check_metrics(m, &r.ev_p, &r.ev_h, all_hold.len(), d.len(), &mut out.warnings);
    check_provenance(inp, &mut out.warnings);
    if m.drift_sweep.is_none() {
        out.notes.push("metrics.json has no drift sweep (e.g. `evaluate --quick` or data without data.meta.json): Figure 8 is omitted.".into());
    }
    Ok(sim)
}

/// Check the CSV against the re-simulation of its sidecar.
fn check_resim(s: &Simulation, d: &Dataset) -> Result<(), String> {
    if s.data.len() != d.len() {
        return Err(format!(
            "data.csv has {} samples but re-simulating data.meta.json gives {}: Figure 2 (true wavelength) is omitted.",
            d.len(),
            s.data.len()
        ));
    }
    let mut worst: f64 = 0.0;
    if s.data.n_gratings() != d.n_gratings() {
        return Err(format!(
            "data.csv has {} gratings but re-simulating data.meta.json gives {}: Figure 2 (true wavelength) is omitted.",
            d.n_gratings(),
            s.data.n_gratings()
        ));
    }
    for g in 0..d.n_gratings() {
        for (a, b) in s.data.dl_pm[g].iter().zip(&d.dl_pm[g]) {
            let diff = (a - b).abs();
            // A gap (NaN) in the CSV where the simulation has a value is a difference too.
            worst = if diff.is_nan() { f64::INFINITY } else { worst.max(diff) };
        }
    }
    if worst.is_nan() || worst > RESIM_TOL_PM {
        return Err(format!(
            "data.csv differs from a re-simulation of data.meta.json by up to {worst:.3e} pm (tolerance {RESIM_TOL_PM:e}): the CSV was edited or the simulator changed; Figure 2 (true wavelength) is omitted."
        ));
    }
    Ok(())
}

fn close(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= METRICS_REL_TOL * b.abs().max(a.abs()) + 1e-12
}

/// Compare metrics.json with the hold-out metrics recomputed from the models and the data.
fn check_metrics(m: &Metrics, p: &ModelEval, h: &ModelEval, hold: usize, n: usize, warnings: &mut Vec<String>) {
    if m.samples != n || m.holdout_samples != hold {
        warnings.push(format!(
            "metrics.json describes {} samples ({} hold-out) but data.csv has {} ({} hold-out).",
            m.samples, m.holdout_samples, n, hold
        ));
    }
    let mut bad = Vec::new();
    for (name, stored, fresh) in [("Model-P", &m.table2.model_p, p), ("Model-H", &m.table2.model_h, h)] {
        if stored.channels.len() != fresh.channels.len() {
            bad.push(format!(
                "{name}: metrics.json has {} channels, the model {}",
                stored.channels.len(),
                fresh.channels.len()
            ));
            continue;
        }
        for (c, ch) in m.channels.iter().enumerate().take(fresh.channels.len()) {
            let (s, f) = (&stored.channels[c], &fresh.channels[c]);
            for (stat, a, b) in [
                ("RMSE", s.rmse, f.rmse),
                ("MAE", s.mae, f.mae),
                ("bias", s.bias, f.bias),
                ("coverage", s.coverage, f.coverage),
            ] {
                if !close(a, b) {
                    bad.push(format!("{name} {ch} {stat}: metrics.json {a:.6} vs recomputed {b:.6}"));
                }
            }
        }
    }
    if !bad.is_empty() {
        warnings.push(format!(
            "metrics.json does not match the models and data in this directory (tables and summary show metrics.json; figures show the recomputed estimates): {}.",
            bad.join("; ")
        ));
    }
    let n = m.table2.gain_pct.len().min(m.table2.model_h.channels.len()).min(m.table2.model_p.channels.len());
    let g: Vec<f64> = (0..n)
        .map(|c| crate::eval::score::gain_pct(m.table2.model_p.channels[c].rmse, m.table2.model_h.channels[c].rmse))
        .collect();
    let gbad: Vec<String> = (0..n)
        .filter(|&c| !close(g[c], m.table2.gain_pct[c]))
        .map(|c| {
            let ch = m.channels.get(c).map_or("?", |s| s.as_str());
            format!("{ch}: {:.2} % stored vs {:.2} % from its RMSEs", m.table2.gain_pct[c], g[c])
        })
        .collect();
    if !gbad.is_empty() {
        warnings.push(format!("metrics.json's gains disagree with its own RMSEs: {}.", gbad.join("; ")));
    }
}

fn check_provenance(inp: &Inputs, warnings: &mut Vec<String>) {
    let m = &inp.metrics;
    for (name, p) in [("model.fbgm", &inp.model_h), ("model-p.fbgm", &inp.model_p)] {
        let pr = &p.provenance;
        if pr.scenario.as_str() != m.scenario || pr.seed != m.seed {
            warnings.push(format!(
                "{name} was trained on scenario “{}”, seed {}, but metrics.json describes “{}”, seed {}.",
                pr.scenario, pr.seed, m.scenario, m.seed
            ));
        }
    }
    if let Some(meta) = &inp.meta {
        if meta.scenario.name != m.scenario || meta.seed != m.seed {
            warnings.push(format!(
                "data.meta.json describes scenario “{}”, seed {}, but metrics.json describes “{}”, seed {}.",
                meta.scenario.name, meta.seed, m.scenario, m.seed
            ));
        }
    }
    if !export::is_model_p(&inp.model_p) {
        warnings.push(format!(
            "model-p.fbgm has {} RBF centres: it is not a polynomial-only Model-P.",
            inp.model_p.centres.len()
        ));
    }
}
