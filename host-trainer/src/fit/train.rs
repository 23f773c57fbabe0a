//! The training entry: Model-P and Model-H fitted on a dataset's calibration batch (DESIGN §4),
//! after cross-validation chose their hyper-parameters and memory terms.

use super::design::{self, Checkpoints};
use super::field;
use super::host::HostParams;
use super::linalg;
use super::memory_core;
use super::options::TrainOptions;
use super::outcome;
use super::poly_core;
use super::provenance::{provenance, Origin};
use super::rbf_inputs::z_sample;
use super::refusals::{refuse_constant_columns, refuse_outliers};
use super::residual::weak_support_threshold;
use super::select::{self, Selection};
use super::skeleton::Skeleton;
use super::static_fidelity::StaticAudit;
use super::trained::Trained;
use super::trust;
use super::variance::VarianceTerms;
use crate::data::import::OnError;
use crate::data::outliers;
use crate::data::Dataset;
use crate::error::TrainerError;

/// [`train_source`] of a dataset with no file name ("the dataset" in messages).
///
/// ```
/// use fbg_trainer::fit::{train, Origin, TrainOptions};
/// use fbg_trainer::sim::{scenario::Preset, simulate};
///
/// // Two days of the `paper` installation, a small grid.
/// let mut scenario = Preset::Paper.config();
/// scenario.clock.days = 2.0;
/// let data = simulate(&scenario, 7).data;
/// let opts = TrainOptions::builder().centres(vec![4]).sigma_mults(vec![1.0]).alpha_rels(vec![1e-4]).check()?;
/// let trained = train(&data, &opts, &Origin { scenario: "paper".into(), seed: 7 })?;
/// assert_eq!(trained.model_h.centres.len(), 4);
/// assert!(trained.model_p.centres.is_empty());
/// # Ok::<(), fbg_trainer::TrainerError>(())
/// ```
pub fn train(d: &Dataset, opts: &TrainOptions, origin: &Origin) -> Result<Trained, TrainerError> {
    train_source(d, "the dataset", opts, origin)
}

/// Fit Model-P and Model-H on the calibration samples of `d`, read from `source` (named by the
/// refusal of reference outliers, with the CSV line: [`crate::data::outliers`]). Reference
/// outliers in the calibration rows refuse the batch, or with [`TrainOptions::on_outlier`]
/// skip leave their rows out ([`Trained::skipped`] and a warning say which).
pub fn train_source(d: &Dataset, source: &str, opts: &TrainOptions, origin: &Origin) -> Result<Trained, TrainerError> {
    // The model's dimensions are the data's: a dataset without references cannot be fitted.
    let dims = d.dims(source)?;
    if let Some(g) = opts.drift_gains().filter(|g| g.len() != dims.gratings()) {
        return Err(TrainerError::options(format!(
            "{}: {} drift gains given for the {} gratings of {source}; give one per grating, in its order",
            opts.drift_gains_name(),
            g.len(),
            dims.gratings()
        )));
    }
    // The record's input rule (the CSV reader applies it as it reads): a record handed over in
    // memory is held to it here, before an implausible cell's square overflows the fit.
    d.check_inputs().map_err(|(row, column, m)| TrainerError::data(source, outliers::csv_line(d, row), &column, m))?;
    let cal_rows = d.cal_indices();
    let found = outliers::find(d, &cal_rows);
    if !found.is_empty() && opts.on_outlier() == OnError::Fail {
        return Err(refuse_outliers(source, &found, opts.skip_outliers_hint()));
    }
    let skip = outliers::rows_of(&found);
    // Fit on the calibration rows with finite inputs and every available reference, outliers
    // left out.
    let cal: Vec<usize> = cal_rows.into_iter().filter(|&i| d.usable(i) && skip.binary_search(&i).is_err()).collect();
    if cal.len() < 200 {
        let left_out =
            if skip.is_empty() { String::new() } else { format!(", {} with reference outliers left out", skip.len()) };
        return Err(TrainerError::Dataset {
            message: format!(
                "{} usable calibration samples (finite inputs and references{left_out}); at least 200 are needed",
                cal.len()
            ),
        });
    }
    refuse_constant_columns(d, &cal)?;
    // No play radius that the gratings' own noise crosses during a hold (DESIGN §4 (c)).
    let noise_pm = trust::white_noise_pm(d, &cal);
    let floored = opts.to_builder().memory(trust::noise_floored(opts.memory(), &noise_pm)).check()?;
    let opts = &floored;
    let mut phases = PhaseClock::start();
    let selection = select::select(d, &cal, opts)?;
    phases.lap("cross-validation");
    opts.check_cancel()?;
    let (model_p, model_h, core_p) = final_fit(d, &cal, opts, &selection, origin, &mut phases)?;
    opts.check_cancel()?;
    let static_audit = StaticAudit::of(&model_p, &model_h, d, &cal)?;
    phases.lap("assembly and static audit");
    let warnings = outcome::train_warnings(&dims, &selection, &static_audit, &found);
    Ok(Trained {
        model_p,
        model_h,
        core: core_p,
        selection,
        phase_seconds: phases.laps,
        static_audit,
        skipped: found,
        warnings,
    })
}

/// The final fit on the whole calibration batch `cal` with the configuration and memory terms
/// `selection` chose: (Model-P, Model-H, Model-P's core).
fn final_fit(
    d: &Dataset,
    cal: &[usize],
    opts: &TrainOptions,
    selection: &Selection,
    origin: &Origin,
    phases: &mut PhaseClock,
) -> Result<(HostParams, HostParams, poly_core::PolyCore), TrainerError> {
    let cfg = selection.chosen;
    let provenance = provenance(origin, cal.len());
    let core0 = poly_core::fit(d, cal, cfg.cross_terms)?;
    let core = memory_core::fit(d, cal, &core0, &opts.memory().menu, &selection.memory)?;
    let core_p = if cfg.cross_terms { core0 } else { poly_core::fit(d, cal, true)? };
    phases.lap("polynomial core");
    // The latch stream of the chosen dead band, once for the RBF inputs and the design.
    let stream = Skeleton::core_only(d, cal, &core, cfg.feature_set, cfg.dead_band_pm).bare_params(&provenance)?;
    let end = cal.last().map(|&i| i + 1).unwrap_or(0);
    let ck = Checkpoints::new(&stream, d, end, &[])?;
    let zs = z_sample(&stream, d, design::Rows::Live(cal, Some(&ck)))?;
    let sk = Skeleton::build(d, cal, &core, &zs, &cfg, opts.seed());
    phases.lap("RBF inputs and centres");
    let base = sk.bare_params(&provenance)?;
    let gram = design::gram(&base, d, cal, Some(&ck))?;
    phases.lap("RBF design and ridge");
    let sys = linalg::RidgeSystem::from_gram(gram.g, &gram.psi_r)?;
    let alpha = cfg.alpha_rel * cal.len() as f64;
    let w = sys.weights(alpha);
    let var = VarianceTerms::from_ridge(&sys, alpha);
    let thr = if sk.centres.is_empty() { 0.0 } else { weak_support_threshold(&gram.max_psi) };
    let t_end = cal.last().map(|&i| d.t_s[i]).unwrap_or(0.0);
    let mut model_h =
        sk.params_with_band(Some(&w), alpha, Some(&var), &selection.var_model_h, t_end, thr, &provenance)?;

    let sk_p = Skeleton { core: core_p.clone(), centres: vec![], ..sk };
    let mut model_p = sk_p.params_with_band(None, 0.0, None, &selection.var_model_p, t_end, 0.0, &provenance)?;
    model_h.field = field::context(&model_h, d, cal, &selection.var_model_h, &selection.cv_rmse_h);
    model_p.field = field::context(&model_p, d, cal, &selection.var_model_p, &selection.cv_rmse_p);
    model_h.trust = trust::spec(&model_h, &model_p, d, cal);
    for m in [&model_h, &model_p] {
        m.validate().map_err(|e| TrainerError::fit(format!("assembled model is invalid: {e}")))?;
    }
    Ok((model_p, model_h, core_p))
}

/// Wall time per phase.
struct PhaseClock {
    last: std::time::Instant,
    laps: Vec<(&'static str, f64)>,
}

impl PhaseClock {
    fn start() -> Self {
        PhaseClock { last: std::time::Instant::now(), laps: Vec::new() }
    }
    /// Close the phase that ran since the last lap.
    fn lap(&mut self, what: &'static str) {
        let now = std::time::Instant::now();
        self.laps.push((what, (now - self.last).as_secs_f64()));
        self.last = now;
    }
}
