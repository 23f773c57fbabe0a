//! Static fidelity and the pace study (DESIGN §4, §5): their target rows, the `paper` study and
//! the `field` preset.

use super::*;

/// "7–26" for the runs' seeds.
pub(super) fn seed_range(runs: &[EvalRun]) -> String {
    match (runs.first(), runs.last()) {
        (Some(a), Some(b)) if a.seed != b.seed => format!("{}–{}", a.seed, b.seed),
        (Some(a), _) => a.seed.to_string(),
        _ => "–".into(),
    }
}

/// "**met** on seed 7; **not met** over seeds 7–26 (12 of 20)".
pub(super) fn seeds_verdict(seed7: bool, ok: usize, runs: &[EvalRun]) -> String {
    let n = runs.len();
    let first = runs.first().map_or(7, |r| r.seed);
    if n <= 1 {
        return format!("{} (seed {first})", yes(seed7));
    }
    format!("{} on seed {first}; {} over seeds {} ({ok} of {n})", yes(seed7), yes(ok == n), seed_range(runs))
}

/// The channels of `row` on which Model-H's RMSE exceeds the record's ratio of Model-P's (or is
/// missing), with the gain.
pub(super) fn channels_h_worse(row: &PaceRow, channels: &[String]) -> Vec<String> {
    (0..row.rmse_p.len())
        .filter(|&c| !row.h_within_p_on(c))
        .map(|c| format!("{} {} %", channel(channels, c), f(row.gain_pct(c), 1)))
        .collect()
}

/// The channels of `row` on which Model-H's band coverage is below the pace target.
pub(super) fn channels_low_coverage(row: &PaceRow, channels: &[String]) -> Vec<String> {
    row.coverage_h
        .iter()
        .enumerate()
        .filter(|(_, v)| !at_most(PACE_MIN_COVERAGE, **v))
        .map(|(c, v)| format!("{} {} %", channel(channels, c), f(100.0 * v, 1)))
        .collect()
}

/// Per channel over `rows`, the smallest of `g(row, c)` (NaN when one is missing).
pub(super) fn min_per_channel(rows: &[PaceRow], g: impl Fn(&PaceRow, usize) -> f64) -> Vec<f64> {
    let nc = rows.iter().map(|r| r.rmse_p.len()).max().unwrap_or(0);
    (0..nc).map(|c| fold_nan(rows.iter().map(|r| g(r, c)), f64::min)).collect()
}

/// The target rows of static fidelity and pace: static slopes, pace, `field`.
pub(super) fn pace_targets(s: &mut String, rep: &Report) {
    let tol = 100.0 * SLOPE_TOL;
    let min_cov = 100.0 * PACE_MIN_COVERAGE;
    match rep.pace_paper.as_ref().filter(|p| p.runs.first().is_some_and(|r| r.pace.is_some())) {
        None => out!(
            s,
            "| static fidelity and pace targets (steps record, ×¼, ×4, ×8) | not measured in this BENCHMARKS.json | – | – |"
        ),
        Some(pb) => {
            let run = &pb.runs[0];
            let study = run.pace.as_ref().expect("filtered on");
            let ch = &run.channels;
            let steps = study.steps();
            // Static slopes.
            let seeds_static = pb.runs.iter().filter(|r| r.pace.as_ref().and_then(|p| p.steps()).is_some_and(|x| x.slopes_within(SLOPE_TOL))).count();
            let st = pb.summary.iter().find(|x| !x.max_slope_dev_p.is_empty());
            let over_seeds = st.map_or(String::new(), |x| {
                format!(
                    "; seeds {}: largest \\|slope − 1\\| Model-P {} %, Model-H {} %; within {tol:.0} % on {} of {} seeds",
                    seed_range(&pb.runs),
                    pct(&x.max_slope_dev_p, 2),
                    pct(&x.max_slope_dev_h, 2),
                    seeds_static,
                    pb.runs.len()
                )
            });
            out!(
                s,
                "| static fidelity: on the steps record, \\|slope − 1\\| ≤ {tol:.0} % for every measurand, Model-H and Model-P (`paper`) | seed {} ({} holds; {}): Model-P {}, Model-H {}{} | {} | `{}` |",
                run.seed,
                steps.map_or(0, |x| x.holds),
                channel_names(ch),
                steps.map_or("–".into(), |x| join(&x.slope_p, 4)),
                steps.map_or("–".into(), |x| join(&x.slope_h, 4)),
                over_seeds,
                seeds_verdict(steps.is_some_and(|x| x.slopes_within(SLOPE_TOL)), seeds_static, &pb.runs),
                run.evaluate_command
            );
            // Pace: RMSE.
            let rows = &study.rows;
            let n_rec = rows.len();
            let h_le_p = rows.iter().filter(|r| r.h_within_p()).count();
            let (paced_max, rest_max) = (fbg_report::PACED_RMSE_RATIO_MAX, fbg_report::REST_RMSE_RATIO_MAX);
            let worse: Vec<String> = rows
                .iter()
                .filter(|r| !r.h_within_p())
                .map(|r| format!("{}: {}", r.label, channels_h_worse(r, ch).join(", ")))
                .collect();
            let seeds_rmse =
                pb.runs.iter().filter(|r| r.pace.as_ref().is_some_and(|p| !p.rows.is_empty() && p.rows.iter().all(|x| x.h_within_p()))).count();
            out!(
                s,
                "| pace (`paper`): at ×¼, ×4, ×8 (all measurands, and each alone) and on the steps record, Model-H RMSE ≤ {paced_max} × Model-P on every channel (≤ {rest_max} × on the rest, long-hold and plateau records) | seed {}: on {h_le_p} of {n_rec} records; smallest gain over the records {} % ({}){}; every record on {} of {} seeds | {} | `{}` |",
                run.seed,
                join(&min_per_channel(rows, |r, c| r.gain_pct(c)), 1),
                channel_names(ch),
                if worse.is_empty() { String::new() } else { format!("; Model-H beyond the ratio (gain) on {}", worse.join("; ")) },
                seeds_rmse,
                pb.runs.len(),
                seeds_verdict(h_le_p == n_rec && n_rec > 0, seeds_rmse, &pb.runs),
                run.evaluate_command
            );
            // Pace: coverage.
            let cov_ok = rows.iter().filter(|r| r.coverage_h_at_least(PACE_MIN_COVERAGE)).count();
            let low: Vec<String> = rows
                .iter()
                .filter(|r| !r.coverage_h_at_least(PACE_MIN_COVERAGE))
                .map(|r| format!("{}: {}", r.label, channels_low_coverage(r, ch).join(", ")))
                .collect();
            let seeds_cov = pb
                .runs
                .iter()
                .filter(|r| r.pace.as_ref().is_some_and(|p| !p.rows.is_empty() && p.rows.iter().all(|x| x.coverage_h_at_least(PACE_MIN_COVERAGE))))
                .count();
            out!(
                s,
                "| pace (`paper`): Model-H band coverage ≥ {min_cov:.0} % on every channel, same records | seed {}: on {cov_ok} of {n_rec} records; lowest {} % ({}){}; every record on {} of {} seeds; both pace targets on every record: {} of {} seeds | {} | same runs |",
                run.seed,
                pcts(&min_per_channel(rows, |r, c| r.coverage_h.get(c).copied().unwrap_or(f64::NAN))),
                channel_names(ch),
                if low.is_empty() { String::new() } else { format!("; below on {}", low.join("; ")) },
                seeds_cov,
                pb.runs.len(),
                pb.seeds_pace_targets,
                pb.runs.len(),
                seeds_verdict(cov_ok == n_rec && n_rec > 0, seeds_cov, &pb.runs)
            );
            calibrated_coverage_target(s, "paper", &seed_range(&pb.runs), &pb.summary, ch);
        }
    }
    match rep.field.as_ref().filter(|f| !f.runs.is_empty()) {
        None => out!(s, "| `field` preset targets | not measured in this BENCHMARKS.json | – | – |"),
        Some(fb) => field_targets(s, fb),
    }
}

/// DESIGN §4's calibration of the band on every record of `preset`'s pace study: the mean
/// over the seeds within 95 ± 3 % per channel (too wide counts as much as too narrow).
fn calibrated_coverage_target(s: &mut String, preset: &str, seeds: &str, summary: &[PaceSummary], ch: &[String]) {
    let outside = |v: &f64| (v - 0.95).abs() > 0.03 || v.is_nan();
    let off: Vec<String> = summary
        .iter()
        .filter(|r| r.mean_coverage_h.iter().any(outside))
        .map(|r| format!("{} {} %", r.label, pcts(&r.mean_coverage_h)))
        .collect();
    let (lo, hi) = summary
        .iter()
        .flat_map(|r| &r.mean_coverage_h)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    out!(
        s,
        "| pace (`{preset}`): Model-H band coverage, mean over seeds {seeds} within 95 ± 3 % per channel on every record (DESIGN §4) | record means {} – {} %; outside on {} of {} records ({}): {} | {} | same runs |",
        f(100.0 * lo, 1),
        f(100.0 * hi, 1),
        off.len(),
        summary.len(),
        channel_names(ch),
        if off.is_empty() { "none".to_string() } else { off.join("; ") },
        yes(!summary.is_empty() && off.is_empty())
    );
}

/// The target rows of the `field` preset: never worse than Model-P; the band's coverage.
fn field_targets(s: &mut String, fb: &FieldBench) {
    let n = fb.runs.len();
    let ch = &fb.runs[0].channels;
    out!(
        s,
        "| `field` preset, seeds {}: Model-H never worse than Model-P on any channel | Model-H worse on {} of {n} seeds ({}: {} of {n}); mean gain {} %, smallest {} % | {} | `{}`, then `{}` (each seed) |",
        seed_range(&fb.runs),
        fb.seeds_h_worse_any,
        channel_names(ch),
        slash(&fb.seeds_h_worse),
        join(&fb.mean_gain_pct, 1),
        join(&fb.min_gain_pct, 1),
        yes(fb.seeds_h_worse_any == 0 && n == COVERAGE_SEEDS.len()),
        fb.runs[0].train_command,
        fb.runs[0].evaluate_command
    );
    // The lowest seed's coverage per channel.
    let lowest: Vec<f64> = (0..ch.len())
        .map(|c| fb.runs.iter().map(|r| r.coverage_h.get(c).copied().unwrap_or(f64::NAN)).fold(f64::INFINITY, f64::min))
        .collect();
    let mean_ok = !fb.mean_coverage_h.is_empty() && fb.mean_coverage_h.iter().all(|c| (100.0 * c - 95.0).abs() <= 3.0);
    out!(
        s,
        "| `field` preset, seeds {}: Model-H band coverage, mean within 95 ± 3 % per channel, no seed below 85 % (DESIGN §4) | mean {} % ({}; Model-P {} %), lowest seed {} % | {} | same runs |",
        seed_range(&fb.runs),
        pcts(&fb.mean_coverage_h),
        channel_names(ch),
        pcts(&fb.mean_coverage_p),
        pcts(&lowest),
        yes(mean_ok && lowest.iter().all(|&c| c >= 0.85))
    );
    calibrated_coverage_target(s, "field", &seed_range(&fb.runs), &fb.pace_summary, ch);
}

/// The pace study and the `field` preset (absent from files written before them).
pub(super) fn pace_section(s: &mut String, rep: &Report) {
    if rep.pace_paper.is_none() && rep.field.is_none() {
        return;
    }
    out!(s, "## Static fidelity and pace (`train` + `evaluate --quick`)\n");
    out!(
        s,
        "Each seed as a user runs it: `train` on the simulated record, then `evaluate --quick` (no refit). Its pace study \
         simulates the same installation (same scenario and seed: gratings, drift and noise) with every measurand trajectory \
         ×¼ (four times slower), ×4 and ×8 faster, all measurands at once and each alone, and as a steps record (each measurand \
         held at levels across its range, one at a time), and scores the hold-out of each with the models calibrated at the \
         native pace. The settled slope is the mean reading over the last half of each hold against the held level. \
         Targets: Model-H RMSE ≤ {} × Model-P ({} × on the rest, long-hold and plateau records) and Model-H band coverage ≥ {:.0} % \
         on every channel of every record; \\|slope − 1\\| ≤ {:.0} % for both models. Per-seed figures: `pace_paper` and `field` in BENCHMARKS.json; models in `target/bench/models/`.\n",
        fbg_report::PACED_RMSE_RATIO_MAX,
        fbg_report::REST_RMSE_RATIO_MAX,
        100.0 * PACE_MIN_COVERAGE,
        100.0 * SLOPE_TOL
    );
    if let Some(pb) = &rep.pace_paper {
        pace_paper(s, pb);
    }
    if let Some(fb) = &rep.field {
        field(s, fb);
    }
}

pub(super) fn pace_paper(s: &mut String, pb: &PaceBench) {
    let Some((run, study)) = pb.runs.first().and_then(|r| r.pace.as_ref().map(|p| (r, p))) else {
        out!(s, "No pace study in the `{}` runs.\n", pb.preset);
        return;
    };
    let ch = &run.channels;
    let names = channel_names(ch);
    out!(s, "### Pace study, `{}` preset, seed {}\n", pb.preset, run.seed);
    out!(
        s,
        "| record | hold-out samples | Model-P RMSE ({}) | Model-H RMSE | Model-H below Model-P ({names}) | Model-H band coverage | Model-P band coverage | both pace targets |\n|---|---|---|---|---|---|---|---|",
        channel_units(ch)
    );
    for r in &study.rows {
        out!(
            s,
            "| {} | {} | {} | {} | {} % | {} % | {} % | {} |",
            r.label,
            r.samples,
            rmses(&r.rmse_p, ch),
            rmses(&r.rmse_h, ch),
            gains(&r.rmse_p, &r.rmse_h),
            pcts(&r.coverage_h),
            pcts(&r.coverage_p),
            if r.h_within_p() && r.coverage_h_at_least(PACE_MIN_COVERAGE) { "yes" } else { "**no**" }
        );
    }
    out!(
        s,
        "| native pace (the hold-out of the calibration record) | – | {} | {} | {} % | {} % | {} % | |",
        rmses(&run.rmse_p, ch),
        rmses(&run.rmse_h, ch),
        gains(&run.rmse_p, &run.rmse_h),
        pcts(&run.coverage_h),
        pcts(&run.coverage_p)
    );
    if let Some(st) = study.steps() {
        out!(
            s,
            "\nSettled slopes on the steps record ({} holds; {names}): Model-P **{}**, Model-H **{}** (target within 1 ± {:.2}).",
            st.holds,
            join(&st.slope_p, 4),
            join(&st.slope_h, 4),
            SLOPE_TOL
        );
    }
    if let Some(sf) = &run.static_fidelity {
        out!(
            s,
            "Static gains over the calibration batch (`evaluate`'s `static_fidelity`, settled reading against the truth; {names}): Model-P {}, Model-H {}.",
            join(&sf.gain_p, 4),
            join(&sf.gain_h, 4)
        );
    }
    out!(s, "\n    {}\n    {}\n", run.train_command, run.evaluate_command);
    if pb.runs.len() > 1 {
        out!(s, "### Pace study over the seeds, `{}` preset, seeds {}\n", pb.preset, seed_range(&pb.runs));
        pace_summary_table(s, &pb.summary, ch, pb.runs.len(), pb.seeds_pace_targets);
        glitch_summary(s, &pb.runs);
        out!(
            s,
            "| seed | Model-H below Model-P at the native pace ({names}) | steps slope, Model-P | steps slope, Model-H | records with Model-H beyond its ratio of Model-P | records with Model-H coverage < {:.0} % | both pace targets on every record |\n|---|---|---|---|---|---|---|",
            100.0 * PACE_MIN_COVERAGE
        );
        for r in &pb.runs {
            let Some(p) = &r.pace else { continue };
            let st = p.steps();
            out!(
                s,
                "| {} | {} % | {} | {} | {} of {} | {} of {} | {} |",
                r.seed,
                gains(&r.rmse_p, &r.rmse_h),
                st.map_or("–".into(), |x| join(&x.slope_p, 4)),
                st.map_or("–".into(), |x| join(&x.slope_h, 4)),
                p.rows.iter().filter(|x| !x.h_within_p()).count(),
                p.rows.len(),
                p.rows.iter().filter(|x| !x.coverage_h_at_least(PACE_MIN_COVERAGE)).count(),
                p.rows.len(),
                if pace_targets_met(&p.rows) { "yes" } else { "no" }
            );
        }
        out!(s, "\nCommands: as for seed {} with `paper-s<seed>`.\n", run.seed);
    }
}

/// Per record over the seeds, and the steps record's slopes.
pub(super) fn pace_summary_table(s: &mut String, summary: &[PaceSummary], ch: &[String], n: usize, seeds_all: usize) {
    let names = channel_names(ch);
    out!(
        s,
        "| record | seeds | Model-H within its ratio of Model-P on every channel | mean gain ({names}) | smallest gain | Model-H coverage ≥ {:.0} % on every channel | lowest Model-H coverage |\n|---|---|---|---|---|---|---|",
        100.0 * PACE_MIN_COVERAGE
    );
    for x in summary {
        out!(
            s,
            "| {} | {} | {} of {} | {} % | {} % | {} of {} | {} % |",
            x.label,
            x.seeds,
            x.seeds_h_le_p,
            x.seeds,
            join(&x.mean_gain_pct, 1),
            join(&x.worst_gain_pct, 1),
            x.seeds_coverage_h_90,
            x.seeds,
            pcts(&x.min_coverage_h)
        );
    }
    if let Some(st) = summary.iter().find(|x| !x.max_slope_dev_p.is_empty()) {
        out!(
            s,
            "\nSteps record over the seeds: largest \\|slope − 1\\| Model-P {} %, Model-H {} % ({names}); both models within {:.0} % on every channel on {} of {} seeds.",
            pct(&st.max_slope_dev_p, 2),
            pct(&st.max_slope_dev_h, 2),
            100.0 * SLOPE_TOL,
            st.seeds_slopes_within_1pct,
            st.seeds
        );
    }
    out!(s, "Both pace targets on every record: {seeds_all} of {n} seeds.\n");
}

pub(super) fn field(s: &mut String, fb: &FieldBench) {
    let Some(first) = fb.runs.first() else { return };
    let ch = &first.channels;
    let names = channel_names(ch);
    let n = fb.runs.len();
    out!(s, "### `{}` preset, seeds {}\n", fb.preset, seed_range(&fb.runs));
    out!(
        s,
        "Other physics per effect (`simulate --preset field`): Bouc–Wen hysteresis, thermal lag of the grating packages, \
         creep and ageing of the bonded gratings, a quantised ambient thermometer, jittered sampling and gaps. \
         Hold-out of each seed's own record, at its own pace.\n"
    );
    out!(
        s,
        "| seed | Model-P RMSE ({}) | Model-H RMSE | Model-H below Model-P ({names}) | Model-P band coverage | Model-H band coverage |\n|---|---|---|---|---|---|",
        channel_units(ch)
    );
    for r in &fb.runs {
        out!(
            s,
            "| {} | {} | {} | {} % | {} % | {} % |",
            r.seed,
            rmses(&r.rmse_p, ch),
            rmses(&r.rmse_h, ch),
            gains(&r.rmse_p, &r.rmse_h),
            pcts(&r.coverage_p),
            pcts(&r.coverage_h)
        );
    }
    out!(s, "| **gain mean** | | | **{} %** | | |", join(&fb.mean_gain_pct, 1));
    out!(s, "| gain smallest | | | {} % | | |", join(&fb.min_gain_pct, 1));
    out!(
        s,
        "| seeds with Model-H worse than Model-P | | | {} of {n} (any channel: {} of {n}) | | target: none |",
        slash(&fb.seeds_h_worse),
        fb.seeds_h_worse_any
    );
    out!(
        s,
        "| **coverage mean** | | | | {} % | **{} %** (target 95 ± 3 %, no seed below 85 %) |\n",
        pcts(&fb.mean_coverage_p),
        pcts(&fb.mean_coverage_h)
    );
    out!(s, "    {}\n    {}\n", first.train_command, first.evaluate_command);
    if !fb.pace_summary.is_empty() {
        out!(s, "Pace study of the `{}` seeds (same records as for `paper`; no target):\n", fb.preset);
        pace_summary_table(s, &fb.pace_summary, ch, n, fb.seeds_pace_targets);
    }
}

/// The glitch study over the seeds: how many glitch rows were flagged and how many later rows
/// moved by more than their band, for the glitches the gate must catch and for the rest.
fn glitch_summary(s: &mut String, runs: &[EvalRun]) {
    let cases: Vec<&GlitchRow> = runs.iter().filter_map(|r| r.pace.as_ref()).flat_map(|p| p.glitch.iter()).collect();
    if cases.is_empty() {
        return;
    }
    let (must, other): (Vec<&GlitchRow>, Vec<&GlitchRow>) = cases.iter().partition(|g| g.must_flag());
    let flagged = |v: &[&GlitchRow]| v.iter().filter(|g| g.flagged).count();
    let beyond = |v: &[&GlitchRow]| v.iter().filter(|g| g.rows_beyond_band > 0).count();
    out!(
        s,
        "\nGlitch study (`evaluate`'s, one sample of one input of the hold-out replaced by 85, −127, 1e300 or NaN; {} cases over {} seeds): the thermometer's glitches and the non-finite ones flagged in {} of {} cases, a later row beyond its band in {}; a grating's 85 or −127 pm (which may be a reading) flagged in {} of {}, a later row beyond its band in {}.\n",
        cases.len(),
        runs.len(),
        flagged(&must),
        must.len(),
        beyond(&must),
        flagged(&other),
        other.len(),
        beyond(&other)
    );
}
