//! The whole evaluation of a scenario (DESIGN §5): Table 2 on the hold-out with the oracle
//! floor, the drift sweep (paper Fig. 12), the ablation (Table 3, every channel), the error
//! budget, the field-recalibration study, and the checks that tie the device arithmetic to the
//! f64 reference. Everything lands in one [`Metrics`] value, written as `metrics.json`
//! (schema: [`crate::eval::metrics`]).

use std::time::Instant;

use fbg_shared::FeatureSet;

use crate::data::{Dataset, Measurand};
use crate::error::TrainerError;
use crate::eval::metrics::{AblationRow, BudgetRow, DriftSweep, Metrics, RecalStudy, SelectionSummary, Table2};
use crate::eval::parity;
use crate::eval::score::{channels, evaluate_holdout, gain_pct, units, ModelEval};
use crate::fit::recalibrate::{first_hours, recalibrate};
use crate::fit::{self, HostParams, Origin, TrainOptions, Trained};
use crate::sim::meta::SimMeta;
use crate::sim::scenario::ScenarioConfig;
use crate::sim::{simulate, Simulation, EFFECT_NAMES};
use crate::stats::linear_fit;

/// Drift multipliers of the sweep (× σ_d of the scenario).
pub(crate) const DRIFT_FACTORS: [f64; 6] = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0];

/// Table 2 for a trained pair on `d`.
/// `oracle` holds the per-sample oracle's hold-out RMSE per output of the models.
pub fn table2(p: &HostParams, h: &HostParams, d: &Dataset, oracle: Option<Vec<f64>>) -> Result<Table2, TrainerError> {
    let (ep, _) = evaluate_holdout(p, d)?;
    let (eh, _) = evaluate_holdout(h, d)?;
    let m = eh.channels.len();
    let gain = (0..m).map(|c| gain_pct(ep.channels[c].rmse, eh.channels[c].rmse)).collect();
    let over = oracle.as_ref().map(|o| (0..m).map(|c| eh.channels[c].rmse / o[c]).collect());
    Ok(Table2 { model_p: ep, model_h: eh, gain_pct: gain, oracle_floor: oracle, h_over_floor: over })
}

fn fixed(opts: &TrainOptions, cfg: &fit::Config) -> TrainOptions {
    opts.fixed_like(cfg).with_seed(opts.seed()).with_progress(false)
}

/// Hold-out RMSE per output of Model-P, of Model-H and of the per-sample oracle.
type RefitRmse = (Vec<f64>, Vec<f64>, Vec<f64>);

/// Hold-out RMSE of both models retrained on a re-simulated scenario with fixed
/// hyper-parameters.
fn refit_rmse(cfg: &ScenarioConfig, seed: u64, opts: &TrainOptions) -> Result<RefitRmse, TrainerError> {
    let s = simulate(cfg, seed);
    let tr = fit::train(&s.data, opts, &Origin { scenario: cfg.name.clone(), seed })?;
    let (ep, _) = evaluate_holdout(&tr.model_p, &s.data)?;
    let (eh, _) = evaluate_holdout(&tr.model_h, &s.data)?;
    let rmse = |e: &ModelEval| e.channels.iter().map(|c| c.rmse).collect();
    Ok((rmse(&ep), rmse(&eh), s.oracle_floor().holdout_for(&Measurand::of_dims(&tr.model_h.dims))))
}

/// The drift sweep, refitting both models at each σ_d with the hyper-parameters chosen on
/// the nominal scenario (so that only the drift changes).
pub fn drift_sweep(
    cfg: &ScenarioConfig,
    seed: u64,
    chosen: &fit::Config,
    opts: &TrainOptions,
) -> Result<DriftSweep, TrainerError> {
    let o = fixed(opts, chosen);
    let pts: Vec<Result<_, TrainerError>> = fit::par_map(&DRIFT_FACTORS, |&f| {
        let mut c = cfg.clone();
        c.drift.sigma_pm = cfg.drift.sigma_pm * f;
        c.drift.enabled = true;
        refit_rmse(&c, seed, &o)
    });
    let mut rmse_p = Vec::new();
    let mut rmse_h = Vec::new();
    for r in pts {
        let (p, h, _) = r?;
        rmse_p.push(p);
        rmse_h.push(h);
    }
    let x: Vec<f64> = DRIFT_FACTORS.iter().map(|f| f * cfg.drift.sigma_pm).collect();
    let line = |ys: &[Vec<f64>], c: usize| {
        let y: Vec<f64> = ys.iter().map(|v| v[c]).collect();
        linear_fit(&x, &y)
    };
    let m = rmse_p.first().map_or(0, |v: &Vec<f64>| v.len());
    let lp: Vec<(f64, f64)> = (0..m).map(|c| line(&rmse_p, c)).collect();
    let lh: Vec<(f64, f64)> = (0..m).map(|c| line(&rmse_h, c)).collect();
    Ok(DriftSweep {
        factors: DRIFT_FACTORS.to_vec(),
        sigma_d_pm: x,
        rmse_p,
        rmse_h,
        slope_p: lp.iter().map(|l| l.1).collect(),
        slope_h: lh.iter().map(|l| l.1).collect(),
        intercept_p: lp.iter().map(|l| l.0).collect(),
        intercept_h: lh.iter().map(|l| l.0).collect(),
    })
}

/// Table 3 for all channels: polynomial only; hybrid without cross-terms; the `paper`
/// variant (z = [Δλ, T_amb, t], no memory terms); the `latch` variant (the previous default:
/// RBF on the direction latches, no memory terms); the default (memory terms fitted with the
/// core, RBF residual); and the default with each memory group the model's dimensions allow
/// removed in turn. The notes name the model's own inputs (no T_amb without a thermometer).
/// Each variant runs its own selection over its own family, inside the calibration batch.
pub fn ablation(
    d: &Dataset,
    trained: &Trained,
    opts: &TrainOptions,
    origin: &Origin,
) -> Result<Vec<AblationRow>, TrainerError> {
    use fbg_shared::MemoryGroup;
    let (ep, _) = evaluate_holdout(&trained.model_p, d)?;
    let (eh, _) = evaluate_holdout(&trained.model_h, d)?;
    let base = opts.clone().with_progress(false);
    let off = fit::memory_core::MemoryOptions::off();
    let dims = trained.model_h.dims;
    let linear: Vec<String> =
        std::iter::once("1".to_string()).chain(Measurand::of_dims(&dims).iter().map(|m| m.short_name())).collect();
    // The RBF inputs of a variant, as the model has them: "[Δλ, T_amb, …]" or "[Δλ, …]".
    let z = |rest: &str| format!("[Δλ{}{rest}]", if dims.ambient() { ", T_amb" } else { "" });
    let mut variants: Vec<(String, String, TrainOptions)> = vec![
        (
            "Hybrid w/o cross-terms".into(),
            format!("stage 2 keeps [{}]; memory terms and RBF residual selected by CV", linear.join(", ")),
            base.to_builder().cross_terms(false).check()?,
        ),
        (
            "Hybrid, paper variant".into(),
            format!("z = {} (paper Eq. 5), no memory terms", z(", t")),
            base.to_builder()
                .feature_sets(vec![FeatureSet::Paper])
                .memory(off.clone())
                .centres(vec![8, 16, 32])
                .check()?,
        ),
        (
            "Hybrid, latch variant".into(),
            format!("z = {} (+t if CV keeps it), no memory terms (previous default)", z(", direction latches")),
            base.to_builder()
                .feature_sets(vec![FeatureSet::HysteresisAware, FeatureSet::HysteresisAwareTime])
                .memory(off)
                .centres(vec![8, 16, 32])
                .check()?,
        ),
    ];
    if opts.memory().enabled() {
        for g in MemoryGroup::ALL
            .into_iter()
            .filter(|&g| opts.memory().groups.contains(&g) && fit::memory_core::applies(&dims, g))
        {
            variants.push((
                format!("Default − {}", g.name()),
                format!("the default with the {} memory group removed", g.name()),
                base.to_builder().memory(opts.memory().without(g)).check()?,
            ));
        }
    }
    let res: Vec<Result<(ModelEval, fit::Config), TrainerError>> = fit::par_map(&variants, |(_, _, o)| {
        let t = fit::train(d, o, origin)?;
        Ok((evaluate_holdout(&t.model_h, d)?.0, t.selection.chosen))
    });
    let mut rows = vec![AblationRow {
        name: "Polynomial only (Model-P)".into(),
        note: "baseline: Eq. 3 core".into(),
        channels: ep.channels,
        config: None,
    }];
    let mut res = res.into_iter();
    for (name, note, _) in variants.iter().take(3) {
        let (e, c) = res.next().ok_or_else(|| TrainerError::fit("ablation"))??;
        rows.push(AblationRow { name: name.clone(), note: note.clone(), channels: e.channels, config: Some(c) });
    }
    rows.push(AblationRow {
        name: "Hybrid, default".into(),
        note: if opts.memory().enabled() {
            format!(
                "memory terms fitted on what the core leaves (groups and λ by CV) + RBF residual on {}",
                z(", latches")
            )
        } else {
            "the trained Model-H".into()
        },
        channels: eh.channels,
        config: Some(trained.selection.chosen),
    });
    for (name, note, _) in variants.iter().skip(3) {
        let (e, c) = res.next().ok_or_else(|| TrainerError::fit("ablation"))??;
        rows.push(AblationRow { name: name.clone(), note: note.clone(), channels: e.channels, config: Some(c) });
    }
    Ok(rows)
}

/// Error budget: both models' hold-out RMSE with each artefact switched off in turn (fixed
/// hyper-parameters), plus the full scenario and physics only.
pub fn error_budget(
    cfg: &ScenarioConfig,
    seed: u64,
    chosen: &fit::Config,
    opts: &TrainOptions,
) -> Result<Vec<BudgetRow>, TrainerError> {
    let o = fixed(opts, chosen);
    let mut names = vec!["none"];
    names.extend(EFFECT_NAMES);
    names.push("all");
    let rows: Vec<Result<BudgetRow, TrainerError>> = fit::par_map(&names, |&name| {
        let mut c = cfg.clone();
        let all = name == "all";
        if all || name == "hysteresis" {
            c.hysteresis.enabled = false;
        }
        if all || name == "scan" {
            c.scan.enabled = false;
        }
        if all || name == "drift" {
            c.drift.enabled = false;
        }
        if all || name == "electronics" {
            c.electronics.enabled = false;
        }
        if all || name == "noise" {
            c.noise.enabled = false;
        }
        match refit_rmse(&c, seed, &o) {
            Ok((p, h, floor)) => Ok(BudgetRow {
                effect_off: name.to_string(),
                rmse_p: p,
                rmse_h: h,
                oracle_floor: floor,
                not_fitted: None,
            }),
            // A fit the scenario without this artefact cannot support (e.g. collinear gratings
            // once the noise is off) is a row without numbers, not a failed study.
            Err(e @ TrainerError::Fit { .. }) => {
                let nan = vec![f64::NAN; cfg.measurands.len()];
                Ok(BudgetRow {
                    effect_off: name.to_string(),
                    rmse_p: nan.clone(),
                    rmse_h: nan.clone(),
                    oracle_floor: nan,
                    not_fitted: Some(e.to_string()),
                })
            }
            Err(e) => Err(e),
        }
    });
    rows.into_iter().collect()
}

/// Train on `seed_old`, move to `seed_new`, recalibrate with the first `hours` and compare.
pub fn recalibration(
    cfg: &ScenarioConfig,
    old_h: &HostParams,
    old_p: &HostParams,
    seed_old: u64,
    seed_new: u64,
    hours: f64,
    chosen: &fit::Config,
) -> Result<RecalStudy, TrainerError> {
    let new_site = simulate(cfg, seed_new);
    let d = &new_site.data;
    let batch = first_hours(d, hours);
    let rmse = |e: &ModelEval| -> Vec<f64> { e.channels.iter().map(|c| c.rmse).collect() };
    let (h_short_p, _) = recalibrate(old_h, d, &batch)?;
    let (p_short_p, _) = recalibrate(old_p, d, &batch)?;
    let full = fit::train(d, &TrainOptions::fixed(chosen), &Origin { scenario: cfg.name.clone(), seed: seed_new })?;
    let h_old = rmse(&evaluate_holdout(old_h, d)?.0);
    let h_short = rmse(&evaluate_holdout(&h_short_p, d)?.0);
    let h_full = rmse(&evaluate_holdout(&full.model_h, d)?.0);
    let p_old = rmse(&evaluate_holdout(old_p, d)?.0);
    let p_short = rmse(&evaluate_holdout(&p_short_p, d)?.0);
    let p_full = rmse(&evaluate_holdout(&full.model_p, d)?.0);
    let recovered_fraction_h = (0..h_old.len()).map(|c| (h_old[c] - h_short[c]) / (h_old[c] - h_full[c])).collect();
    Ok(RecalStudy {
        batch_hours: hours,
        batch_samples: batch.len(),
        seed_old,
        seed_new,
        h_old,
        h_short,
        h_full,
        p_old,
        p_short,
        p_full,
        recovered_fraction_h,
    })
}

/// Which studies to run.
#[derive(Clone, Copy, Debug)]
pub struct Studies {
    /// The pace study (`eval::pace`): simulated data only, no refit.
    pub pace: bool,
    pub drift_sweep: bool,
    pub ablation: bool,
    pub error_budget: bool,
    pub parity: bool,
    pub recalibration: bool,
}

impl Studies {
    pub const ALL: Studies = Studies {
        pace: true,
        drift_sweep: true,
        ablation: true,
        error_budget: true,
        parity: true,
        recalibration: true,
    };
    pub const NONE: Studies = Studies {
        pace: false,
        drift_sweep: false,
        ablation: false,
        error_budget: false,
        parity: false,
        recalibration: false,
    };
}

/// Batch lengths of the recalibration study \[h\].
pub(crate) const RECAL_BATCH_HOURS: [f64; 2] = [2.0, 24.0];
/// The changed installation of the recalibration study uses this seed offset.
pub(crate) const RECAL_SEED_OFFSET: u64 = 1;

/// Train on a simulation and measure everything.
pub fn run_all(
    sim: &Simulation,
    opts: &TrainOptions,
    studies: Studies,
    log: &dyn Fn(&str),
) -> Result<(Trained, Metrics), TrainerError> {
    let mut timings = Vec::new();
    let origin = Origin { scenario: sim.config.name.clone(), seed: sim.seed };
    let t = Instant::now();
    let trained = fit::train(&sim.data, opts, &origin)?;
    timings.push(("train".to_string(), t.elapsed().as_secs_f64()));
    log(&format!(
        "trained Model-P and Model-H in {:.1} s ({} grid points)",
        t.elapsed().as_secs_f64(),
        trained.selection.rows.len()
    ));
    let oracle = sim.oracle_floor().holdout_for(&Measurand::of_dims(&trained.model_h.dims));
    let t = Instant::now();
    let t2 = table2(&trained.model_p, &trained.model_h, &sim.data, Some(oracle))?;
    timings.push(("evaluate".to_string(), t.elapsed().as_secs_f64()));

    let chosen = trained.selection.chosen;
    let drift = if studies.drift_sweep {
        let t = Instant::now();
        let r = drift_sweep(&sim.config, sim.seed, &chosen, opts)?;
        timings.push(("drift_sweep".to_string(), t.elapsed().as_secs_f64()));
        log(&format!(
            "drift sweep ({} refits of both models) in {:.1} s",
            DRIFT_FACTORS.len(),
            t.elapsed().as_secs_f64()
        ));
        Some(r)
    } else {
        None
    };
    let abl = if studies.ablation {
        let t = Instant::now();
        let r = ablation(&sim.data, &trained, opts, &origin)?;
        timings.push(("ablation".to_string(), t.elapsed().as_secs_f64()));
        log(&format!("ablation in {:.1} s", t.elapsed().as_secs_f64()));
        Some(r)
    } else {
        None
    };
    let budget = if studies.error_budget {
        let t = Instant::now();
        let r = error_budget(&sim.config, sim.seed, &chosen, opts)?;
        timings.push(("error_budget".to_string(), t.elapsed().as_secs_f64()));
        log(&format!("error budget in {:.1} s", t.elapsed().as_secs_f64()));
        Some(r)
    } else {
        None
    };
    let parity = if studies.parity { Some(parity::check(&trained.model_h, &sim.data, &t2.model_h)?) } else { None };
    let recal = if studies.recalibration {
        let t = Instant::now();
        let seed_new = sim.seed.wrapping_add(RECAL_SEED_OFFSET);
        let r: Result<Vec<_>, TrainerError> = fit::par_map(&RECAL_BATCH_HOURS, |&h| {
            recalibration(&sim.config, &trained.model_h, &trained.model_p, sim.seed, seed_new, h, &chosen)
        })
        .into_iter()
        .collect();
        timings.push(("recalibration".to_string(), t.elapsed().as_secs_f64()));
        log(&format!("recalibration study in {:.1} s", t.elapsed().as_secs_f64()));
        Some(r?)
    } else {
        None
    };
    let d = &sim.data;
    let mut m = Metrics {
        trainer_version: env!("CARGO_PKG_VERSION").to_string(),
        scenario: sim.config.name.clone(),
        seed: sim.seed,
        samples: d.len(),
        cal_samples: d.cal_indices().len(),
        holdout_samples: d.holdout_indices().len(),
        channels: channels(&trained.model_h.dims),
        units: units(&trained.model_h.dims),
        warnings: Vec::new(),
        selection: SelectionSummary::from(&trained.selection),
        table2: t2,
        drift_sweep: drift,
        ablation: abl,
        error_budget: budget,
        parity,
        recalibration: recal,
        static_fidelity: Some(crate::eval::metrics::static_fidelity(&trained.static_audit)),
        pace: if studies.pace {
            let t = Instant::now();
            let r =
                crate::eval::pace::pace_study(&sim.config, sim.seed, &trained.model_p, &trained.model_h, &sim.data)?;
            log(&format!("pace study ({} records) in {:.1} s", r.rows.len(), t.elapsed().as_secs_f64()));
            Some(r)
        } else {
            None
        },
        timings_s: timings,
    };
    m.warnings = crate::eval::warnings::evaluation(&m, &trained.model_h.dims);
    Ok((trained, m))
}

/// The hyper-parameters a trained model carries, as a grid point.
pub(crate) fn config_of(h: &HostParams) -> fit::Config {
    let n_cal = h.provenance.n_cal.max(1) as f64;
    fit::Config {
        feature_set: h.hyper.feature_set,
        dead_band_pm: h.hyper.dead_band_pm,
        k: h.centres.len(),
        sigma_mult: h.hyper.sigma_mult,
        alpha_rel: h.hyper.alpha / n_cal,
        cross_terms: true,
    }
}

/// Evaluate given models (from blobs) on `d`: Table 2, and the studies that the data allow
/// (Table 3 retrains on the calibration part; the drift sweep and error budget need the
/// scenario of a simulated CSV), and the evaluation's warnings (`train`'s, recorded in the
/// model's `coefficients.json`, are the caller's to [`crate::eval::warnings::merge`] in).
pub fn evaluate_models(
    p: &HostParams,
    h: &HostParams,
    d: &Dataset,
    meta: Option<&SimMeta>,
    studies: Studies,
    progress: bool,
    log: &dyn Fn(&str),
) -> Result<Metrics, TrainerError> {
    let mut timings = Vec::new();
    // One step per phase (on a terminal only); the phases that retrain draw their own
    // cross-validation bars, so this one is suspended while they run.
    let with_meta = meta.is_some();
    let steps = 1
        + usize::from(studies.ablation)
        + usize::from(with_meta && studies.drift_sweep)
        + usize::from(with_meta && studies.error_budget)
        + usize::from(studies.parity);
    let bar = crate::progress::bar(progress, steps as u64, "evaluate");
    bar.steady_tick(std::time::Duration::from_millis(200));
    bar.set_message("hold-out (Table 2)");
    let t = Instant::now();
    let oracle = meta.map(|m| m.oracle_floor_for(&Measurand::of_dims(&h.dims)));
    let n_out = h.dims.n_outputs();
    let t2 = table2(p, h, d, oracle)?;
    bar.inc(1);
    timings.push(("evaluate".to_string(), t.elapsed().as_secs_f64()));
    let chosen = config_of(h);
    // The variants retrain on the rows the given models were fitted on: a model exists only
    // for a batch without reference outliers or one trained with their rows left out.
    let opts = TrainOptions::default()
        .with_progress(progress)
        .with_seed(1)
        .with_on_outlier(crate::data::import::OnError::Skip);
    let origin = Origin {
        scenario: meta.map(|m| m.scenario.name.clone()).unwrap_or_else(|| h.provenance.scenario.to_string()),
        seed: meta.map(|m| m.seed).unwrap_or(h.provenance.seed),
    };
    // Both models' static gains over the calibration batch (DESIGN §4), once: for the metrics
    // and for the stand-in of the given models in Table 3.
    let cal: Vec<usize> = d.cal_indices().into_iter().filter(|&i| d.usable(i)).collect();
    let audit = if cal.is_empty() { None } else { Some(fit::static_fidelity::StaticAudit::of(p, h, d, &cal)?) };
    let abl = if studies.ablation {
        let t = Instant::now();
        // The given models are the baseline and default rows; only the variants retrain.
        let trained = given_as_trained(p, h, d, &cal, chosen, audit.as_ref())?;
        bar.set_message("ablation");
        let r = bar.suspend(|| ablation(d, &trained, &opts, &origin))?;
        bar.inc(1);
        timings.push(("ablation".to_string(), t.elapsed().as_secs_f64()));
        bar.suspend(|| log(&format!("ablation in {:.1} s", t.elapsed().as_secs_f64())));
        Some(r)
    } else {
        None
    };
    let (drift, budget) = match (meta, studies.drift_sweep || studies.error_budget) {
        (Some(m), true) => scenario_studies(m, studies, &chosen, &opts, &bar, log, &mut timings)?,
        _ => (None, None),
    };
    bar.set_message("parity");
    let parity = if studies.parity { Some(parity::check(h, d, &t2.model_h)?) } else { None };
    bar.finish_and_clear();
    let mut m = Metrics {
        trainer_version: env!("CARGO_PKG_VERSION").to_string(),
        scenario: origin.scenario.clone(),
        seed: origin.seed,
        samples: d.len(),
        cal_samples: d.cal_indices().len(),
        holdout_samples: d.holdout_indices().len(),
        channels: channels(&h.dims),
        units: units(&h.dims),
        warnings: Vec::new(),
        selection: SelectionSummary::given(chosen, n_out),
        table2: t2,
        drift_sweep: drift,
        ablation: abl,
        error_budget: budget,
        parity,
        recalibration: None,
        static_fidelity: audit.as_ref().map(crate::eval::metrics::static_fidelity),
        pace: match meta {
            Some(m) if studies.pace => {
                let t = Instant::now();
                let r = crate::eval::pace::pace_study(&m.scenario, m.seed, p, h, d)?;
                timings.push(("pace".to_string(), t.elapsed().as_secs_f64()));
                Some(r)
            }
            _ => None,
        },
        timings_s: timings,
    };
    m.warnings = crate::eval::warnings::evaluation(&m, &h.dims);
    Ok(m)
}

/// The given models as the outcome of a fit (the baseline and default rows of Table 3): their
/// grid point `chosen`, no cross-validation, the static audit `audit` of the calibration rows
/// `cal` (computed here when there is none).
fn given_as_trained(
    p: &HostParams,
    h: &HostParams,
    d: &Dataset,
    cal: &[usize],
    chosen: fit::Config,
    audit: Option<&fit::static_fidelity::StaticAudit>,
) -> Result<Trained, TrainerError> {
    let n_out = h.dims.n_outputs();
    Ok(Trained {
        model_p: p.clone(),
        model_h: h.clone(),
        core: fit::PolyCore::of(p),
        selection: fit::Selection {
            chosen,
            memory: fit::memory_core::MemoryChoice::none(),
            memory_rows: vec![],
            rows: vec![],
            cv_rmse_p: vec![f64::NAN; n_out],
            cv_rmse_h: vec![f64::NAN; n_out],
            var_model_p: Default::default(),
            var_model_h: Default::default(),
            drift_rate_pm2_per_s: None,
            stated_drift_pm_per_sqrt_day: None,
            stated_drift_gains: None,
            folds: vec![],
            n_cal: h.provenance.n_cal as usize,
            cv_stride: 1,
        },
        phase_seconds: vec![],
        static_audit: match audit {
            Some(a) => a.clone(),
            None => fit::static_fidelity::StaticAudit::of(p, h, d, cal)?,
        },
        skipped: vec![],
        warnings: vec![],
    })
}

/// The studies that re-simulate the scenario of `m` (the drift sweep and the error budget,
/// as `studies` asks), each retraining at `chosen`; their time goes into `timings`.
fn scenario_studies(
    m: &SimMeta,
    studies: Studies,
    chosen: &fit::Config,
    opts: &TrainOptions,
    bar: &crate::progress::Bar,
    log: &dyn Fn(&str),
    timings: &mut Vec<(String, f64)>,
) -> Result<(Option<DriftSweep>, Option<Vec<BudgetRow>>), TrainerError> {
    let t = Instant::now();
    bar.set_message("drift sweep");
    let ds = if studies.drift_sweep {
        let r = bar.suspend(|| drift_sweep(&m.scenario, m.seed, chosen, opts))?;
        bar.inc(1);
        Some(r)
    } else {
        None
    };
    bar.set_message("error budget");
    let eb = if studies.error_budget {
        let r = bar.suspend(|| error_budget(&m.scenario, m.seed, chosen, opts))?;
        bar.inc(1);
        Some(r)
    } else {
        None
    };
    timings.push(("drift_sweep+error_budget".to_string(), t.elapsed().as_secs_f64()));
    bar.suspend(|| log(&format!("drift sweep and error budget in {:.1} s", t.elapsed().as_secs_f64())));
    Ok((ds, eb))
}
