//! Each grating's sensitivity to each measurand (∂Δλ/∂y) and the model's
//! inverse (∂ŷ/∂Δλ) at the calibration's mean input.

use crate::common;
use fbg_shared::{FeatureSet, Sample};

use fbg_trainer::data::Measurand;
use fbg_trainer::fit::sensitivity::{self, ForwardMethod, Sensitivity};
use fbg_trainer::fit::static_fidelity::settled_model;
use fbg_trainer::fit::{self, Config, HostCompensator, HostParams, Origin, TrainOptions};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::{simulate, Simulation};

fn train(s: &Simulation) -> fit::Trained {
    let opts = TrainOptions::fixed(&Config {
        feature_set: FeatureSet::HysteresisAware,
        dead_band_pm: 4.0,
        k: 8,
        sigma_mult: 2.0,
        alpha_rel: 1e-4,
        cross_terms: true,
    });
    fit::train(&s.data, &opts, &Origin { scenario: s.config.name.clone(), seed: s.seed }).unwrap()
}

/// The calibration rows the fit used.
fn cal_rows(s: &Simulation) -> Vec<usize> {
    s.data.cal_indices().into_iter().filter(|&i| s.data.usable(i)).collect()
}

fn mean(rows: &[usize], v: &[f64]) -> f64 {
    rows.iter().map(|&i| v[i]).sum::<f64>() / rows.len() as f64
}

/// The true ∂Δλ_i/∂y_j of the simulated installation at the calibration's mean truth, in steady
/// state: the gauge matrix with its cross-terms (central differences of the forward physics,
/// which is quadratic, so exact up to rounding), plus on the temperature column the
/// interrogator's electronics drift, which follows the ambient temperature and so, once
/// settled, the structure's (lin + 2·quad·(T̄_amb − ref), the same on every grating). N rows ×
/// M columns in the model's output order.
fn true_gauge(s: &Simulation, outputs: &[String]) -> Vec<Vec<f64>> {
    let rows = cal_rows(s);
    let ph = &s.physics;
    let y: Vec<f64> = ph
        .measurands
        .iter()
        .map(|m| mean(&rows, &s.data.refs.iter().find(|r| r.measurand == *m).unwrap().values))
        .collect();
    let cols: Vec<usize> =
        outputs.iter().map(|o| ph.measurands.iter().position(|m| m.column() == *o).unwrap()).collect();
    let e = &s.config.electronics;
    let amb: Vec<f64> = rows.iter().map(|&i| s.ambient_true_c[s.grid_rows[i]]).collect();
    let amb_mean = amb.iter().sum::<f64>() / amb.len() as f64;
    let electronics = if e.enabled { e.lin_pm_per_c + 2.0 * e.quad_pm_per_c2 * (amb_mean - e.ref_c) } else { 0.0 };
    (0..ph.n_gratings())
        .map(|i| {
            cols.iter()
                .map(|&j| {
                    let h = 1.0;
                    let (mut a, mut b) = (y.clone(), y.clone());
                    a[j] += h;
                    b[j] -= h;
                    let gauge = (ph.forward(&a)[i] - ph.forward(&b)[i]) / (2.0 * h);
                    gauge + if ph.measurands[j] == Measurand::T { electronics } else { 0.0 }
                })
                .collect()
        })
        .collect()
}

/// The calibration's mean input: the mean shift of each grating and the mean T_amb (NaN
/// without the ambient input).
fn mean_input(p: &HostParams, s: &Simulation) -> (Vec<f64>, f64) {
    let rows = cal_rows(s);
    let x = (0..s.data.n_gratings()).map(|g| mean(&rows, &s.data.dl_pm[g])).collect();
    (x, if p.dims.ambient() { mean(&rows, s.data.ambient()) } else { f64::NAN })
}

/// The reading of `p`'s settled model through `fbg_shared` at shifts `dl` and ambient `amb`: a
/// fresh compensator's first step, as a device after boot.
fn reading(p: &HostParams, dl: &[f64], amb: f64) -> Vec<f64> {
    let mut c = HostCompensator::new(&settled_model(p)).unwrap();
    let mut smp = Sample::new([0.0f64; 8], amb, 0.0);
    smp.gratings = dl.len() as u8;
    smp.dl_pm[..dl.len()].copy_from_slice(dl);
    c.step(&smp).values[..p.dims.n_outputs()].to_vec()
}

/// Largest |S_ij − K_ij| over each column's largest |K_ij|: a sensitivity's error as a share of
/// the largest sensitivity to that measurand (so the small cross-sensitivities, 0.01 pm/kPa of
/// a strain grating, are judged on the scale that matters for the reading).
fn worst_column_relative(s: &[Vec<f64>], k: &[Vec<f64>]) -> f64 {
    let m = k[0].len();
    (0..m)
        .map(|j| {
            let scale = k.iter().map(|r| r[j].abs()).fold(0.0, f64::max);
            s.iter().zip(k).map(|(a, b)| (a[j] - b[j]).abs()).fold(0.0, f64::max) / scale
        })
        .fold(0.0, f64::max)
}

fn product(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<Vec<f64>> {
    a.iter().map(|r| (0..b[0].len()).map(|j| r.iter().zip(b).map(|(x, row)| x * row[j]).sum()).collect()).collect()
}

fn paper(seed: u64) -> (Simulation, fit::Trained, Sensitivity) {
    let s = simulate(&Preset::Paper.config(), seed);
    let tr = train(&s);
    let sens = sensitivity::of(&tr.model_p).unwrap();
    (s, tr, sens)
}

/// How the tolerance below was chosen: the spread of the worst column-relative error over
/// seeds 3, 5, 6, 8, 9, 10 (`cargo test -p fbg-trainer --test trainer sensitivity:: -- --ignored
/// --nocapture`). The test itself runs on seed 21, which was not among them.
#[test]
#[ignore]
fn print_paper_sensitivities() {
    for seed in [3, 5, 6, 8, 9, 10] {
        let (s, _, sens) = paper(seed);
        let k = true_gauge(&s, &sens.outputs);
        eprintln!(
            "seed {seed}: worst {:.4}\n  forward {:?}\n  truth   {:?}",
            worst_column_relative(&sens.forward, &k),
            sens.forward,
            k
        );
    }
}

/// Largest error of a forward sensitivity, as a share of the largest true sensitivity to the
/// same measurand. A least-squares calibration on one week of the `paper` installation cannot
/// pin a static slope better than a few per cent: the interrogator's scan ripple (3 pm over a
/// 0.8 nm period) alone tilts each grating's apparent slope by up to 2π·3/800 = 2.4 % at its
/// operating point; the electronics drift (0.8 pm/°C, 7 % of the temperature column) is split
/// by the fit between the gratings and a thermometer that lags by 20 min; and the drift's
/// random walk (σ_d·√n ≈ 3.5 pm over the batch, against spans of ±33 pm for the diaphragm and
/// ±60 pm for temperature) correlates with the measurands by chance. Over seeds 3, 5, 6, 8, 9
/// and 10 the worst error was 1.7–7.5 %; 10 % leaves a margin over that spread, and a wrong
/// convention still fails it by far (the gratings' slopes with T_amb held put the
/// temperature column 70 % off on seed 3; pm read as nm, or a transposed matrix, more).
const FORWARD_TOLERANCE: f64 = 0.10;

#[test]
fn paper_forward_sensitivities_match_the_true_gauge_matrix_and_invert_the_inverse() {
    // Seed 21 was not looked at while choosing FORWARD_TOLERANCE.
    let (s, _, sens) = paper(21);
    let k = true_gauge(&s, &sens.outputs);
    let worst = worst_column_relative(&sens.forward, &k);
    eprintln!("seed 21: worst {worst:.4}\n  forward {:?}\n  truth   {k:?}", sens.forward);
    assert!(
        worst <= FORWARD_TOLERANCE,
        "forward sensitivities {:?} vs the truth {k:?}: worst error {:.1} % of the column's largest",
        sens.forward,
        100.0 * worst
    );
    assert_eq!((sens.method, sens.rank, sens.gratings), (ForwardMethod::Inverse, 3, 3));
    assert!(sens.ambient_follows);
    assert_eq!(sens.units, ["°C", "µε", "kPa"]);
    // inverse × forward = I.
    let id = product(&sens.inverse, &sens.forward);
    for (r, row) in id.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let want = if r == c { 1.0 } else { 0.0 };
            assert!((v - want).abs() < 1e-9, "∂ŷ/∂Δλ · ∂Δλ/∂y = {id:?}");
        }
    }
}

#[test]
fn the_sensitivities_are_those_of_the_shared_inference() {
    let mut cfg = Preset::Paper.config();
    cfg.clock.days = 3.0;
    let s = simulate(&cfg, 4);
    let tr = train(&s);
    let p = &tr.model_p;
    let sens = sensitivity::of(p).unwrap();
    let (x, amb) = mean_input(p, &s);
    let y0 = reading(p, &x, amb);
    // The core's slopes (gratings, then T_amb) by central differences through fbg_shared.
    let core = sensitivity::core_jacobian(p, &[0.0; 4]);
    let h = 0.5;
    for c in 0..=x.len() {
        let (mut xa, mut xb, mut aa, mut ab) = (x.clone(), x.clone(), amb, amb);
        if c < x.len() {
            xa[c] += h;
            xb[c] -= h;
        } else {
            aa += h;
            ab -= h;
        }
        let (ya, yb) = (reading(p, &xa, aa), reading(p, &xb, ab));
        for o in 0..ya.len() {
            let num = (ya[o] - yb[o]) / (2.0 * h);
            assert!(
                (num - core[o][c]).abs() <= 1e-6 * core[o][c].abs().max(1e-3),
                "output {o}, input {c}: analytic {} vs through fbg_shared {num}",
                core[o][c]
            );
        }
    }
    // Forward, end to end: move the gratings by ±S·δy and the thermometer with the
    // temperature; the device's reading moves by ±δy (central differences: the static map is
    // quadratic in its inputs, so they are exact up to rounding).
    for j in 0..y0.len() {
        let dy: Vec<f64> = (0..y0.len()).map(|c| if c == j { [0.1, 1.0, 0.5][c] } else { 0.0 }).collect();
        let at = |sign: f64| {
            let xs: Vec<f64> = x
                .iter()
                .enumerate()
                .map(|(i, v)| v + sign * (0..dy.len()).map(|c| sens.forward[i][c] * dy[c]).sum::<f64>())
                .collect();
            reading(p, &xs, amb + sign * dy[0])
        };
        let (ya, yb) = (at(1.0), at(-1.0));
        let read: Vec<f64> = (0..y0.len()).map(|c| (ya[c] - yb[c]) / 2.0).collect();
        for c in 0..y0.len() {
            assert!((read[c] - dy[c]).abs() <= 1e-6 * dy[j], "a step of {dy:?} read as {read:?}");
        }
    }
}

#[test]
fn more_gratings_than_outputs_take_the_pseudo_inverse_and_say_so() {
    let mut cfg = Preset::Array8.config();
    cfg.clock.days = 3.0;
    let s = simulate(&cfg, 4);
    let tr = train(&s);
    let sens = sensitivity::of(&tr.model_p).unwrap();
    assert_eq!((sens.gratings, sens.outputs.len(), sens.rank), (8, 4, 4));
    assert_eq!(sens.method, ForwardMethod::PseudoInverse);
    assert!(sens.how().contains("Moore–Penrose"), "{}", sens.how());
    assert_eq!(sens.forward.len(), 8);
    let id = product(&sens.inverse, &sens.forward);
    for (r, row) in id.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            assert!((v - if r == c { 1.0 } else { 0.0 }).abs() < 1e-9, "{id:?}");
        }
    }
}

#[test]
fn without_a_thermometer_the_temperature_sensitivity_includes_the_interrogators() {
    let mut cfg = Preset::Temperature1.config();
    cfg.ambient.thermometer = false;
    let s = simulate(&cfg, 21);
    let tr = train(&s);
    let sens = sensitivity::of(&tr.model_p).unwrap();
    assert_eq!(sens.ambient, None);
    assert!(!sens.ambient_follows);
    assert_eq!(sens.method, ForwardMethod::Inverse);
    let k = true_gauge(&s, &sens.outputs);
    let worst = worst_column_relative(&sens.forward, &k);
    eprintln!("temperature-1 without a thermometer: forward {:?}, truth {k:?}", sens.forward);
    assert!(worst <= FORWARD_TOLERANCE, "forward {:?} vs truth {k:?}", sens.forward);
    assert!((sens.inverse[0][0] * sens.forward[0][0] - 1.0).abs() < 1e-12);
}

/// `coefficients.json`, `inspect` (text and JSON) and the report all carry the calibration
/// sheet, the same numbers as `fit::sensitivity` on the Model-P blob.
#[test]
fn coefficients_inspect_and_the_report_carry_the_sensitivities() {
    let d = tempfile::tempdir().unwrap();
    let csv = common::short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = common::run(common::bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let p = fbg_trainer::export::read_blob(&d.path().join("m-p.fbgm")).unwrap();
    let sens = sensitivity::of(&p).unwrap();
    let coef: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("m.coefficients.json")).unwrap()).unwrap();
    let s = &coef["sensitivity"];
    // coefficients.json is written from the f64 fit, the blob holds f32: equal to 1e-6.
    let near = |a: &serde_json::Value, b: f64| a.as_f64().is_some_and(|a| (a - b).abs() <= 1e-6 * b.abs());
    assert!(near(&s["forward"]["dl3_pm"]["p_kPa"], sens.forward[2][2]), "{s}");
    assert!(near(&s["inverse"]["strain_ue"]["dl1_pm"], sens.inverse[1][0]), "{s}");
    assert_eq!(
        (s["forward_units"]["T_C"].as_str(), s["inverse_units"]["p_kPa"].as_str()),
        (Some("pm/°C"), Some("kPa/pm"))
    );
    assert_eq!(s["method"], "inverse");
    assert!(s["ambient_slope"]["T_C"].is_f64());
    let (ok, out, err) = common::run(common::bin().arg("inspect").arg(&model));
    assert!(ok, "{err}");
    assert!(out.contains("sensitivities from") && out.contains("m-p.fbgm"), "{out}");
    assert!(
        out.contains("∂Δλ/∂T [pm/°C]") && out.contains("∂Δλ/∂ε [pm/µε]") && out.contains("∂Δλ/∂p [pm/kPa]"),
        "{out}"
    );
    let (ok, js, _) = common::run(common::bin().args(["inspect", "--json"]).arg(&model));
    assert!(ok);
    let j: serde_json::Value = serde_json::from_str(&js).unwrap();
    assert_eq!(j["sensitivity"]["forward"]["dl3_pm"]["p_kPa"].as_f64(), Some(sens.forward[2][2]));
    assert!(j["sensitivity"]["source"].as_str().is_some_and(|x| x.contains("m-p.fbgm")));
    let (ok, _, err) =
        common::run(common::bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&model));
    assert!(ok, "{err}");
    let rep = d.path().join("report");
    let (ok, _, err) = common::run(
        common::bin().args(["report", "--out"]).arg(&rep).arg("--data").arg(&csv).arg("--model").arg(&model),
    );
    assert!(ok, "{err}");
    let html = std::fs::read_to_string(rep.join("index.html")).unwrap();
    assert!(html.contains("id=\"sensitivity\"") && html.contains("pm/µε") && html.contains("kPa/pm"));
    assert!(rep.join("sensitivity.csv").is_file() && rep.join("sensitivity_inverse.md").is_file());
}
