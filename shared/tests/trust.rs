//! The second rule of the model (DESIGN §4, [`fbg_shared::trust`]): the gate of the memory
//! state and the fade to Model-P, in both precisions.
//!
//! The model is the test kit's synthetic installation with every memory slot in use
//! (`synthetic_params`), given a trust spec measured on its own clean samples the way the
//! trainer measures it (largest |Δx|/Δt between consecutive samples); nothing here was tuned on
//! the assertions' outcomes.

use fbg_shared::compensator::SwingFilter;
use fbg_shared::layout::{pad, MAX_GRATINGS};
use fbg_shared::{Compensator, Estimate, Flags, ModelParams, Real, Sample, TrustSpec};
use fbg_testkit::installation::{samples, synthetic_params, MAX_K};

type Params = ModelParams<f64, MAX_K>;

/// The largest |Δx|/Δt of each envelope input over `s` (what `fit::trust::spec` measures).
fn rates(s: &[Sample<f32>]) -> [f64; 9] {
    let mut r = [0.0f64; 9];
    for w in s.windows(2) {
        let dt = f64::from(w[1].t_s - w[0].t_s);
        for (g, rg) in r.iter_mut().enumerate().take(3) {
            *rg = rg.max(f64::from(w[1].dl_pm[g] - w[0].dl_pm[g]).abs() / dt);
        }
        r[3] = r[3].max(f64::from(w[1].t_amb_c - w[0].t_amb_c).abs() / dt);
    }
    r
}

/// The synthetic model with a trust spec from its own clean stream: rate limits, a quiet time
/// of `quiet_s` on every grating, and a fallback band wider than its own.
fn trusted(quiet_s: f64) -> (Params, Vec<Sample<f32>>) {
    let mut p = synthetic_params(16, 11).unwrap();
    let clean = samples(1500, 3);
    let r = rates(&clean);
    let mut t = TrustSpec::off();
    t.rate_max[..4].copy_from_slice(&r[..4]);
    t.quiet_max_s = pad(&[quiet_s; 3]);
    for o in 0..3 {
        t.fallback_var[o] = 4.0 * p.band_k[o] * p.band_k[o] * p.resid_var[o];
    }
    p.trust = t;
    p.validate().unwrap();
    (p, clean)
}

/// Model-P of `p`: its core alone (no memory terms, no centres), what Model-H falls back to.
fn model_p(p: &Params) -> Params {
    let mut pp = fbg_testkit::installation::without_memory(p.clone());
    pp.centres.clear();
    pp.var_inv_g = [0.0; fbg_shared::layout::VAR_RANK];
    pp.var_inv_g_tail = 0.0;
    pp.hyper.feature_set = fbg_shared::FeatureSet::Paper;
    pp
}

fn run<F: Real>(p: &Params, s: &[Sample<f32>]) -> Vec<Estimate<F>> {
    let mut c = Compensator::<F, MAX_K>::new(p).unwrap();
    s.iter().map(|x| c.step(&x.cast())).collect()
}

/// The glitches of the glitch study: a DS18B20's power-on and error values, 1e300, NaN.
const GLITCHES: [f64; 4] = [85.0, -127.0, 1e300, f64::NAN];

/// The glitches of input `input` at row `at` of `clean`: the thermometer gets the study's
/// values; a grating's 85 and −127 pm may be readings (this installation's grating 1 steps by
/// ±72 pm from one sample to the next), so it gets jumps of twenty times its largest clean step
/// either way (a jump no installation makes in one Δt), 1e300 and NaN.
fn glitches(clean: &[Sample<f32>], input: usize, at: usize) -> [f64; 4] {
    if input == 3 {
        return GLITCHES;
    }
    let step = clean[1..].iter().zip(clean).map(|(a, b)| (a.dl_pm[input] - b.dl_pm[input]).abs()).fold(0.0, f32::max);
    let v = f64::from(clean[at].dl_pm[input]);
    [v + 20.0 * f64::from(step), v - 20.0 * f64::from(step), 1e300, f64::NAN]
}

fn glitched(clean: &[Sample<f32>], at: usize, input: usize, v: f64) -> Vec<Sample<f32>> {
    let mut s = clean.to_vec();
    if input < 3 {
        s[at].dl_pm[input] = v as f32;
    } else {
        s[at].t_amb_c = v as f32;
    }
    s
}

fn glitch_leaves_no_trace<F: Real>() {
    let (p, clean) = trusted(1e9);
    let base = run::<F>(&p, &clean);
    assert!(base.iter().all(|e| e.flags.is_ok()), "a clean stream is never refused");
    let at = 700;
    for input in 0..4 {
        for v in glitches(&clean, input, at) {
            // In f32, 1e300 is +∞: refused as non-finite, as NaN.
            let est = run::<F>(&p, &glitched(&clean, at, input, v));
            assert!(est[at].flags.is_fault(), "input {input} glitch {v}: row not flagged ({})", est[at].flags);
            for (k, (e, c)) in est.iter().zip(&base).enumerate() {
                if k == at {
                    continue;
                }
                for o in 0..3 {
                    let d = (e.values[o] - c.values[o]).to_f64().abs();
                    let b = c.band95[o].to_f64();
                    // Later rows are the clean stream's but for the one Δt the skipped
                    // sample lengthens (the low-passes step over it): within the band.
                    assert!(d <= b, "input {input} glitch {v}: row {k} output {o} moved {d} (band {b})");
                }
            }
        }
    }
}

#[test]
fn a_glitch_is_flagged_and_leaves_later_rows_as_they_were_f64() {
    glitch_leaves_no_trace::<f64>();
}

#[test]
fn a_glitch_is_flagged_and_leaves_later_rows_as_they_were_f32() {
    glitch_leaves_no_trace::<f32>();
}

#[test]
fn a_refused_sample_reads_model_p_and_says_so() {
    let (p, clean) = trusted(1e9);
    let s = glitched(&clean, 400, 3, 85.0);
    let est = run::<f64>(&p, &s);
    let e = &est[400];
    assert!(e.flags.contains(Flags::OUT_OF_ENVELOPE.union(Flags::FALLBACK)), "{}", e.flags);
    // Model-P's answer: the same model without memory and centres on the same sample.
    let pp = model_p(&p);
    let mut cp = Compensator::<f64, MAX_K>::new(&pp).unwrap();
    let ep = cp.step(&s[400].cast());
    for o in 0..3 {
        assert_eq!(e.values[o], ep.values[o], "output {o}");
        let want = (p.trust.fallback_var[o]).sqrt() * p.hyper.flagged_band_factor;
        assert!((e.band95[o] - want).abs() <= 1e-9 * want, "output {o}: band {} want {want}", e.band95[o]);
    }
}

#[test]
fn a_real_step_is_let_in_once_time_allows_it() {
    // A lasting jump of 90 pm on grating 2 towards the middle of its envelope (inside the
    // widened envelope, faster than ten times any clean step of it): refused at first, let in
    // once the rate limit × elapsed time covers it; the gate cannot lock a stream out.
    let (p, clean) = trusted(1e9);
    let jump =
        f64::from(clean[1..].iter().zip(&clean).map(|(a, b)| (a.dl_pm[1] - b.dl_pm[1]).abs()).fold(0.0, f32::max));
    let mut s = clean.clone();
    let step = if s[500].dl_pm[1] > 0.0 { -90.0 } else { 90.0 };
    assert!(90.0 > 10.0 * jump * 1.01, "the clean stream steps by {jump} pm");
    for x in s.iter_mut().skip(500) {
        x.dl_pm[1] += step;
    }
    let est = run::<f64>(&p, &s);
    assert!(est[500].flags.contains(Flags::FALLBACK));
    let back = est.iter().skip(500).position(|e| !e.flags.contains(Flags::FALLBACK)).unwrap();
    assert!(back > 0 && back < 60, "let in after {back} samples");
}

/// Each grating's largest quiet time over `s` through `p`'s memory bank (what the trainer
/// measures on a calibration batch).
fn quiet_max(p: &Params, s: &[Sample<f32>]) -> [f64; MAX_GRATINGS] {
    let mut bank = fbg_shared::MemoryBank::<f64>::new(&p.memory, &p.dims);
    let mut q = [0.0f64; MAX_GRATINGS];
    for x in s {
        let x = x.cast::<f64>();
        bank.advance(&x.dl_pm, x.t_amb_c, x.t_s);
        for (g, qg) in q.iter_mut().enumerate().take(3) {
            *qg = qg.max(bank.state().quiet_s(g, x.t_s));
        }
    }
    q
}

#[test]
fn inside_the_quiet_time_the_model_is_bit_identical_to_one_without_a_fade() {
    // The quiet times measured on the stream itself: it never leaves them.
    let (mut p, clean) = trusted(1e9);
    p.trust.quiet_max_s = quiet_max(&p, &clean);
    assert!(p.trust.quiet_max_s[..3].iter().all(|&q| q > 0.0 && q < 1e6), "{:?}", p.trust.quiet_max_s);
    let mut off = p.clone();
    off.trust.quiet_max_s = [0.0; MAX_GRATINGS];
    let (a, b) = (run::<f32>(&p, &clean), run::<f32>(&off, &clean));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.values, y.values);
        assert_eq!(x.band95, y.band95);
        assert_eq!(x.flags, y.flags);
    }
}

/// Beyond the largest validated lead Model-H keeps its own band, growing with the lead: the
/// same bits whatever that lead is (the band used to decay towards the fallback band there).
#[test]
fn beyond_the_validated_lead_the_band_is_model_hs_own() {
    let (mut p, clean) = trusted(1e9);
    p.resid_var_growth = [1e-6; fbg_shared::layout::MAX_OUTPUTS];
    let first = clean.first().map_or(0.0, |s| f64::from(s.t_s));
    p.t_cal_end_s = first;
    p.field.lead_max_s = 60.0;
    p.validate().unwrap();
    let mut long = p.clone();
    long.field.lead_max_s = 1e9;
    // The stream on the calibration record's clock: its lead is known.
    let on_clock = |p: &Params| {
        let mut c = Compensator::<f64, MAX_K>::new(p).unwrap();
        c.set_clock(fbg_shared::StreamClock::Calibration);
        clean.iter().map(|x| c.step(&x.cast())).collect::<Vec<Estimate<f64>>>()
    };
    let (a, b) = (on_clock(&p), on_clock(&long));
    let last = clean.last().map_or(0.0, |s| f64::from(s.t_s));
    assert!(last - first > 100.0 * 60.0, "the stream reaches far beyond the validated lead");
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.band95, y.band95);
        assert_eq!(x.flags, y.flags);
    }
    // And the band does grow with the lead.
    let (head, tail) = (a.first().map_or(0.0, |e| e.band95[0]), a.last().map_or(0.0, |e| e.band95[0]));
    assert!(tail > head, "{head} → {tail}");
}

#[test]
fn at_rest_beyond_the_quiet_time_the_model_is_model_p() {
    // The stream stops moving after sample 600 (every input held, noise only): once a
    // grating's quiet time passes twice the calibration's, the estimate is Model-P's core
    // and band, flagged FALLBACK and not as a fault.
    let q = 4.0 * 3600.0;
    let (p, clean) = trusted(q);
    let mut s = clean[..600].to_vec();
    let last = s[599];
    let mut rng = fbg_testkit::Rng::new(9);
    for i in 600..1500 {
        let mut x = last;
        for g in 0..3 {
            x.dl_pm[g] += (0.3 * rng.normal()) as f32;
        }
        x.t_s = 60.0 * i as f32;
        s.push(x);
    }
    let est = run::<f64>(&p, &s);
    let pp = model_p(&p);
    let ep = run::<f64>(&pp, &s);
    let faded = (600..1500).filter(|&i| est[i].flags.contains(Flags::FALLBACK)).count();
    assert!(faded > 0, "rest never faded");
    // Twice the quiet time after the last reversal at the latest, the fade is complete.
    for i in 600 + (2.0 * q / 60.0) as usize + 1..1500 {
        assert!(est[i].flags.contains(Flags::FALLBACK) && !est[i].flags.is_fault(), "row {i}: {}", est[i].flags);
        for o in 0..3 {
            assert_eq!(est[i].values[o], ep[i].values[o], "row {i} output {o}");
            let want = p.trust.fallback_var[o].sqrt();
            assert!((est[i].band95[o] - want).abs() <= 1e-9 * want);
        }
    }
    // While the stream still moved, nothing faded.
    assert!(est[..600].iter().all(|e| !e.flags.contains(Flags::FALLBACK)));
}

#[test]
fn the_state_stays_bounded_whatever_arrives() {
    // Garbage of every size, sign and kind for a long stretch: the memory state only ever
    // holds samples inside the widened envelope, so a clean sample afterwards reads a
    // finite value within the output envelope.
    let (p, clean) = trusted(1e9);
    let mut rng = fbg_testkit::Rng::new(5);
    let mut s = clean[..300].to_vec();
    for &c in &clean[300..800] {
        let mut x = c;
        let v = [1e30, -1e30, 1e6, -1e6, 5e3, f64::NAN, f64::INFINITY][rng.next_u64() as usize % 7];
        x.dl_pm[rng.next_u64() as usize % 3] = v as f32;
        x.t_amb_c = if rng.unit() < 0.5 { (v * 0.1) as f32 } else { x.t_amb_c };
        s.push(x);
    }
    s.extend_from_slice(&clean[800..1000]);
    let est = run::<f32>(&p, &s);
    for e in &est[900..1000] {
        assert!(e.values[..3].iter().all(|v| v.is_finite()));
        assert!(!e.flags.contains(Flags::IMPLAUSIBLE), "{}", e.flags);
    }
}

/// The pace filter after every sample of `s` (the filter the gate moves, run as the trainer
/// runs it over a calibration batch).
fn filters(s: &[Sample<f32>]) -> Vec<SwingFilter<f64>> {
    let mut f = SwingFilter::<f64>::new();
    let mut last_t = f64::NAN;
    s.iter()
        .map(|x| {
            let x = x.cast::<f64>();
            let mut v = [0.0; 9];
            v[..3].copy_from_slice(&x.dl_pm[..3]);
            v[3] = x.t_amb_c;
            f.update(&v, 4, x.t_s - last_t);
            last_t = x.t_s;
            f
        })
        .collect()
}

/// Each envelope input's swing power after every sample of `s`.
fn powers(s: &[Sample<f32>]) -> Vec<[f64; 4]> {
    filters(s).iter().map(|f| [f.power(0), f.power(1), f.power(2), f.power(3)]).collect()
}

/// `p` with the pace of `calibration`: each input's largest RMS swing over it.
fn with_pace(p: &Params, calibration: &[Sample<f32>]) -> Params {
    let mut p = p.clone();
    for row in powers(calibration) {
        for (m, v) in p.trust.swing_rms_max.iter_mut().zip(row) {
            *m = m.max(v.sqrt());
        }
    }
    p.validate().unwrap();
    p
}

/// `s` played `pace` times faster, forwards and backwards `legs` times (no jump between legs):
/// the same readings, every interval between them divided by `pace`.
fn faster(s: &[Sample<f32>], pace: f32, legs: usize) -> Vec<Sample<f32>> {
    let dt = (s[1].t_s - s[0].t_s) / pace;
    (0..legs)
        .flat_map(|l| {
            let leg: Vec<Sample<f32>> = if l % 2 == 0 { s.to_vec() } else { s.iter().rev().copied().collect() };
            leg.into_iter().skip(usize::from(l > 0))
        })
        .enumerate()
        .map(|(i, x)| Sample { t_s: s[0].t_s + dt * i as f32, ..x })
        .collect()
}

#[test]
fn at_the_calibration_pace_the_model_is_bit_identical_to_one_without_the_pace_term() {
    let (p, clean) = trusted(1e9);
    let paced = with_pace(&p, &clean);
    assert!(paced.trust.swing_rms_max[..4].iter().all(|&v| v > 0.0), "{:?}", paced.trust.swing_rms_max);
    // The calibration stream itself, in the precision its pace was measured in.
    let (a, b) = (run::<f64>(&paced, &clean), run::<f64>(&p, &clean));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.values, y.values);
        assert_eq!(x.band95, y.band95);
        assert_eq!(x.flags, y.flags);
    }
}

#[test]
fn beyond_the_calibration_pace_model_h_fades_to_model_p_and_the_band_widens_with_the_pace() {
    // The pace measured on the stream played eight times slower, forwards and backwards for
    // eight legs (64 times its length); then the stream at its own pace: eight times the
    // calibration's (the synthetic stream's fastest motions sit near the swing's 5-min corner,
    // so playing it faster still would take them out of the band-pass). Every sample is within
    // the gate's rate limit (set on the stream at its own pace) and let in.
    let (p, clean) = trusted(1e9);
    let paced = with_pace(&p, &faster(&clean, 0.125, 8));
    let fast = clean;
    let (a, b) = (run::<f64>(&paced, &fast), run::<f64>(&p, &fast));
    let pp = model_p(&p);
    let ep = run::<f64>(&pp, &fast);
    let rho_sq: Vec<f64> = powers(&fast)
        .iter()
        .map(|w| (0..4).map(|k| w[k] / paced.trust.swing_rms_max[k].powi(2)).fold(0.0, f64::max))
        .collect();
    let (mut within, mut beyond) = (0, 0);
    for (i, ((x, y), &r2)) in a.iter().zip(&b).zip(&rho_sq).enumerate() {
        if y.flags.is_fault() || y.flags.contains(Flags::FALLBACK) {
            continue;
        }
        if r2 <= 1.0 {
            // Within the calibration's pace: as without the term.
            assert_eq!((x.values, x.band95, x.flags), (y.values, y.band95, y.flags), "row {i}");
            within += 1;
        } else if r2 >= 4.0 + 1e-9 {
            // ρ ≥ 2: Model-P's value, Model-P's band times ρ, flagged as a fallback (no fault).
            assert!(x.flags.contains(Flags::FALLBACK) && !x.flags.is_fault(), "row {i}: {}", x.flags);
            for o in 0..3 {
                assert_eq!(x.values[o], ep[i].values[o], "row {i} output {o}");
                let want = p.trust.fallback_var[o].sqrt() * r2.sqrt();
                assert!((x.band95[o] - want).abs() <= 1e-9 * want, "row {i} output {o}: {} vs {want}", x.band95[o]);
            }
            beyond += 1;
        } else {
            assert!(x.flags.contains(Flags::FALLBACK), "row {i}: ρ² = {r2}");
            assert!(x.band95.iter().zip(&y.band95).take(3).all(|(w, n)| w > n), "row {i}");
        }
    }
    assert!(within > 0 && beyond > 0, "{within} rows within the pace, {beyond} at twice it or more");
}

/// Each envelope input's largest RMS swing and speed over `calibration` (what
/// `fit::trust::spec` measures).
fn pace_maxima(calibration: &[Sample<f32>]) -> ([f64; 4], [f64; 4]) {
    let (mut swing, mut speed) = ([0.0f64; 4], [0.0f64; 4]);
    for f in filters(calibration) {
        for k in 0..4 {
            swing[k] = swing[k].max(f.power(k).sqrt());
            speed[k] = speed[k].max(f.speed_power(k).sqrt());
        }
    }
    (swing, speed)
}

#[test]
fn the_speed_grows_with_the_pace_of_an_oscillation_the_swing_reads_as_its_amplitude() {
    // A 25-min load cycle of 15 pm sampled every 10 s for two days, and the same cycle eight
    // times faster (a 3-min period, 18 samples a period): the swing's band-pass reads the
    // faster one no larger, its speed reads it several times larger.
    let power = |period_s: f64| {
        let mut f = SwingFilter::<f64>::new();
        for i in 0..17_280 {
            let t = 10.0 * i as f64;
            let mut v = [0.0; 9];
            v[0] = 15.0 * (std::f64::consts::TAU * t / period_s).sin();
            f.update(&v, 1, 10.0);
        }
        (f.power(0), f.speed_power(0))
    };
    let ((swing_1, speed_1), (swing_8, speed_8)) = (power(1500.0), power(1500.0 / 8.0));
    assert!(swing_8 <= swing_1, "swing power {swing_8} at ×8 against {swing_1}");
    assert!(speed_8 >= 4.0 * speed_1, "speed power {speed_8} at ×8 against {speed_1}");
}

#[test]
fn a_stream_eight_times_faster_than_the_calibration_fades_to_model_p_by_its_speed() {
    // The pace (swing and speed) measured on the clean stream; then the same readings eight
    // times faster, forwards and backwards for eight legs. The synthetic stream's motions sit
    // near the swing's fast corner, so at ×8 they leave the band-pass: the swing alone
    // would keep most of what Model-H adds; with the speed every row of the second half is
    // Model-P's, flagged as a fallback.
    let (p, clean) = trusted(1e9);
    let (swing, speed) = pace_maxima(&clean);
    let mut paced = p.clone();
    paced.trust.swing_rms_max[..4].copy_from_slice(&swing);
    paced.trust.speed_rms_max[..4].copy_from_slice(&speed);
    paced.validate().unwrap();
    let mut swing_only = paced.clone();
    swing_only.trust.speed_rms_max = [0.0; 9];
    let fast = faster(&clean, 8.0, 8);
    let ep = run::<f64>(&model_p(&p), &fast);
    let half = fast.len() / 2;
    let at_model_p = |e: &[Estimate<f64>]| {
        e[half..]
            .iter()
            .zip(&ep[half..])
            .filter(|(x, y)| x.values[..3] == y.values[..3] && x.flags.contains(Flags::FALLBACK))
            .count()
    };
    let (with_speed, without) = (at_model_p(&run::<f64>(&paced, &fast)), at_model_p(&run::<f64>(&swing_only, &fast)));
    let rows = fast.len() - half;
    assert_eq!(with_speed, rows, "{with_speed} of {rows} rows at Model-P's value with the speed");
    assert!(without < rows / 2, "{without} of {rows} rows at Model-P's value with the swing alone");
}

#[test]
fn a_stream_slower_than_the_calibrations_slowest_fades_to_model_p_by_its_slowness() {
    // The smallest swing measured on the clean stream once its filters had settled (9 h in, as
    // the trainer measures it); then that stream, followed by its readings four times slower,
    // backwards and forwards for four legs. Where the slowness σ is within 1 the estimate is that of the
    // model without the term; at σ ≥ 2 (the stream's first rows among them: no pace yet) it is
    // Model-P's value and band, flagged as a fallback.
    let (p, clean) = trusted(1e9);
    let pw = powers(&clean);
    let settle = clean.iter().position(|x| x.t_s - clean[0].t_s >= 9.0 * 3600.0).unwrap();
    let mut paced = p.clone();
    for k in 0..4 {
        paced.trust.swing_rms_min[k] = pw[settle..].iter().map(|w| w[k]).fold(f64::INFINITY, f64::min).sqrt();
    }
    paced.validate().unwrap();
    // The readings backwards on the clean stream's own (increasing) clock.
    let back: Vec<Sample<f32>> = clean.iter().rev().zip(&clean).map(|(x, t)| Sample { t_s: t.t_s, ..*x }).collect();
    let end = clean[clean.len() - 1].t_s;
    let slow: Vec<Sample<f32>> = clean
        .iter()
        .copied()
        .chain(faster(&back, 0.25, 4).into_iter().skip(1).map(|x| Sample { t_s: x.t_s - back[0].t_s + end, ..x }))
        .collect();
    let (a, b) = (run::<f64>(&paced, &slow), run::<f64>(&p, &slow));
    let ep = run::<f64>(&model_p(&p), &slow);
    let sigma_sq: Vec<f64> = powers(&slow)
        .iter()
        .map(|w| {
            (0..4)
                .map(|k| {
                    let min = paced.trust.swing_rms_min[k].powi(2);
                    if w[k] * 4.0 <= min {
                        4.0
                    } else {
                        min / w[k]
                    }
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let (mut within, mut beyond) = (0, 0);
    for (i, ((x, y), &s2)) in a.iter().zip(&b).zip(&sigma_sq).enumerate() {
        if y.flags.is_fault() || y.flags.contains(Flags::FALLBACK) {
            continue;
        }
        if s2 <= 1.0 {
            assert_eq!((x.values, x.band95, x.flags), (y.values, y.band95, y.flags), "row {i}");
            within += 1;
        } else if s2 >= 4.0 - 1e-12 {
            assert!(x.flags.contains(Flags::FALLBACK) && !x.flags.is_fault(), "row {i}: {}", x.flags);
            for o in 0..3 {
                assert_eq!(x.values[o], ep[i].values[o], "row {i} output {o}");
                let want = p.trust.fallback_var[o].sqrt();
                assert!((x.band95[o] - want).abs() <= 1e-9 * want, "row {i} output {o}: {} vs {want}", x.band95[o]);
            }
            beyond += 1;
        } else {
            assert!(x.flags.contains(Flags::FALLBACK), "row {i}: σ² = {s2}");
        }
    }
    assert!(sigma_sq[1] >= 4.0, "a stream that has just started has no pace: σ² = {}", sigma_sq[1]);
    assert!(within > 0 && beyond > 0, "{within} rows within the calibration's slowest, {beyond} at half it or slower");
    let slow_part = &sigma_sq[clean.len()..];
    let at_half = slow_part.iter().filter(|&&s2| s2 >= 4.0 - 1e-12).count();
    assert!(
        2 * at_half > slow_part.len(),
        "{at_half} of {} rows of the slow part at half the slowest pace or slower",
        slow_part.len()
    );
}
