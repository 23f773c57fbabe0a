//! The models are fitted from the calibration batch only, deterministically,
//! and behave as a calibration engineer expects on the `paper` preset.

use crate::common;

use fbg_shared::FeatureSet;
use fbg_trainer::data::{Measurand, Split};
use fbg_trainer::eval::score::evaluate_holdout;
use fbg_trainer::fit::static_fidelity::static_gain;
use fbg_trainer::fit::{train, Config, HostParams, Origin, TrainOptions};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;

fn short_paper(days: f64) -> fbg_trainer::sim::scenario::ScenarioConfig {
    let mut c = Preset::Paper.config();
    c.clock.days = days;
    c
}

fn without_date(mut p: HostParams) -> HostParams {
    p.provenance.date_yyyymmdd = 0;
    p
}

#[test]
fn changing_the_holdout_cannot_change_the_fitted_models() {
    let s = simulate(&short_paper(4.0), 3);
    let origin = Origin { scenario: "paper".into(), seed: 3 };
    let a = train(&s.data, &common::small_grid(), &origin).unwrap();
    let mut d = s.data.clone();
    for i in 0..d.len() {
        if d.split[i] == Split::Holdout {
            d.dl_pm[0][i] += 1e3 * (i as f64).sin();
            d.dl_pm[2][i] = -d.dl_pm[2][i];
            d.t_amb_c.as_mut().unwrap()[i] += 40.0;
            d.reference_mut(Measurand::T).unwrap()[i] = 1e4;
            d.reference_mut(Measurand::STRAIN).unwrap()[i] *= -3.0;
            d.reference_mut(Measurand::P).unwrap()[i] = 0.0;
        }
    }
    let b = train(&d, &common::small_grid(), &origin).unwrap();
    // The memory terms (groups and λ per output) are chosen inside the calibration batch too.
    assert!(a.model_h.has_memory(), "the default model has memory terms");
    assert_eq!(a.selection.memory, b.selection.memory);
    assert_eq!(without_date(a.model_h), without_date(b.model_h));
    assert_eq!(without_date(a.model_p), without_date(b.model_p));
    assert_eq!(a.selection.chosen, b.selection.chosen);
    // And the hold-out really was different.
    assert_ne!(s.data, d);
}

#[test]
fn training_is_deterministic() {
    let s = simulate(&short_paper(3.0), 5);
    let o = Origin::default();
    let a = train(&s.data, &common::small_grid(), &o).unwrap();
    let b = train(&s.data, &common::small_grid(), &o).unwrap();
    assert_eq!(without_date(a.model_h), without_date(b.model_h));
}

#[test]
fn too_few_calibration_samples_is_a_clear_error() {
    let s = simulate(&short_paper(3.0), 5);
    let idx: Vec<usize> = (0..150).chain(s.data.len() - 100..s.data.len()).collect();
    let d = s.data.select(&idx);
    let e = train(&d, &common::small_grid(), &Origin::default()).unwrap_err().to_string();
    assert!(e.contains("calibration samples"), "{e}");
}

#[test]
fn fixed_grid_point_is_honoured() {
    let s = simulate(&short_paper(3.0), 5);
    let cfg = Config {
        feature_set: FeatureSet::HysteresisAware,
        dead_band_pm: 3.0,
        k: 12,
        sigma_mult: 1.5,
        alpha_rel: 1e-4,
        cross_terms: true,
    };
    let t = train(&s.data, &TrainOptions::fixed(&cfg), &Origin::default()).unwrap();
    assert_eq!(t.selection.chosen, cfg);
    assert_eq!(t.model_h.centres.len(), 12);
    assert_eq!(t.model_h.hyper.dead_band_pm, 3.0);
    assert_eq!(t.model_p.centres.len(), 0);
    // Model-P and Model-H share stage 1 and the polynomial core B (the static calibration):
    // Model-H's memory terms are fitted on what B leaves, never with it.
    assert_eq!(t.model_p.stage1, t.model_h.stage1);
    assert!(!t.model_p.has_memory());
    assert_eq!(t.model_p.poly, t.model_h.poly);
    // The memory terms were chosen inside the calibration batch and are in the model.
    assert_eq!(t.model_h.has_memory(), t.selection.memory.any());
}

/// The default pipeline on the default scenario: the numbers DESIGN §5 asks for, with
/// tolerances (seeded, so deterministic). Model-H is ahead of Model-P on every channel with the
/// same static gain (DESIGN §4, static fidelity); the size of the gain over seeds 7–26 is
/// `cargo xtask bench`'s.
#[test]
fn paper_preset_model_h_beats_model_p_and_removes_the_hysteresis_bias() {
    let s = simulate(&Preset::Paper.config(), 7);
    let t = train(&s.data, &TrainOptions::default(), &Origin { scenario: "paper".into(), seed: 7 }).unwrap();
    let (ep, _) = evaluate_holdout(&t.model_p, &s.data).unwrap();
    let (eh, _) = evaluate_holdout(&t.model_h, &s.data).unwrap();
    let floor = s.oracle_floor().rmse_holdout;
    for (c, &floor_c) in floor.iter().enumerate() {
        let (p, h) = (ep.channels[c], eh.channels[c]);
        assert!(h.rmse < 0.95 * p.rmse, "channel {c}: H {} vs P {}", h.rmse, p.rmse);
        // The per-sample oracle is a reference, not a floor, for a model with memory: only
        // check that it is the same order of magnitude.
        assert!(h.rmse > 0.5 * floor_c, "channel {c}: {} vs per-sample oracle {floor_c}", h.rmse);
        assert!(h.r2 > 0.95, "channel {c}: R² {}", h.r2);
        // T's band under-covers on this seed (0.889): its hold-out error is 21 % above the
        // cross-validated one the band is calibrated on (the drift the memory terms no longer
        // absorb at the calibration's pace). The 95 % and 90 % targets are `cargo xtask
        // bench`'s (reported there as not met); this pins that it gets no worse.
        let low = if c == 0 { 0.88 } else { 0.90 };
        assert!((low..=0.995).contains(&h.coverage), "channel {c}: coverage {}", h.coverage);
        // Play radii stand above the noise (5σ, DESIGN §4 (c)): the narrow loops that radii of
        // 2 and 4 pm caught are left to the RBF, and on p the index falls by half
        // (−1.35 → −0.69 at this seed) where it fell by 58 % with radii that noise crossed.
        assert!(
            h.hysteresis_index.abs() < 0.6 * p.hysteresis_index.abs(),
            "channel {c}: hysteresis index {} vs {}",
            h.hysteresis_index,
            p.hysteresis_index
        );
    }
    // Static fidelity: the truth regressed on either model's settled reading over the
    // calibration batch has slope 1 (Model-H's memory terms do not carry the measurand).
    let cal = s.data.cal_indices();
    let gp = static_gain(&t.model_p, &s.data, &cal).unwrap();
    let gh = static_gain(&t.model_h, &s.data, &cal).unwrap();
    for c in 0..3 {
        assert!((gp.gain[c] - 1.0).abs() < 0.005, "Model-P static gain {c}: {}", gp.gain[c]);
        assert!((gh.gain[c] - 1.0).abs() < 0.01, "Model-H static gain {c}: {}", gh.gain[c]);
    }
    // The default variant: memory terms on every channel, the RBF on the latch inputs.
    assert_ne!(t.selection.chosen.feature_set, FeatureSet::Paper);
    assert!((0..3).all(|o| t.selection.memory.groups[o] != 0), "{:?}", t.selection.memory);
    assert!(t.model_h.centres.len() <= 32, "the device holds 32 centres");
}

/// Real data: a missing reference column is an unfitted output; gaps (empty cells) are skipped
/// in fitting and flagged when compensating.
#[test]
fn missing_reference_and_gaps_are_handled() {
    let dir = tempfile::tempdir().unwrap();
    let s = simulate(&short_paper(4.0), 11);
    let mut d = s.data.clone();
    assert!(d.remove_reference(Measurand::P));
    for i in (50..d.len()).step_by(97) {
        d.dl_pm[1][i] = f64::NAN; // a peak the interrogator missed
    }
    let csv = dir.path().join("real.csv");
    d.write_csv(&csv).unwrap();
    let text = common::read_csv_body(&csv);
    assert!(text.starts_with("t_s,T_C,strain_ue,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split\n"), "{}", &text[..80]);
    let back = fbg_trainer::data::Dataset::read_csv(&csv).unwrap();
    assert_eq!(back.measurands(), [Measurand::T, Measurand::STRAIN]);
    assert!(back.dl_pm[1][50].is_nan());

    // The model's outputs are the data's measurands: T and ε (no p output at all).
    let t = train(&back, &common::small_grid(), &Origin::default()).unwrap();
    assert_eq!(t.model_h.dims.n_outputs(), 2);
    assert_eq!(t.model_h.fitted, [true, true, false, false]);
    let (eh, est) = evaluate_holdout(&t.model_h, &back).unwrap();
    assert_eq!(eh.channels.len(), 2);
    assert!(eh.channels[0].rmse.is_finite() && eh.channels[1].rmse < 10.0);
    assert!(est.iter().all(|e| e.values().len() == 2));
    // A gap sample is flagged NON_FINITE by the compensator and the stream carries on.
    let mut c = fbg_trainer::fit::HostCompensator::new(&t.model_h).unwrap();
    let gap = back.sample(50 + 97 * 55);
    assert!(gap.dl_pm[1].is_nan());
    assert!(c.step(&gap).flags.contains(fbg_shared::Flags::NON_FINITE));
    assert!(!c.step(&back.sample(1)).flags.contains(fbg_shared::Flags::NON_FINITE));
}

/// The parallel, checkpointed passes over a record give exactly what one sequential pass of
/// the compensator gives, on any pool size.
#[test]
fn stretches_resumed_from_checkpoints_answer_as_one_sequential_pass() {
    use fbg_trainer::fit::design::{self, CheckpointCache, Checkpoints};
    use fbg_trainer::fit::HostCompensator;
    // Long enough for several stretches; a gap in the middle of the calibration batch.
    let mut s = simulate(&short_paper(7.0), 9);
    s.data.dl_pm[1][3000] = f64::NAN;
    let d = &s.data;
    let cfg = Config {
        feature_set: FeatureSet::HysteresisAware,
        dead_band_pm: 4.0,
        k: 16,
        sigma_mult: 2.0,
        alpha_rel: 1e-4,
        cross_terms: true,
    };
    let tr = train(d, &TrainOptions::fixed(&cfg), &Origin::default()).unwrap();
    let h = &tr.model_h;
    // Every third calibration row, and a few hold-out rows.
    let mut rows: Vec<usize> = d.cal_indices().into_iter().step_by(3).collect();
    rows.extend([d.len() - 7, d.len() - 1]);

    // Sequential reference, on the record's own clock (as the stretches run it).
    let mut c = HostCompensator::new(h).unwrap();
    c.set_clock(d.calibration_clock(h));
    let mut want_est = Vec::new();
    let mut want_psi = Vec::new();
    let mut r = rows.iter().peekable();
    for i in 0..d.len() {
        let mut psi = vec![0.0; h.centres.len()];
        let e = c.step_with(&d.sample(i), |j, v| psi[j] = v);
        if r.peek() == Some(&&i) {
            r.next();
            want_est.push(e);
            want_psi.push(psi);
        }
    }
    let bits = |e: &fbg_shared::Estimate<f64>| (e.values.map(f64::to_bits), e.band95.map(f64::to_bits), e.flags);
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let cache = CheckpointCache::new(d.len(), rows.clone());
            let ck = cache.get(h, d).unwrap();
            for ck in [None, Some(&*ck), Some(&Checkpoints::new(h, d, d.len(), &[]).unwrap())] {
                let est = design::run_with(h, d, &rows, ck).unwrap();
                assert_eq!(est.iter().map(bits).collect::<Vec<_>>(), want_est.iter().map(bits).collect::<Vec<_>>());
                let (psi, _) = design::design_matrix_with(h, d, &rows, ck).unwrap();
                for (r, want) in want_psi.iter().enumerate() {
                    for (j, w) in want.iter().enumerate() {
                        assert_eq!(psi[(r, j)].to_bits(), w.to_bits(), "row {r} centre {j}");
                    }
                }
            }
            // The ridge sums, accumulated stretch by stretch, against ΨᵀΨ of the whole Ψ.
            let usable: Vec<usize> = rows.iter().copied().filter(|&i| d.usable(i)).collect();
            let (psi, _) = design::design_matrix(h, d, &usable).unwrap();
            let g = design::gram(h, d, &usable, None).unwrap();
            let want = psi.tr_mul(&psi);
            assert!((&g.g - &want).amax() <= 1e-12 * want.amax());
            assert_eq!(g.n, usable.len());
        });
    }
}

/// The audit `train` warns from: a Model-H whose core gain was cut (as a joint fit of B with
/// level-free memory terms does at the calibration's pace) disagrees with Model-P on exactly
/// that output, by the cut.
#[test]
fn static_audit_names_an_output_whose_core_gain_was_cut() {
    let s = simulate(&short_paper(3.0), 5);
    let t = train(&s.data, &common::small_grid(), &Origin::default()).unwrap();
    let cal = s.data.cal_indices();
    assert!(t.static_audit.disagreements().is_empty(), "{:?}", t.static_audit);
    let mut cut = t.model_h.clone();
    // Output 2 (p): every non-constant term of B at 60 %.
    for v in cut.poly[2].iter_mut().skip(1) {
        *v *= 0.6;
    }
    let a = fbg_trainer::fit::static_fidelity::StaticAudit::of(&t.model_p, &cut, &s.data, &cal).unwrap();
    let d = a.disagreements();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].0, 2);
    // The truth regressed on the cut reading: the gain it would need, 1 / 0.6.
    assert!((d[0].1 / d[0].2 - 1.0 / 0.6).abs() < 0.1, "{d:?}");
}

/// The reference-outlier test finds nothing in any simulated preset — their
/// references carry AR noise, holds, ramps, reversals and (with `--steps`) stepped levels held
/// from 4 rows up — over every row, calibration and hold-out, with |z| well below the limit.
/// The detector was designed on seeds 1–5 and 7 (and pace 4 / 0.25 on seed 3); these seeds
/// were not used then.
#[test]
fn simulated_presets_have_no_reference_outliers() {
    use fbg_trainer::data::outliers::{find, largest_z, Z_LIMIT};
    let mut worst = (0.0, String::new());
    for preset in
        [Preset::Paper, Preset::Harsh, Preset::Field, Preset::Array8, Preset::StrainPair, Preset::Temperature1]
    {
        let base = preset.config();
        let records = [
            (base.clone(), 11, "plain"),
            (base.steps(), 12, "steps"),
            (base.paced(4.0, None).steps(), 13, "pace 4 steps"),
        ];
        for (cfg, seed, what) in records {
            let d = simulate(&cfg, seed).data;
            let all: Vec<usize> = (0..d.len()).collect();
            let found = find(&d, &all);
            assert!(found.is_empty(), "{} {what} seed {seed}: {:?}", preset.name(), &found[..found.len().min(3)]);
            for r in &d.refs {
                let x: Vec<f64> = r.values.iter().copied().filter(|v| v.is_finite()).collect();
                let z = largest_z(&x);
                if z > worst.0 {
                    worst = (z, format!("{} {what} seed {seed} {}", preset.name(), r.measurand));
                }
            }
        }
    }
    // Headroom: the largest |z| of a clean record stays under three quarters of the limit
    // (3.95 over the design seeds).
    eprintln!("largest |z| of a clean record: {:.2} ({})", worst.0, worst.1);
    assert!(worst.0 < 0.75 * Z_LIMIT, "largest |z| {:.2} ({})", worst.0, worst.1);
}

/// One reference cell T_C = 1e6 in a 2-day calibration is refused naming the
/// file, its CSV line and column, the value and the running median; with skip its row is left
/// out (the same models as with the cell emptied), counted in a warning, and the hold-out T
/// RMSE is the clean calibration's again.
#[test]
fn a_reference_outlier_is_refused_with_its_line_or_left_out_with_skip() {
    use fbg_trainer::data::import::OnError;
    use fbg_trainer::fit::train_source;
    let s = simulate(&short_paper(2.0), 21);
    let origin = Origin::default();
    let clean = train(&s.data, &common::small_grid(), &origin).unwrap();
    let row = 700;
    assert_eq!(s.data.split[row], Split::Cal);
    let mut d = s.data.clone();
    d.reference_mut(Measurand::T).unwrap()[row] = 1e6;

    let e = train_source(&d, "cal.csv", &common::small_grid(), &origin).unwrap_err().to_string();
    assert!(
        e.starts_with("cal.csv: line 702, column T_C: reference outlier: 1000000 °C where the running median is "),
        "{e}"
    );
    assert!(e.contains("--on-error skip"), "{e}");
    // A front end names its own option (Python's parameter).
    let python = common::small_grid().with_skip_outliers_hint("fit with `on_outlier=\"skip\"`");
    let e = train_source(&d, "<frame>", &python, &origin).unwrap_err().to_string();
    assert!(e.contains("or fit with `on_outlier=\"skip\"` to leave") && !e.contains("--on-error"), "{e}");

    let skip = common::small_grid().with_on_outlier(OnError::Skip);
    let t = train_source(&d, "cal.csv", &skip, &origin).unwrap();
    assert_eq!(t.skipped.iter().map(|o| (o.line, o.column.as_str())).collect::<Vec<_>>(), [(702, "T_C")]);
    assert_eq!(t.selection.n_cal, clean.selection.n_cal - 1);
    let w = t.warnings.iter().find(|w| w.code == "reference_outliers_skipped").expect("a warning for the skipped row");
    assert_eq!(w.channel.as_deref(), Some("T"));
    assert_eq!((w.numbers["rows"], w.numbers["first_line"]), (1.0, 702.0));
    // Leaving the row out is emptying the cell.
    let mut blank = s.data.clone();
    blank.reference_mut(Measurand::T).unwrap()[row] = f64::NAN;
    let b = train(&blank, &common::small_grid(), &origin).unwrap();
    assert_eq!(without_date(b.model_h), without_date(t.model_h.clone()));
    assert!(b.warnings.iter().all(|w| w.code != "reference_outliers_skipped"));
    // The hold-out T RMSE of both models is back at the clean calibration's.
    for (name, got, want) in [("Model-H", &t.model_h, &clean.model_h), ("Model-P", &t.model_p, &clean.model_p)] {
        let rmse = |p: &HostParams| evaluate_holdout(p, &d).unwrap().0.channels[0].rmse;
        let (g, w) = (rmse(got), rmse(want));
        assert!((g - w).abs() < 0.05 * w, "{name}: hold-out T RMSE {g} with the row left out, {w} clean");
    }
}

/// The same cell in a 200-row calibration: refused with its line; left out, the batch is one
/// row short of the minimum and the error says why.
#[test]
fn a_reference_outlier_in_a_200_row_calibration_is_refused_with_its_line() {
    use fbg_trainer::data::import::OnError;
    let s = simulate(&short_paper(400.0 * 60.0 / 86_400.0), 22);
    assert_eq!(s.data.cal_indices().len(), 200);
    let mut d = s.data.clone();
    d.reference_mut(Measurand::T).unwrap()[100] = 1e6;
    let e = train(&d, &common::small_grid(), &Origin::default()).unwrap_err().to_string();
    assert!(e.starts_with("the dataset: line 102, column T_C: reference outlier: 1000000 °C"), "{e}");
    let skip = common::small_grid().with_on_outlier(OnError::Skip);
    let e = train(&d, &skip, &Origin::default()).unwrap_err().to_string();
    assert!(e.contains("199 usable calibration samples") && e.contains("1 with reference outliers left out"), "{e}");
}

/// An input cell whose square overflows (a shift of 1e154 pm) used to keep the fit's
/// SVD iterating forever, and smaller implausible ones failed with an anonymous "non-finite
/// envelope". A record handed over in memory is held to the CSV reader's input rule: refused
/// at once, naming the CSV line and column, before any fitting.
#[test]
fn an_implausible_input_cell_is_refused_by_line_and_column_before_the_fit() {
    use fbg_trainer::fit::train_source;
    let s = simulate(&short_paper(2.0), 21);
    for (column, value, says) in [
        ("dl2_pm", 1e154, "1e154 (shift_pm) is a shift beyond 10 nm"),
        ("dl2_pm", 1e6, "1000000 should be a shift in pm but looks like an absolute wavelength in pm"),
        ("dl1_pm", -1e300, "-1e300 (shift_pm) is a shift beyond 10 nm"),
        ("T_amb_C", 1e154, "ambient 1e154 °C is outside -80–200 °C"),
    ] {
        let mut d = s.data.clone();
        let row = 17;
        match column {
            "T_amb_C" => d.t_amb_c.as_mut().unwrap()[row] = value,
            "dl1_pm" => d.dl_pm[0][row] = value,
            _ => d.dl_pm[1][row] = value,
        }
        let e = train_source(&d, "x.csv", &common::small_grid(), &Origin::default()).unwrap_err().to_string();
        assert!(e.starts_with(&format!("x.csv: line 19, column {column}: {says}")), "{e}");
    }
}

/// A fit whose cancel flag is set (Python's Ctrl-C) ends with `Interrupted`, before its work.
#[test]
fn a_cancelled_fit_ends_interrupted() {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    let s = simulate(&short_paper(2.0), 21);
    let opts = common::small_grid().with_cancel(Arc::new(AtomicBool::new(true)));
    let e = train(&s.data, &opts, &Origin::default()).unwrap_err();
    assert!(matches!(e, fbg_trainer::TrainerError::Interrupted { .. }), "{e}");
    assert_eq!(e.to_string(), "fit: interrupted");
}
