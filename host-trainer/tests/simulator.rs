//! The simulator is deterministic, each trajectory and effect has its
//! configured statistics, and every effect can be removed exactly.

use crate::common;

use fbg_trainer::sim::scenario::{Preset, ScenarioConfig};
use fbg_trainer::sim::{interrogator, simulate, trajectories, EFFECT_NAMES};
use fbg_trainer::stats::{mean, std_dev};

fn quiet() -> ScenarioConfig {
    // Deterministic parts only, to check amplitudes exactly.
    let mut c = Preset::Paper.config();
    c.temperature.ar_sigma_c = 0.0;
    c.strain.ar_sigma_ue = 0.0;
    c.pressure.ar_sigma_kpa = 0.0;
    c
}

#[test]
fn same_seed_gives_identical_bytes_and_other_seed_differs() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = Preset::Paper.config();
    let (a, b, c) = (dir.path().join("a.csv"), dir.path().join("b.csv"), dir.path().join("c.csv"));
    simulate(&cfg, 7).data.write_csv(&a).unwrap();
    simulate(&cfg, 7).data.write_csv(&b).unwrap();
    simulate(&cfg, 8).data.write_csv(&c).unwrap();
    let (a, b, c) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap(), std::fs::read(c).unwrap());
    assert_eq!(a, b);
    assert_ne!(a, c);
    let text = String::from_utf8(a).unwrap();
    let text = common::csv_body(&text);
    assert_eq!(text.lines().count(), 20_161);
    assert_eq!(text.lines().next().unwrap(), "t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split");
}

#[test]
fn paper_preset_has_the_design_spreads() {
    let s = simulate(&Preset::Paper.config(), 7);
    let d = &s.data;
    let st = std_dev(d.target(0).as_slice().iter().copied());
    let se = std_dev(d.target(1).as_slice().iter().copied());
    let sp = std_dev(d.target(2).as_slice().iter().copied());
    // DESIGN §3 amplitudes: T √(4²/2 + 2²/2 + 0.3²) = 3.18 °C; ε ≈ √(86.6² + 42.4² + 14.1² + 5²)
    // = 97.6 µε (the load levels are random); p √(25²/2 + 8²/2 + 1) = 18.6 kPa.
    assert!((st - 3.18).abs() < 0.25, "T std {st}");
    assert!((se - 97.6).abs() < 15.0, "ε std {se}");
    assert!((sp - 18.6).abs() < 1.0, "p std {sp}");
    assert_eq!(d.cal_indices().len(), 10_080);
}

#[test]
fn sine_amplitudes_match_configuration() {
    let c = quiet();
    let s = simulate(&c, 3);
    let t = &s.data.t_s;
    // Least-squares amplitude of a known-frequency sine in the residual after the others.
    let amp = |y: &[f64], period: f64| {
        let w = std::f64::consts::TAU / period;
        let (mut ss, mut cc, mut n) = (0.0, 0.0, 0.0);
        for (&ti, &yi) in t.iter().zip(y) {
            ss += yi * (w * ti).sin();
            cc += yi * (w * ti).cos();
            n += 1.0;
        }
        2.0 * (ss * ss + cc * cc).sqrt() / n
    };
    let tc: Vec<f64> = s.data.target(0).as_slice().iter().map(|v| v - 20.0).collect();
    assert!((amp(&tc, 86_400.0) - 4.0).abs() < 0.05, "diurnal {}", amp(&tc, 86_400.0));
    assert!((amp(&tc, 7.0 * 86_400.0) - 2.0).abs() < 0.05);
    let pc: Vec<f64> = s.data.target(2).as_slice().iter().map(|v| v - 150.0).collect();
    assert!((amp(&pc, 43_200.0) - 25.0).abs() < 0.2);
    assert!((amp(&pc, 9_000.0) - 8.0).abs() < 0.2);
    assert!((mean(s.data.target(2).as_slice().iter().copied()) - 150.0).abs() < 0.5);
    // Strain: the periodic loads ride on random load steps; remove the steps first.
    let steps = trajectories::load_steps(&c.strain, t, 3);
    let ec: Vec<f64> = s.data.target(1).as_slice().iter().zip(&steps).map(|(e, l)| e - l).collect();
    assert!((amp(&ec, 10_800.0) - 60.0).abs() < 0.5);
    assert!((amp(&ec, 2_400.0) - 20.0).abs() < 0.5);
}

#[test]
fn load_steps_hold_and_ramp() {
    let c = Preset::Paper.config();
    let t: Vec<f64> = (0..20_160).map(|k| k as f64 * 60.0).collect();
    let l = trajectories::load_steps(&c.strain, &t, 5);
    for v in &l {
        assert!((-150.0..=150.0).contains(v));
    }
    // After the 30 min ramp the level is constant until the next 6 h boundary.
    let seg = 6 * 60; // samples per hold
    let ramp = 30;
    for k in 1..10 {
        let s = k * seg;
        let held = &l[s + ramp..s + seg];
        assert!(held.iter().all(|v| *v == held[0]));
        // The ramp is linear between the previous and the new level.
        let (a, b) = (l[s - 1], held[0]);
        let mid = l[s + ramp / 2];
        assert!((mid - (a + b) / 2.0).abs() < 1e-9);
    }
}

#[test]
fn ar1_wiggles_have_configured_sigma_and_correlation() {
    let mut rng = fbg_trainer::rng::Rng::new(9, fbg_trainer::rng::Stream::Temperature);
    let x = trajectories::ar1(200_000, 0.3, 1800.0, 60.0, &mut rng);
    let s = std_dev(x.iter().copied());
    assert!((s - 0.3).abs() < 0.02, "σ {s}");
    let m = mean(x.iter().copied());
    let lag1: f64 = x.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / (x.len() - 1) as f64;
    let rho = lag1 / (s * s);
    let want = (-60.0f64 / 1800.0).exp();
    assert!((rho - want).abs() < 0.01, "lag-1 correlation {rho} vs {want}");
}

#[test]
fn ambient_lags_temperature_with_offset_and_noise() {
    let s = simulate(&Preset::Paper.config(), 4);
    let d = &s.data;
    // Offset: mean(T_amb − T) ≈ 0.5 °C (the lag averages out over whole cycles).
    let off = mean(d.ambient().iter().zip(d.target(0).as_slice()).map(|(a, t)| a - t));
    assert!((off - 0.5).abs() < 0.05, "offset {off}");
    // Reading noise: T_amb minus the noise-free ambient has σ 0.1 °C.
    let n = std_dev(d.ambient().iter().zip(&s.ambient_true_c).map(|(a, b)| a - b));
    assert!((n - 0.1).abs() < 0.005, "reading noise {n}");
}

#[test]
fn random_walk_increments_have_variance_sigma_d_squared() {
    let x = interrogator::random_walk(100_000, 0.05, 12);
    let inc: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let var = std_dev(inc.iter().copied()).powi(2);
    assert!((var / 0.0025 - 1.0).abs() < 0.02, "increment variance {var}");
    assert_eq!(x[0], 0.0);
    // Channel gains scale the common walk.
    let c = Preset::Paper.config();
    let s = simulate(&c, 2);
    for i in (0..s.data.len()).step_by(997) {
        let d = &s.effects.drift;
        assert!((d[1][i] - 1.1 * d[0][i]).abs() < 1e-12);
        assert!((d[2][i] - 1.2 * d[0][i]).abs() < 1e-12);
    }
}

#[test]
fn play_operator_gives_direction_dependent_offsets_of_configured_width() {
    // In the full simulation, on the strain grating: long rises read about −r, long falls
    // about +r (Eq. 9's own terms are small at these speeds).
    let mut c = Preset::Paper.config();
    c.hysteresis.play_half_width_pm = 6.0;
    let s = simulate(&c, 5);
    let x = &s.effects.physics[0];
    let h = &s.effects.hysteresis[0];
    let (up, down) = common::on_long_moves(x, h);
    assert!(up.len() > 20 && down.len() > 20, "{} rising, {} falling", up.len(), down.len());
    let (mu, md) = (mean(up.iter().copied()), mean(down.iter().copied()));
    assert!((mu + 6.0).abs() < 0.6, "rising offset {mu}");
    assert!((md - 6.0).abs() < 0.6, "falling offset {md}");
    // And the offset never exceeds the half-width plus Eq. 9's small terms.
    assert!(h.iter().all(|v| v.abs() < 6.0 + 1.5));
}

#[test]
fn switching_an_effect_off_removes_exactly_its_contribution() {
    let base = Preset::Paper.config();
    let full = simulate(&base, 21);
    for name in EFFECT_NAMES {
        let mut c = base.clone();
        match name {
            "hysteresis" => c.hysteresis.enabled = false,
            "scan" => c.scan.enabled = false,
            "drift" => c.drift.enabled = false,
            "electronics" => c.electronics.enabled = false,
            "noise" => c.noise.enabled = false,
            _ => unreachable!(),
        }
        let off = simulate(&c, 21);
        let contrib = full.effects.by_name(name).unwrap();
        assert!(contrib[0].iter().any(|v| *v != 0.0), "{name} contributes nothing");
        for (g, contrib_g) in contrib.iter().enumerate() {
            assert_eq!(contrib_g.len(), full.data.len(), "{name}: channel {g}");
            for (i, &part) in contrib_g.iter().enumerate() {
                let diff = full.data.dl_pm[g][i] - off.data.dl_pm[g][i];
                assert!(
                    (diff - part).abs() < 1e-9,
                    "{name}: channel {g} sample {i}: removed {diff}, contribution {part}"
                );
            }
            // Everything else is untouched: the measurands and the other effects.
            assert_eq!(full.effects.physics[g], off.effects.physics[g]);
        }
        assert_eq!(full.data.target(0).as_slice(), off.data.target(0).as_slice());
        assert_eq!(full.data.t_amb_c, off.data.t_amb_c);
    }
}

#[test]
fn measured_shift_is_the_sum_of_its_parts() {
    let s = simulate(&Preset::Harsh.config(), 1);
    let e = &s.effects;
    for g in 0..3 {
        for i in (0..s.data.len()).step_by(101) {
            let sum = e.physics[g][i]
                + e.hysteresis[g][i]
                + e.scan[g][i]
                + e.drift[g][i]
                + e.electronics[g][i]
                + e.noise[g][i];
            assert!((sum - s.data.dl_pm[g][i]).abs() < 1e-9);
        }
    }
}

#[test]
fn oracle_floor_is_set_by_noise_only() {
    let s = simulate(&Preset::Paper.config(), 7);
    let o = s.oracle_floor();
    // Noise ≈ 1.3 pm per channel through the inverse gauge matrix.
    assert!(o.rmse_holdout[0] > 0.05 && o.rmse_holdout[0] < 0.3, "{:?}", o.rmse_holdout);
    assert!(o.rmse_holdout[1] > 0.5 && o.rmse_holdout[1] < 4.0);
    assert!(o.rmse_holdout[2] > 0.5 && o.rmse_holdout[2] < 4.0);
    // Without noise the oracle is exact.
    let mut c = Preset::Paper.config();
    c.noise.enabled = false;
    let o = simulate(&c, 7).oracle_floor();
    assert!(o.rmse_holdout.iter().all(|v| *v < 1e-8), "{:?}", o.rmse_holdout);
}

#[test]
fn harsh_hold_out_leaves_the_calibration_temperature_range() {
    let s = simulate(&Preset::Harsh.config(), 7);
    let d = &s.data;
    let cal_max = d.cal_indices().iter().map(|&i| d.target(0).as_slice()[i]).fold(f64::MIN, f64::max);
    let above = d.holdout_indices().iter().filter(|&&i| d.target(0).as_slice()[i] > cal_max).count();
    assert!(above > d.holdout_indices().len() / 3, "{above} hold-out samples above the calibration range");
}

#[test]
fn csv_round_trips_and_bad_cells_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.csv");
    let s = simulate(&Preset::Paper.config(), 7);
    s.data.write_csv(&p).unwrap();
    let back = fbg_trainer::data::Dataset::read_csv(&p).unwrap();
    assert_eq!(back.len(), s.data.len());
    assert!((back.dl_pm[2][100] - s.data.dl_pm[2][100]).abs() < 1e-6);
    assert_eq!(back.split, s.data.split);

    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[5] = lines[5].replacen(",cal", ",banana", 1);
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, lines.join("\n")).unwrap();
    let e = fbg_trainer::data::Dataset::read_csv(&bad).unwrap_err().to_string();
    assert!(e.contains("bad.csv") && e.contains("line 6") && e.contains("split"), "{e}");

    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut cells: Vec<&str> = lines[3].split(',').collect();
    cells[6] = "x1";
    lines[3] = cells.join(",");
    std::fs::write(&bad, lines.join("\n")).unwrap();
    let e = fbg_trainer::data::Dataset::read_csv(&bad).unwrap_err().to_string();
    assert!(e.contains("line 4") && e.contains("dl2_pm") && e.contains("x1"), "{e}");

    std::fs::write(&bad, "t_s,T_C\n1,2\n").unwrap();
    let e = fbg_trainer::data::Dataset::read_csv(&bad).unwrap_err().to_string();
    assert!(e.contains("missing column `dl1_pm`"), "{e}");
    // The ambient thermometer is optional in a dataset, required by a model that reads it.
    std::fs::write(&bad, "t_s,T_C,dl1_pm,dl2_pm,dl3_pm\n1,2,3,4,5\n").unwrap();
    let d = fbg_trainer::data::Dataset::read_csv(&bad).unwrap();
    assert!(d.t_amb_c.is_none());
    assert!(!d.dims("bad.csv").unwrap().ambient());
    let e = d.inputs_for(&fbg_shared::layout::Dims::PAPER, "bad.csv", "evaluate").unwrap_err().to_string();
    assert!(e.contains("bad.csv") && e.contains("column T_amb_C") && e.contains("`evaluate`"), "{e}");
}
