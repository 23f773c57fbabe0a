//! The same installation at another pace, the steps record, and the
//! new physics (three hysteresis models, the gratings' package thermal lag, creep and ageing, a
//! quantised thermometer, timestamp jitter and recording gaps, the `field` preset). Every new
//! effect is off unless asked for: the older presets keep their pinned bytes (tests/shapes.rs).

use crate::common;

use common::{bin, run};
use fbg_trainer::data::{Dataset, Kind, Measurand, Split};
use fbg_trainer::sim::package::first_order_lag;
use fbg_trainer::sim::scenario::{HysteresisModel, Preset, ScenarioConfig};
use fbg_trainer::sim::steps::{holds, percentile};
use fbg_trainer::sim::{simulate, trajectories, Simulation, EFFECT_NAMES, PACKAGE_EFFECT_NAMES};
use fbg_trainer::stats::{mean, median, rms, std_dev};

/// Least-squares amplitude of a sine of `period_s` in `y` (mean removed) over the times `t`.
fn amp(t: &[f64], y: &[f64], period_s: f64) -> f64 {
    let m = mean(y.iter().copied());
    let w = std::f64::consts::TAU / period_s;
    let (mut ss, mut cc) = (0.0, 0.0);
    for (&ti, &yi) in t.iter().zip(y) {
        ss += (yi - m) * (w * ti).sin();
        cc += (yi - m) * (w * ti).cos();
    }
    2.0 * (ss * ss + cc * cc).sqrt() / t.len() as f64
}

fn lag1_correlation(x: &[f64]) -> f64 {
    let m = mean(x.iter().copied());
    let var: f64 = x.iter().map(|v| (v - m).powi(2)).sum();
    x.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / var
}

fn csv_bytes(cfg: &ScenarioConfig, seed: u64) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.csv");
    simulate(cfg, seed).data.write_csv(&p).unwrap();
    std::fs::read(p).unwrap()
}

fn reference(s: &Simulation, m: Measurand) -> &[f64] {
    s.data.reference(m).unwrap()
}

#[test]
fn pace_divides_every_period_of_the_measurands() {
    let paper = Preset::Paper.config();
    let native = simulate(&paper, 7);
    let fast = simulate(&paper.paced(4.0, None), 7);
    let slow = simulate(&paper.paced(0.25, None), 7);
    let t = &native.data.t_s;
    // Pressure: the 12 h sine of 25 kPa runs at 3 h, four times faster, and at 48 h slower.
    let p = |s: &Simulation| reference(s, Measurand::P).to_vec();
    assert!((amp(t, &p(&native), 43_200.0) - 25.0).abs() < 1.0);
    assert!((amp(t, &p(&fast), 43_200.0 / 4.0) - 25.0).abs() < 1.0, "{}", amp(t, &p(&fast), 10_800.0));
    assert!(amp(t, &p(&fast), 43_200.0) < 1.5);
    assert!((amp(t, &p(&slow), 43_200.0 * 4.0) - 25.0).abs() < 1.0);
    assert!(amp(t, &p(&slow), 43_200.0) < 1.5);
    // Temperature: the diurnal 4 °C sine at 6 h.
    let temp = reference(&fast, Measurand::T);
    assert!((amp(t, temp, 21_600.0) - 4.0).abs() < 0.1, "{}", amp(t, temp, 21_600.0));
    assert!(amp(t, temp, 86_400.0) < 0.3);
    // Strain: with the (paced) load steps removed, the 3 h sine of 60 µε at 45 min.
    let steps = trajectories::load_steps(&paper.strain.paced(4.0), t, 7);
    let e: Vec<f64> = reference(&fast, Measurand::STRAIN).iter().zip(&steps).map(|(e, l)| e - l).collect();
    assert!((amp(t, &e, 2_700.0) - 60.0).abs() < 1.0, "{}", amp(t, &e, 2_700.0));
    // The AR(1) correlation time too: without the sines, the lag-1 correlation of p is
    // exp(−dt/(τ/4)) instead of exp(−dt/τ).
    let mut quiet = paper.clone();
    quiet.pressure.sine1_amp_kpa = 0.0;
    quiet.pressure.sine2_amp_kpa = 0.0;
    let r_native = lag1_correlation(reference(&simulate(&quiet, 3), Measurand::P));
    let r_fast = lag1_correlation(reference(&simulate(&quiet.paced(4.0, None), 3), Measurand::P));
    assert!((r_native - (-60.0f64 / 1800.0).exp()).abs() < 0.01, "{r_native}");
    assert!((r_fast - (-60.0f64 / 450.0).exp()).abs() < 0.02, "{r_fast}");
}

#[test]
fn pace_keeps_the_installation_and_the_instrument() {
    let paper = Preset::Paper.config();
    let native = simulate(&paper, 7);
    let only_p = paper.paced(4.0, Some(Measurand::P));
    assert_eq!(only_p.name, "paper@x4(p_kPa)");
    assert_eq!(paper.paced(0.25, None).name, "paper@x0.25");
    assert_eq!(paper.steps().name, "paper@steps");
    // A new pace replaces the earlier one; steps are named once.
    assert_eq!(paper.paced(4.0, None).steps().paced(2.0, None).steps().name, "paper@x2@steps");
    let e2 = Measurand { kind: Kind::Strain, index: 2 };
    let long = Preset::Array8.config().paced(1.0 / 3.0, Some(e2)).steps();
    // Too long for the model blob's 24 bytes: the base name gives way to the suffixes first.
    assert_eq!(long.name, "a@x0.333(strain2_ue)@ste");
    let mid = Preset::StrainPair.config().paced(4.0, Some(Measurand::STRAIN)).steps();
    assert_eq!(mid.name, "stra@x4(strain_ue)@steps");
    assert_eq!(long.validate(), Ok(()));
    let s = simulate(&only_p, 7);
    // Only p moves at the new pace; T (and so the thermometer) and ε are the native ones.
    assert_eq!(reference(&s, Measurand::T), reference(&native, Measurand::T));
    assert_eq!(reference(&s, Measurand::STRAIN), reference(&native, Measurand::STRAIN));
    assert_eq!(s.data.t_amb_c, native.data.t_amb_c);
    assert_ne!(reference(&s, Measurand::P), reference(&native, Measurand::P));
    for cfg in [only_p, paper.paced(4.0, None), paper.paced(0.25, None)] {
        // The instrument is untouched, the installation the same: dispersed gauge matrix,
        // drift and noise realisations.
        assert_eq!(
            (&cfg.clock, &cfg.ambient, &cfg.hysteresis, &cfg.drift, &cfg.noise, &cfg.gratings),
            (&paper.clock, &paper.ambient, &paper.hysteresis, &paper.drift, &paper.noise, &paper.gratings)
        );
        assert_eq!(cfg.temperature, paper.temperature, "the stored values stay native");
        let s = simulate(&cfg, 7);
        assert_eq!(s.physics, native.physics, "{}", cfg.name);
        assert_eq!(s.effects.drift, native.effects.drift);
        assert_eq!(s.effects.noise, native.effects.noise);
        assert_eq!(s.data.len(), native.data.len());
    }
}

#[test]
fn new_keys_default_off_and_old_files_still_load() {
    // A scenario file written before the new keys existed: the paper preset's dump without
    // them loads as the paper preset.
    let text = toml::to_string(&Preset::Paper.config()).unwrap();
    let new_keys = ["jitter_s", "gaps_per_day", "gap_mean_s", "resolution_c", "thermal_lag_s", "model"];
    let new_tables = ["[hysteresis.bouc_wen]", "[hysteresis.preisach]", "[ageing]", "[pace]", "[steps]", "[plateaus]"];
    let mut old = String::new();
    let mut skipping = false;
    for line in text.lines() {
        if line.starts_with('[') {
            skipping = new_tables.contains(&line.trim());
        }
        let key = line.split('=').next().unwrap_or("").trim();
        if !skipping && !new_keys.contains(&key) {
            old.push_str(line);
            old.push('\n');
        }
    }
    assert!(!old.contains("pace") && !old.contains("jitter"), "{old}");
    let back = ScenarioConfig::from_toml_str(&old, "old.toml").unwrap();
    assert_eq!(back, Preset::Paper.config());
    // The paced and steps configurations round-trip through their dump.
    for cfg in [
        Preset::Paper.config().paced(4.0, Some(Measurand::P)),
        Preset::Field.config().steps(),
        Preset::Array8.config().plateaus(),
    ] {
        let text = toml::to_string(&cfg).unwrap();
        assert!(text.contains("[pace]") && text.contains("[steps]"), "{text}");
        assert_eq!(ScenarioConfig::from_toml_str(&text, "dump.toml").unwrap(), cfg);
    }
}

#[test]
fn plateau_record_rests_every_measurand_on_its_own_schedule() {
    let paper = Preset::Paper.config();
    let native = simulate(&paper, 7);
    let s = simulate(&paper.plateaus(), 7);
    let n_cal = paper.n_cal();
    assert_eq!(s.data.len(), native.data.len());
    assert_eq!(s.physics, native.physics);
    assert!(s.data.split[n_cal..].iter().all(|&x| x == Split::Holdout));
    for (a, b) in s.data.refs.iter().zip(&native.data.refs) {
        assert_eq!(a.values[..n_cal], b.values[..n_cal], "{}", a.measurand);
        // Rests of 4–16 h (one sample a minute) after 10-min ramps: most of the hold-out
        // sits exactly still, inside the calibration part's 5th–95th percentiles.
        let v = &a.values[n_cal..];
        let still = v.windows(2).filter(|w| w[0] == w[1]).count();
        assert!(still as f64 > 0.95 * v.len() as f64, "{}: {still} of {}", a.measurand, v.len());
        let (lo, hi) = (percentile(&a.values[..n_cal], 5.0), percentile(&a.values[..n_cal], 95.0));
        assert!(v[10..].iter().all(|x| (lo..=hi).contains(x)), "{}", a.measurand);
    }
    // Not one schedule for all: the measurands move at different times.
    let moves = |c: usize| -> Vec<usize> {
        let v = &s.data.refs[c].values;
        (n_cal + 1..v.len()).filter(|&i| v[i] != v[i - 1]).collect()
    };
    assert_ne!(moves(0), moves(1));
}

#[test]
fn steps_record_continues_the_calibration_part_with_held_levels() {
    let paper = Preset::Paper.config();
    let native = simulate(&paper, 7);
    let cfg = paper.steps();
    let s = simulate(&cfg, 7);
    // 12 h visits, each level visited twice (from below, from above).
    let (n_cal, hold) = (10_080, 720);
    assert_eq!(s.data.len(), n_cal + 3 * 5 * 2 * hold);
    assert_eq!(cfg.n_samples(), s.data.len());
    assert_eq!(s.physics, native.physics);
    for (a, b) in s.data.refs.iter().zip(&native.data.refs) {
        assert_eq!(a.values[..n_cal], b.values[..n_cal], "{}", a.measurand);
    }
    assert!(s.data.split[..n_cal].iter().all(|&x| x == Split::Cal));
    assert!(s.data.split[n_cal..].iter().all(|&x| x == Split::Holdout));
    assert_eq!(*s.data.t_s.last().unwrap(), (s.data.len() - 1) as f64 * 60.0);

    let found = holds(&s.data);
    assert_eq!(found.len(), 30, "{found:?}");
    // In the dataset's order, each measurand in turn, low, high, second-lowest, …, middle,
    // each level twice in a row.
    let order: Vec<usize> = found.iter().map(|h| h.measurand).collect();
    assert_eq!(order, [[0; 10], [1; 10], [2; 10]].concat());
    for c in 0..3 {
        let cal = &s.data.refs[c].values[..n_cal];
        let (lo, hi) = (percentile(cal, 5.0), percentile(cal, 95.0));
        let all: Vec<f64> = found.iter().filter(|h| h.measurand == c).map(|h| h.level).collect();
        assert!(all.chunks(2).all(|p| p[0] == p[1]), "{all:?}");
        let lv: Vec<f64> = all.iter().step_by(2).copied().collect();
        assert_eq!(lv[0], lo);
        assert!((lv[1] - hi).abs() < 1e-9 * hi.abs().max(1.0));
        assert!(lv[0] < lv[2] && lv[2] < lv[4] && lv[4] < lv[3] && lv[3] < lv[1], "{lv:?}");
        // The first visit of a level comes from below, the second from above: the sample
        // before each hold is below, then above, the level.
        for pair in found.iter().filter(|h| h.measurand == c).collect::<Vec<_>>().chunks(2) {
            let before = |h: &fbg_trainer::sim::steps::Hold| {
                let v = &s.data.refs[c].values;
                let mut i = h.rows.start;
                while v[i - 1] == h.level {
                    i -= 1;
                }
                v[i - 1]
            };
            assert!(before(pair[0]) < pair[0].level && before(pair[1]) > pair[1].level, "{pair:?}");
        }
    }
    for h in &found {
        // The settled last half of a 12 h visit after its two 30 min ramps.
        let held = hold - 60 + 1;
        assert_eq!(h.rows.len(), held - held / 2);
        for (c, r) in s.data.refs.iter().enumerate() {
            let v = &r.values[h.rows.clone()];
            assert!(v.iter().all(|&x| x == v[0]), "{} not held", r.measurand);
            if c == h.measurand {
                assert_eq!(v[0], h.level);
            } else {
                assert_eq!(v[0], median(&r.values[..n_cal]), "{} not at its median", r.measurand);
            }
        }
        // Constant truth, but every instrument artefact still on the readings.
        let dl = &s.data.dl_pm[0][h.rows.clone()];
        assert!(std_dev(dl.iter().copied()) > 0.5);
    }
    // Found again in the CSV, which knows nothing of the scenario.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("steps.csv");
    s.data.write_csv(&p).unwrap();
    let again = holds(&Dataset::read_csv(&p).unwrap());
    assert_eq!(
        again.iter().map(|h| (h.measurand, h.rows.clone())).collect::<Vec<_>>(),
        found.iter().map(|h| (h.measurand, h.rows.clone())).collect::<Vec<_>>()
    );
    assert!(holds(&native.data).is_empty());

    // The field installation, with gaps, jitter and its package: still ≥ 5 levels each.
    let field = simulate(&Preset::Field.config().steps(), 7);
    let found = holds(&field.data);
    for c in 0..3 {
        let mut lv: Vec<f64> = found.iter().filter(|h| h.measurand == c).map(|h| h.level).collect();
        lv.dedup();
        assert!(lv.len() >= 5, "measurand {c}: {lv:?}");
    }
    for h in &found {
        for r in &field.data.refs {
            let v = &r.values[h.rows.clone()];
            assert!(v.iter().all(|&x| x == v[0]));
        }
    }
}

#[test]
fn field_preset_is_deterministic_and_has_its_physics() {
    let cfg = Preset::Field.config();
    assert_eq!(cfg.validate(), Ok(()));
    let a = csv_bytes(&cfg, 7);
    assert_eq!(a, csv_bytes(&cfg, 7));
    assert_ne!(a, csv_bytes(&cfg, 8));
    let text = String::from_utf8(a).unwrap();
    assert_eq!(
        common::csv_body(&text).lines().next().unwrap(),
        "t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split"
    );

    let s = simulate(&cfg, 7);
    let d = &s.data;
    assert_eq!(cfg.hysteresis.model, HysteresisModel::BoucWen);
    assert!(d.len() < cfg.n_samples() && d.len() > cfg.n_samples() * 9 / 10, "{} rows", d.len());
    assert!(d.t_s.windows(2).all(|w| w[1] > w[0]));
    assert!(d.ambient().iter().all(|a| (a / 0.0625 - (a / 0.0625).round()).abs() < 1e-9));
    let e = &s.effects;
    for g in 0..3 {
        assert!(rms(e.thermal_lag[g].iter().copied()) > 0.1, "grating {g}");
        let h = rms(e.hysteresis[g].iter().copied());
        assert!((0.3..=3.0).contains(&h), "grating {g}: hysteresis rms {h} pm");
    }
    assert!(rms(e.creep[0].iter().copied()) > 0.3);
    assert!(e.creep[1].iter().chain(&e.creep[2]).all(|&v| v == 0.0));
    let last = *e.ageing[1].last().unwrap();
    assert!((last - 0.2 * 60.0 * (1.0 - (-14.0f64 / 60.0).exp())).abs() < 0.05, "{last}");
    for g in 0..3 {
        for i in (0..d.len()).step_by(97) {
            let sum: f64 = EFFECT_NAMES.iter().chain(&PACKAGE_EFFECT_NAMES).map(|n| e.by_name(n).unwrap()[g][i]).sum();
            assert!((e.physics[g][i] + sum - d.dl_pm[g][i]).abs() < 1e-9);
        }
    }
    let summary = s.summary();
    assert!(summary["effect_rms_pm"]["creep"].is_array() && summary["rows_dropped_in_gaps"].as_u64() > Some(0));
    let paper = simulate(&Preset::Paper.config(), 7).summary();
    assert!(paper["effect_rms_pm"].get("creep").is_none() && paper.get("rows_dropped_in_gaps").is_none());
    assert!(s.oracle_floor().rmse_holdout.iter().all(|v| v.is_finite()));
}

#[test]
fn gaps_drop_rows_of_the_same_installation_and_jitter_moves_only_the_times() {
    let paper = Preset::Paper.config();
    let full = simulate(&paper, 7);
    let mut cfg = paper.clone();
    cfg.clock.gaps_per_day = 3.0;
    cfg.clock.gap_mean_s = 1800.0;
    let s = simulate(&cfg, 7);
    let d = &s.data;
    assert!(d.len() < full.data.len() - 100, "{} rows", d.len());
    assert!(d.t_s.windows(2).all(|w| w[1] > w[0]));
    assert!(d.t_s.windows(2).any(|w| w[1] - w[0] > 600.0), "no gap in t_s");
    assert_eq!(s.grid_rows.len(), d.len());
    for (r, &i) in s.grid_rows.iter().enumerate().step_by(7) {
        assert_eq!(d.t_s[r], full.data.t_s[i]);
        assert_eq!(d.split[r], full.data.split[i]);
        assert_eq!(d.truth(r), full.data.truth(i));
        assert_eq!(d.ambient()[r], full.data.ambient()[i]);
        assert_eq!(s.ambient_true_c[r], full.ambient_true_c[i]);
        for g in 0..3 {
            assert_eq!(d.dl_pm[g][r], full.data.dl_pm[g][i]);
            for name in EFFECT_NAMES.iter().chain(&PACKAGE_EFFECT_NAMES) {
                assert_eq!(s.effects.by_name(name).unwrap()[g][r], full.effects.by_name(name).unwrap()[g][i]);
            }
            assert_eq!(s.effects.physics[g][r], full.effects.physics[g][i]);
        }
    }
    // The split stays by time.
    let cal_end = 10_080.0 * 60.0;
    assert!(d.t_s.iter().zip(&d.split).all(|(&t, &x)| (x == Split::Cal) == (t < cal_end)));
    let o = s.oracle_floor();
    assert!(o.rmse_holdout.iter().chain(&o.rmse_cal).all(|v| v.is_finite() && *v > 0.0));

    let mut cfg = paper.clone();
    cfg.clock.jitter_s = 2.0;
    let j = simulate(&cfg, 7);
    assert!(j.data.t_s.windows(2).all(|w| w[1] > w[0]));
    assert_eq!(j.data.dl_pm, full.data.dl_pm);
    let dev: Vec<f64> = j.data.t_s.iter().zip(&full.data.t_s).map(|(a, b)| a - b).collect();
    assert!((rms(dev.iter().copied()) - 2.0).abs() < 0.1);
}

#[test]
fn every_hysteresis_model_reads_low_rising_and_high_falling() {
    for model in [HysteresisModel::Eq9Play, HysteresisModel::BoucWen, HysteresisModel::Preisach] {
        let mut c = Preset::Paper.config();
        c.hysteresis.model = model;
        let s = simulate(&c, 5);
        let x = &s.effects.physics[0];
        let h = &s.effects.hysteresis[0];
        let (up, down) = common::on_long_moves(x, h);
        let (mu, md) = (mean(up.iter().copied()), mean(down.iter().copied()));
        assert!(mu < md - 1.0, "{model:?}: rising {mu}, falling {md}");
        assert!(h.iter().all(|v| v.abs() < 8.0), "{model:?}");
    }
}

#[test]
fn package_lag_creep_and_thermometer_resolution() {
    let paper = Preset::Paper.config();
    let native = simulate(&paper, 3);
    let mut c = paper.clone();
    c.gratings.thermal_lag_s = vec![0.0, 0.0, 3600.0];
    c.ageing.creep_fraction = vec![0.02, 0.0, 0.0];
    c.ambient.resolution_c = 0.0625;
    let s = simulate(&c, 3);
    // The references stay the structure's.
    assert_eq!(s.data.refs, native.data.refs);
    assert_eq!(s.effects.physics, native.effects.physics);
    let temp = reference(&s, Measurand::T);
    let strain = reference(&s, Measurand::STRAIN);
    let k = &s.physics.k;
    // Grating 3 reads its lagged temperature: K_T·(T_lag − T) plus the small cross-terms.
    let lagged = first_order_lag(temp, 3600.0, 60.0);
    for i in (0..s.data.len()).step_by(101) {
        let want = k[2][0] * (lagged[i] - temp[i]);
        assert!((s.effects.thermal_lag[2][i] - want).abs() < 0.05 * want.abs() + 0.05, "sample {i}");
    }
    assert!(s.effects.thermal_lag[0].iter().chain(&s.effects.thermal_lag[1]).all(|&v| v == 0.0));
    // Grating 1 loses 2 % of the strain, through the 2-day creep lag.
    let creep = first_order_lag(strain, 2.0 * 86_400.0, 60.0);
    for i in (0..s.data.len()).step_by(101) {
        let want = -k[0][1] * 0.02 * creep[i];
        assert!((s.effects.creep[0][i] - want).abs() < 0.05, "sample {i}: {} vs {want}", s.effects.creep[0][i]);
    }
    // The thermometer reads in steps of 0.0625 °C, within half a step of the unquantised one.
    for (q, a) in s.data.ambient().iter().zip(native.data.ambient()) {
        assert!((q / 0.0625 - (q / 0.0625).round()).abs() < 1e-9 && (q - a).abs() <= 0.03125 + 1e-12);
    }
}

#[test]
fn bad_values_of_the_new_keys_name_the_key() {
    let cases = [
        ("[clock]\njitter_s = -1.0\n", "clock.jitter_s"),
        ("[clock]\ngaps_per_day = -1.0\n", "clock.gaps_per_day"),
        ("[clock]\ngap_mean_s = -5.0\n", "clock.gap_mean_s"),
        ("[clock]\ngaps_per_day = 100.0\ngap_mean_s = 3600.0\n", "clock.gap_mean_s"),
        ("[clock]\njitter_s = \"x\"\n", "clock.jitter_s"),
        ("[ambient]\nresolution_c = -0.1\n", "ambient.resolution_c"),
        ("[gratings]\nthermal_lag_s = [1.0]\n", "gratings.thermal_lag_s"),
        ("[gratings]\nthermal_lag_s = [1.0, -2.0, 3.0]\n", "gratings.thermal_lag_s[1]"),
        ("[hysteresis]\nmodel = \"foo\"\n", "hysteresis.model"),
        ("[hysteresis.bouc_wen]\na = 0.0\n", "hysteresis.bouc_wen.a"),
        ("[hysteresis.bouc_wen]\nbeta = -1.0\n", "hysteresis.bouc_wen.beta"),
        ("[hysteresis.bouc_wen]\ngamma = 0.5\n", "hysteresis.bouc_wen.gamma"),
        ("[hysteresis.bouc_wen]\nn = 0.5\n", "hysteresis.bouc_wen.n"),
        ("[hysteresis.bouc_wen]\nalpha = 0.5\n", "alpha"),
        ("[hysteresis.preisach]\nloop_width_pm = -1.0\n", "hysteresis.preisach.loop_width_pm"),
        ("[hysteresis.preisach]\nhi_pm = -400.0\n", "hysteresis.preisach.hi_pm"),
        ("[hysteresis.preisach]\nlo_pm = 1e9\n", "hysteresis.preisach.lo_pm"),
        ("[hysteresis.preisach]\ncells = 1\n", "hysteresis.preisach.cells"),
        ("[hysteresis.preisach]\nweights = \"normal\"\n", "hysteresis.preisach.weights"),
        ("[hysteresis.preisach]\nsigma_pm = 0.0\n", "hysteresis.preisach.sigma_pm"),
        ("[ageing]\ncreep_fraction = [0.9, 0.0, 0.0]\n", "ageing.creep_fraction[0]"),
        ("[ageing]\ncreep_fraction = [0.01]\n", "ageing.creep_fraction"),
        ("[ageing]\ncreep_tau_s = 0.0\n", "ageing.creep_tau_s"),
        ("[ageing]\ndrift_pm_per_day = [1.0, 2.0]\n", "ageing.drift_pm_per_day"),
        ("[ageing]\ndrift_pm_per_day = [1.0, 2.0, 1e6]\n", "ageing.drift_pm_per_day[2]"),
        ("[ageing]\nageing_tau_days = 0.0\n", "ageing.ageing_tau_days"),
        ("[ageing]\ncreep = 0.1\n", "creep"),
        ("[pace]\nfactor = 0.0\n", "pace.factor"),
        ("[pace]\nfactor = -2.0\n", "pace.factor"),
        ("[pace]\nonly = \"T2_C\"\n", "pace.only"),
        ("[pace]\nonly = \"banana\"\n", "pace.only"),
        ("[pace]\nspeed = 2.0\n", "speed"),
        ("[steps]\nlevels = 4\n", "steps.levels"),
        ("[steps]\nlevels = -1\n", "steps.levels"),
        ("[steps]\nenabled = true\nhold_s = 60.0\n", "steps.hold_s"),
        ("[steps]\nramp_s = 50000.0\n", "steps.ramp_s"),
        ("[steps]\nenabled = true\nlevels = 1000\nhold_s = 1e7\nramp_s = 0.0\n", "steps.hold_s"),
        ("[steps]\nlevel = 5\n", "level"),
        ("[plateaus]\nenabled = true\nhold_min_s = 60.0\n", "plateaus.hold_min_s"),
        ("[plateaus]\nhold_min_s = 7200.0\nhold_max_s = 3600.0\n", "plateaus.hold_max_s"),
        ("[plateaus]\nramp_s = 7200.0\n", "plateaus.ramp_s"),
        ("[plateaus]\nenabled = true\n[steps]\nenabled = true\n", "plateaus.enabled"),
    ];
    for (text, key) in cases {
        let e = ScenarioConfig::from_toml_str(text, "bad.toml").unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains(key), "{text:?}: {e}");
    }
}

#[test]
fn the_command_line_paces_steps_and_dumps_the_native_values() {
    let dir = tempfile::tempdir().unwrap();
    let (a, toml) = (dir.path().join("a.csv"), dir.path().join("a.toml"));
    let (ok, _, err) = run(bin()
        .args(["simulate", "--pace", "4", "--pace-of", "p_kPa", "--out"])
        .arg(&a)
        .arg("--dump-config")
        .arg(&toml));
    assert!(ok && err.contains("paper@x4(p_kPa)"), "{err}");
    let dumped = std::fs::read_to_string(&toml).unwrap();
    assert!(dumped.contains("[pace]\nfactor = 4.0\nonly = \"p_kPa\""), "{dumped}");
    assert!(dumped.contains("sine1_period_s = 43200.0"), "the native period is stored: {dumped}");
    // The dump reproduces the record.
    let b = dir.path().join("b.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--config"]).arg(&toml).arg("--out").arg(&b));
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());

    let c = dir.path().join("c.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--preset", "field", "--steps", "--out"]).arg(&c));
    assert!(ok && err.contains("field@steps"), "{err}");
    assert!(!holds(&Dataset::read_csv(&c).unwrap()).is_empty());

    for (args, words) in [
        (vec!["--pace-of", "p_kPa"], "--pace"),
        (vec!["--pace", "0"], "--pace: 0 is out of range [0.001, 1000]"),
        (vec!["--pace", "2", "--pace-of", "strain2_ue"], "pace.only"),
        (vec!["--pace", "2", "--pace-of", "banana"], "banana"),
    ] {
        let (ok, _, err) = run(bin().arg("simulate").args(&args).arg("--out").arg(dir.path().join("x.csv")));
        assert!(!ok && err.contains(words) && !err.contains("panicked"), "{args:?}: {err}");
    }
}
