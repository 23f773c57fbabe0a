//! BENCHMARKS.md from the [`Report`]: one function per section, in the order of the file.

use std::fmt::Write as _;

use super::pace::{pace_targets_met, PACE_MIN_COVERAGE, SLOPE_TOL};
use super::report::{
    at_most, Accuracy, DeviceResults, EvalRun, FieldBench, FitRun, Fleet, Inference, Machine, PaceBench, PaceRow,
    PaceSummary, PresetRun, Report, Rmse, SizeRun, StepRow, Training,
};
use super::stats::{max_rel_diff, median};
use super::COVERAGE_SEEDS;

/// The `paper` gains of the model before static fidelity (issue 26), printed beside today's: an
/// earlier measurement, not one of this run.
const BEFORE_STATIC_FIDELITY: &str =
    "*earlier measurement, not this run:* before static fidelity (BENCHMARKS at 2f716d4): mean gain 47.9 / 32.2 / 41.9 %";

/// The per-seed coverage target: at least this many coverage seeds within 95 ± 2 %.
const SEEDS_WITHIN_2: usize = 16;

/// `writeln!` into a `String`, which cannot fail.
macro_rules! out {
    ($s:expr) => {{
        let _ = writeln!($s);
    }};
    ($s:expr, $($arg:tt)*) => {{
        let _ = writeln!($s, $($arg)*);
    }};
}

/// A number with `digits` decimals, "–" when missing (NaN) or infinite.
fn f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

/// Seconds with three significant figures.
fn secs(x: f64) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    let d = if x >= 100.0 {
        0
    } else if x >= 10.0 {
        1
    } else if x >= 1.0 {
        2
    } else {
        3
    };
    format!("{x:.d$} s")
}

fn yes(b: bool) -> &'static str {
    if b {
        "**met**"
    } else {
        "**not met**"
    }
}

/// T, ε, p with the decimals that suit each.
fn rmse3(v: &Rmse) -> [String; 3] {
    [f(v[0], 3), f(v[1], 2), f(v[2], 2)]
}

/// Per-round values, "1.23, 4.56".
fn list2(v: &[f64]) -> String {
    v.iter().filter(|x| !x.is_nan()).map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", ")
}

/// A fit's median time, NaN when it did not run (no peer).
fn median_of(run: Option<&FitRun>) -> f64 {
    run.map_or(f64::NAN, |r| r.median)
}

/// The whole file.
pub fn markdown(rep: &Report) -> String {
    let mut s = String::new();
    header(&mut s, rep);
    machine(&mut s, &rep.machine, rep.wall_seconds);
    targets(&mut s, rep);
    training(&mut s, &rep.training, &rep.datasets);
    inference(&mut s, &rep.inference_host);
    accuracy(&mut s, &rep.accuracy);
    pace_section(&mut s, rep);
    device(&mut s, rep);
    fleet(&mut s, &rep.fleet);
    if let Some(m) = &rep.memory {
        super::memory::markdown(&mut s, m);
    }
    if let Some(v) = &rep.slurm {
        slurm(&mut s, v);
    }
    s
}

fn header(s: &mut String, rep: &Report) {
    out!(s, "# Benchmarks\n");
    out!(
        s,
        "Written by `cargo xtask bench` (xtask/src/bench/){}; the same numbers are in `BENCHMARKS.json`. \
         Every time is the median of repeated runs (counts below); every ratio compares runs taken side by side, \
         alternating, in the same invocation. Fits are timed inside the release binaries (CSV reading outside the clock).\n",
        if rep.quick { " **with --quick (one repeat: not for publishing)**" } else { "" }
    );
}

fn machine(s: &mut String, m: &Machine, wall_seconds: f64) {
    let or_q = |v: &Option<String>| v.clone().unwrap_or_else(|| "?".into());
    out!(s, "## Machine\n");
    out!(s, "| | |\n|---|---|");
    out!(s, "| CPU | {} ({} cores), {} RAM |", m.cpu, m.cores, or_q(&m.memory));
    out!(s, "| OS | {} |", m.os);
    out!(s, "| Rust | {} |", m.rustc);
    match &m.scikit_learn {
        Some(v) => out!(
            s,
            "| Python peer | Python {}, numpy {}, scikit-learn {} (venv `target/bench/venv`, `pip install scikit-learn numpy`) |",
            or_q(&m.python),
            or_q(&m.numpy),
            v
        ),
        None => out!(
            s,
            "| Python peer | **skipped**: {} |",
            m.peer_skipped_because.as_deref().unwrap_or("python3/venv/pip unavailable")
        ),
    }
    out!(s, "| QEMU | {} |", m.qemu);
    let dirty = &m.git.modified_files;
    out!(
        s,
        "| source | commit {}{} |",
        m.git.commit,
        if dirty.is_empty() { String::new() } else { format!(" with uncommitted changes to {}", dirty.join(", ")) }
    );
    out!(s, "| load average (1/5/15 min) | {} at the start, {} at the end |", m.loadavg_start, m.loadavg_end);
    out!(s, "| whole run | {:.0} s |\n", if wall_seconds.is_finite() { wall_seconds } else { 0.0 });
}

/// The targets of DESIGN §8, one row each.
fn targets(s: &mut String, rep: &Report) {
    out!(s, "## Targets\n");
    out!(s, "| target | measured | verdict | command |\n|---|---|---|---|");
    let acc = &rep.accuracy;
    if let Some(paper) = acc.presets.first() {
        accuracy_targets(s, paper, acc);
    }
    match rep.device_results() {
        Some(dev) => device_targets(s, dev, acc.presets.first()),
        None => out!(
            s,
            "| device targets (inference cost, flash, RAM, blob) | the device bench failed (below) | – | device part |"
        ),
    }
    if let Some(big) = rep.training.sizes.last() {
        let fp = &big.fixed_paper;
        let notebook = fp.notebook.as_ref();
        let peer = fp.peer.as_ref().map(|p| &p.fit);
        let agree = max_rel_diff(&fp.ours.fit.rmse_h, notebook.map_or(&[f64::NAN; 3], |n| &n.rmse_h));
        let agree_sub = max_rel_diff(&fp.ours.fit.rmse_h, peer.map_or(&[f64::NAN; 3], |p| &p.rmse_h));
        let (nb_ratio, ratio) = (fp.notebook_ratio_median, fp.ratio_median);
        let fm = &big.fixed_memory;
        let peer_m = fm.peer.as_ref().map(|p| &p.fit);
        let agree_m = max_rel_diff(&fm.fit.rmse_h, peer_m.map_or(&[f64::NAN; 3], |p| &p.rmse_h));
        out!(
            s,
            "| host training: 1 000 000 samples ≥ 5× faster than the scikit-learn pipeline with the same features, same accuracy | \
             the default model's features (latch RBF + memory terms fitted on what the core leaves): scikit-learn pipeline / ours = **{}×** \
             (rounds: {}; the pipeline computing its own inputs, {} of latch loop and memory terms + {} of fit, as ours computes them inside its {}; \
             fit alone, the inputs handed over: **{}×**, rounds {}; ours includes the cross-validation of the memory menu and of the band, \
             the peer is given the groups and ridge ours chose), Model-H hold-out RMSE within {} %. Paper features: **{}×** against the pipeline as a notebook writes it (`KMeans` with its defaults on every calibration row; ours {} vs {}), \
             RMSE within {:.1} %; **{}×** against the same pipeline given our k-means subsample ({}; RMSE within {:.1} %) | \
             {} with the default features; paper features: {} against the notebook pipeline, {} against the subsampled one | `{}` vs `{}`; `{}` vs `{}` and `{}` |",
            f(fm.pipeline_ratio_median, 2),
            list2(&fm.pipeline_ratio_per_round),
            secs(fm.peer.as_ref().map_or(f64::NAN, |p| p.latch_seconds + p.feature_seconds)),
            secs(median_of(peer_m)),
            secs(fm.fit.median),
            f(fm.ratio_median, 2),
            list2(&fm.ratio_per_round),
            f(100.0 * agree_m, 1),
            f(nb_ratio, 2),
            secs(fp.ours.fit.median),
            secs(median_of(notebook)),
            100.0 * agree,
            f(ratio, 2),
            secs(median_of(peer)),
            100.0 * agree_sub,
            yes(fm.pipeline_ratio_median >= 5.0 && agree_m <= 0.05),
            yes(nb_ratio >= 5.0 && agree <= 0.05),
            yes(ratio >= 5.0 && agree_sub <= 0.05),
            fm.fit.command,
            peer_m.map_or("", |p| &p.command),
            fp.ours.fit.command,
            notebook.map_or("", |n| &n.command),
            peer.map_or("", |p| &p.command)
        );
    }
    if let Some(paper) = acc.presets.first() {
        let covs = paper.model_h_default.coverage.map(|c| 100.0 * c);
        let mean = acc.coverage_paper.mean_h;
        out!(
            s,
            "| band coverage 95 ± 2 % on the `paper` hold-out | seed 7: {:.1} / {:.1} / {:.1} %; mean of seeds 7–26: {:.1} / {:.1} / {:.1} % | {} (seed 7) | accuracy run; coverage runs |",
            covs[0],
            covs[1],
            covs[2],
            100.0 * mean[0],
            100.0 * mean[1],
            100.0 * mean[2],
            yes(covs.iter().all(|c| (c - 95.0).abs() <= 2.0))
        );
        let cp = &acc.coverage_paper;
        let n = cp.per_seed.len();
        let w = cp.seeds_within_95_pm_2;
        let ok = (0..3).all(|c| (100.0 * cp.mean_h[c] - 95.0).abs() <= 1.0 && w[c] >= SEEDS_WITHIN_2);
        let reference = cp.ensemble_band.as_ref().filter(|e| e.channels.len() == 3).map_or(String::new(), |e| {
            format!(
                "; the reference band on the lead time alone, set on all {n} hold-outs at once: {} / {} / {} of {n}",
                e.channels[0].seeds_within_95_pm_2,
                e.channels[1].seeds_within_95_pm_2,
                e.channels[2].seeds_within_95_pm_2
            )
        });
        out!(
            s,
            "| band coverage, seeds {}–{}: mean within 95 ± 1 % per channel, ≥ {SEEDS_WITHIN_2} of {n} seeds within 95 ± 2 % | mean {:.1} / {:.1} / {:.1} %; within ± 2 %: {} / {} / {} of {n}{} | {} | coverage runs (below) |",
            COVERAGE_SEEDS[0],
            COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1],
            100.0 * cp.mean_h[0],
            100.0 * cp.mean_h[1],
            100.0 * cp.mean_h[2],
            w[0],
            w[1],
            w[2],
            reference,
            yes(ok)
        );
    }
    pace_targets(s, rep);
    out!(s);
}

/// Accuracy and parity rows of the targets.
fn accuracy_targets(s: &mut String, paper: &PresetRun, acc: &Accuracy) {
    let h = &paper.model_h_default;
    let gains: Rmse = std::array::from_fn(|c| 100.0 * (1.0 - h.run.rmse[c] / paper.model_p.rmse[c]));
    let over_oracle: Rmse = std::array::from_fn(|c| h.run.rmse[c] / paper.oracle_floor.rmse[c]);
    out!(
        s,
        "| accuracy, `paper` preset: Model-H hold-out RMSE ≥ 25 % below Model-P on every channel | {:.1} / {:.1} / {:.1} % below (T / ε / p); Model-H at {:.2} / {:.2} / {:.2} × the per-sample oracle | {} | `{}` |",
        gains[0],
        gains[1],
        gains[2],
        over_oracle[0],
        over_oracle[1],
        over_oracle[2],
        yes(gains.iter().all(|g| *g >= 25.0)),
        h.run.command
    );
    let g = &acc.gain_paper;
    let (gm, gmin, n_all) = (g.mean_pct, g.min_pct, g.seeds_all_channels_25);
    out!(
        s,
        "| accuracy, `paper` preset, seeds {}–{}: ≥ 25 % on every channel on every seed; mean ≥ 40 / 30 / 40 % (T / ε / p) | mean {:.1} / {:.1} / {:.1} %, smallest {:.1} / {:.1} / {:.1} %; {} of {} seeds ≥ 25 % on every channel | {} | coverage runs (below) |",
        COVERAGE_SEEDS[0],
        COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1],
        gm[0],
        gm[1],
        gm[2],
        gmin[0],
        gmin[1],
        gmin[2],
        n_all,
        COVERAGE_SEEDS.len(),
        yes(n_all == COVERAGE_SEEDS.len() && gm[0] >= 40.0 && gm[1] >= 30.0 && gm[2] >= 40.0)
    );
    let n = g.per_seed.len();
    let seeds_20 = g.per_seed.iter().filter(|v| v.iter().all(|&x| x >= 20.0)).count();
    out!(
        s,
        "| accuracy, `paper` preset, seeds {}–{}, at its own pace (issue 26): ≥ 25 % below Model-P on every channel on the mean, ≥ 20 % on every seed | mean {:.1} / {:.1} / {:.1} %, smallest {:.1} / {:.1} / {:.1} %; {} of {n} seeds ≥ 20 % on every channel; {BEFORE_STATIC_FIDELITY} | {} | coverage runs (below) |",
        COVERAGE_SEEDS[0],
        COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1],
        gm[0],
        gm[1],
        gm[2],
        gmin[0],
        gmin[1],
        gmin[2],
        seeds_20,
        yes(n == COVERAGE_SEEDS.len() && seeds_20 == n && gm.iter().all(|&x| x >= 25.0))
    );
    gb_hybrid_target(s, paper, acc);
    if let Some(harsh) = acc.presets.iter().find(|p| p.preset == "harsh") {
        let (hh, hp) = (harsh.model_h_default.run.rmse, harsh.model_p.rmse);
        out!(
            s,
            "| accuracy, `harsh` preset: Model-H never worse than Model-P on any channel | Model-H {} / {} / {} against Model-P {} / {} / {} (T [°C] / ε [µε] / p [kPa]) | {} | `{}` |",
            f(hh[0], 3),
            f(hh[1], 2),
            f(hh[2], 2),
            f(hp[0], 3),
            f(hp[1], 2),
            f(hp[2], 2),
            yes((0..3).all(|c| hh[c] <= hp[c])),
            harsh.model_h_default.run.command
        );
    }
    let par = &h.parity;
    let pmax = par.max_diff_over_rmse.map(|v| 100.0 * v);
    out!(
        s,
        "| f32 device path vs f64 host: max difference ≤ 1 % of Model-H's RMSE | {:.4} / {:.4} / {:.4} % ({} hold-out samples, {} flag mismatches) | {} | same run |",
        pmax[0],
        pmax[1],
        pmax[2],
        par.samples,
        par.flag_mismatches,
        yes(pmax.iter().all(|p| *p <= 1.0))
    );
}

/// The target "ahead of the gradient-boosting hybrids on every channel": on seed 7 (the peers'
/// table) and over the coverage seeds.
fn gb_hybrid_target(s: &mut String, paper: &PresetRun, acc: &Accuracy) {
    let h = paper.model_h_default.run.rmse;
    let seed7: Vec<_> = paper.blackbox.iter().flat_map(|b| &b.peers).filter(|p| p.is_gb_hybrid()).collect();
    if seed7.is_empty() {
        out!(s, "| accuracy, `paper` preset: ahead of the gradient-boosting hybrids on every channel | no Python peer in this run | – | accuracy run |");
        return;
    }
    let seed7_ok = seed7.iter().all(|p| (0..3).all(|c| h[c] < p.rmse[c]));
    let mut parts: Vec<String> = seed7
        .iter()
        .map(|p| {
            format!(
                "seed 7, against {} ({}): Model-H / hybrid = {} / {} / {}",
                p.inputs,
                p.n_inputs.map_or(String::from("?"), |n| format!("{n} inputs")),
                f(h[0] / p.rmse[0], 3),
                f(h[1] / p.rmse[1], 3),
                f(h[2] / p.rmse[2], 3)
            )
        })
        .collect();
    let mut all_ok = true;
    for g in &acc.gb_hybrids_paper {
        all_ok &= (0..3).all(|c| g.mean_rmse_h[c] < g.mean_rmse_peer[c]);
        parts.push(format!(
            "mean over {} seeds against {}: Model-H {} / {} / {}, hybrid {} / {} / {}; Model-H ahead on {} / {} / {} of {} seeds",
            g.seeds,
            g.inputs,
            f(g.mean_rmse_h[0], 3),
            f(g.mean_rmse_h[1], 3),
            f(g.mean_rmse_h[2], 3),
            f(g.mean_rmse_peer[0], 3),
            f(g.mean_rmse_peer[1], 3),
            f(g.mean_rmse_peer[2], 3),
            g.seeds_ahead[0],
            g.seeds_ahead[1],
            g.seeds_ahead[2],
            g.seeds
        ));
    }
    let verdict = match (seed7_ok, acc.gb_hybrids_paper.is_empty()) {
        (true, _) => yes(true).to_string(),
        (false, true) => format!("{} (seed 7)", yes(false)),
        (false, false) => {
            format!("{} on seed 7; on the mean over the seeds: {}", yes(false), if all_ok { "met" } else { "not met" })
        }
    };
    out!(
        s,
        "| accuracy, `paper` preset: ahead of the gradient-boosting hybrids on every channel | {} | {} | accuracy run; coverage runs (`bench/sklearn_peer.py hybrids --data target/bench/data/paper-s<seed>.csv`) |",
        parts.join("; "),
        verdict
    );
}

/// Inference cost, flash, RAM and blob rows of the targets.
fn device_targets(s: &mut String, dev: &DeviceResults, paper: Option<&PresetRun>) {
    match dev.record.step.iter().find(|x| x.name == "default") {
        Some(d0) => {
            let ins = d0.instructions_per_step;
            out!(
                s,
                "| inference cost, default model with its memory bank (K = {}, {} memory terms): ≤ 2 500 instructions per step (QEMU -icount) | {} instructions ({} with a new Δt every step; arithmetic lower bound {}) | {} | `{}` |",
                d0.k,
                d0.memory_terms,
                f(ins, 0),
                f(d0.instructions_per_step_new_dt_every_step, 0),
                d0.lower_bound_ops,
                yes(ins <= 2500.0),
                dev.command
            );
        }
        None => out!(
            s,
            "| inference cost of the default model | no `default` model in the device results | – | device part |"
        ),
    }
    let pr = &dev.record.product;
    let flash = pr.flash_bytes as f64;
    let ram = pr.static_ram_plus_stack_bytes as f64;
    let ram_serving = pr.static_ram_plus_serving_stack_bytes as f64;
    out!(
        s,
        "| firmware flash ≤ 48 KiB with the signature verifier (32 KiB before it) | {} B ({:.1} KiB) | {} | device part |",
        f(flash, 0),
        flash / 1024.0,
        yes(flash <= 49152.0)
    );
    out!(
        s,
        "| static RAM + measured stack ≤ 8 KiB serving (≤ 12 KiB at the model-load / verification peak) | {} B while serving; {} B at the peak (boot / model update) | {} (load peak ≤ 12 KiB: {}) | device part |",
        f(ram_serving, 0),
        f(ram, 0),
        yes(ram_serving <= 8192.0),
        if ram <= 12288.0 { "met" } else { "not met" }
    );
    if let Some(paper) = paper {
        let blob = paper.model_h_default.run.bytes as f64;
        out!(
            s,
            "| blob ≤ 4 KiB | trained Model-H (K = {}) {} B; device default model {} B | {} | accuracy run; device part |",
            paper.model_h_default.chosen.k,
            f(blob, 0),
            pr.default_blob_bytes,
            yes(blob <= 4096.0)
        );
    }
}

fn training(s: &mut String, tr: &Training, datasets: &[String]) {
    out!(s, "## Host training time\n");
    out!(
        s,
        "Model-P + Model-H on the calibration half of the `paper` scenario sampled at 1e4, 1e5 and 1e6 points over its 14 days \
         (`[clock] dt_s` = 120.96 / 12.096 / 1.2096 s, seed 7). *Select* is `train`'s full hyper-parameter selection by blocked \
         time-series cross-validation (540 grid points; beyond 40 000 calibration rows the CV works on an even stride, the final fit uses every row). \
         *Fixed* is one configuration, K = 32, σ = 2 × the median nearest-neighbour distance of the centres, α = 1e-5·n, dead band 4 pm; \
         ours still runs the cross-validation once for the 95 % band, which the peer does not compute. Both sides use every core \
         (ours: rayon; scikit-learn: its OpenMP/BLAS threads).\n"
    );
    out!(
        s,
        "| samples | calibration rows | ours, select (default: memory terms) | ours, fixed | scikit-learn notebook, fixed | ratio notebook / ours | scikit-learn with our k-means subsample | ratio subsampled / ours | ours, fixed, latch features | sklearn (subsample), latch features | ratio | ours, fixed, latch RBF + memory terms | sklearn (subsample), same memory terms | ratio |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for z in &tr.sizes {
        let (fp, fd) = (&z.fixed_paper, &z.fixed_default);
        out!(
            s,
            "| {} | {} | {} | {} | {} | **{}×** (rounds: {}) | {} | **{}×** (rounds: {}) | {} | {} (+ {} latch loop) | {}× | {} | {} (+ {} latches and terms) | **{}×** (rounds: {}) |",
            z.n_samples,
            z.n_cal,
            secs(z.ours_select.fit.median),
            secs(fp.ours.fit.median),
            secs(median_of(fp.notebook.as_ref())),
            f(fp.notebook_ratio_median, 2),
            list2(&fp.notebook_ratio_per_round),
            secs(median_of(fp.peer.as_ref().map(|p| &p.fit))),
            f(fp.ratio_median, 2),
            list2(&fp.ratio_per_round),
            secs(fd.ours.median),
            secs(median_of(fd.peer.as_ref().map(|p| &p.fit))),
            secs(fd.peer.as_ref().map_or(f64::NAN, |p| p.latch_seconds)),
            f(fd.ratio, 2),
            secs(z.fixed_memory.fit.median),
            secs(median_of(z.fixed_memory.peer.as_ref().map(|p| &p.fit))),
            secs(z.fixed_memory.peer.as_ref().map_or(f64::NAN, |p| p.latch_seconds + p.feature_seconds)),
            f(z.fixed_memory.ratio_median, 2),
            list2(&z.fixed_memory.ratio_per_round)
        );
    }
    train_end_to_end(s, &tr.sizes);
    let big = tr.sizes.last();
    // Where our fixed fit spends its time at the largest size (median over rounds per phase).
    if let Some((big, rounds)) = big.map(|b| (b, &b.fixed_paper.ours_phases_per_round)).filter(|(_, r)| !r.is_empty()) {
        out!(
            s,
            "\nOur fixed fit at {} samples, phase by phase (median over the rounds of each process's median):\n",
            big.n_samples
        );
        out!(s, "| phase | seconds |\n|---|---|");
        for (k, phase) in rounds[0].iter().enumerate() {
            let t: Vec<f64> = rounds.iter().filter_map(|r| r.get(k).map(|p| p.1)).collect();
            out!(s, "| {} | {} |", phase.0, secs(median(&t)));
        }
    }
    let g = &tr.growth_exponent;
    out!(
        s,
        "\nGrowth exponent (least-squares slope of ln time against ln n over the three sizes): ours with selection **{}**, ours fixed **{}**, scikit-learn with our subsample, fixed **{}**. \
         Below 1 because costs that do not grow with n still weigh at these sizes: k-means on at most 20 000 points on both sides, and on ours the \
         cross-validation on at most 40 000 rows; the per-sample passes (design matrix, ΨᵀΨ, latches) grow linearly. \
         The notebook pipeline's k-means sees every row, so it grows faster: exponent **{}**.\n",
        f(g.ours_select, 2),
        f(g.ours_fixed_paper, 2),
        f(g.peer_fixed_paper, 2),
        f(g.notebook_fixed_paper, 2)
    );
    if let (Some(z), Some(big)) = (tr.sizes.first(), big) {
        out!(
            s,
            "Repeats: each process fits {} times at 1e4 and 1e5 and {} times at 1e6 and reports the median; the paper-feature comparison alternates ours / the notebook pipeline / the subsampled pipeline for {} rounds and each ratio is the median of the rounds' ratios; the other columns are one process each.\n",
            z.repeats_per_process,
            big.repeats_per_process,
            z.rounds
        );
    }
    holdout_rmse(s, &tr.sizes);
    out!(s, "\nCommands (n = 1e6 shown; the others differ only in the CSV):\n");
    if let Some(big) = big {
        let (fp, fd) = (&big.fixed_paper, &big.fixed_default);
        for c in [
            Some(&big.ours_select.fit.command),
            Some(&fp.ours.fit.command),
            fp.notebook.as_ref().map(|n| &n.command),
            fp.peer.as_ref().map(|p| &p.fit.command),
            Some(&fd.ours.command),
            fd.peer.as_ref().map(|p| &p.fit.command),
        ]
        .into_iter()
        .flatten()
        .filter(|c| !c.is_empty())
        {
            out!(s, "    {c}");
        }
    }
    out!(s, "\nDatasets:\n");
    for c in datasets {
        out!(s, "    {c}");
    }
    out!(s, "\n{PEER_TEXT}\n");
}

/// What a user waits for: `train` from the CSV to the written blobs (sizes measured before it
/// was part of the bench have no row; without any row there is no table).
fn train_end_to_end(s: &mut String, sizes: &[SizeRun]) {
    let rows: Vec<_> = sizes.iter().filter_map(|z| z.train_end_to_end.as_ref().map(|e| (z.n_samples, e))).collect();
    if rows.is_empty() {
        return;
    }
    out!(
        s,
        "\n`train` end to end (one run per size, wall clock of the process: read the CSV, select by cross-validation, fit, write both blobs and the coefficients) beside the fit time it reports and the CSV read rate of `bench-fit`:\n"
    );
    out!(
        s,
        "| samples | `train` wall clock | of which the fit | CSV size | CSV read | read rate | command |\n|---|---|---|---|---|---|---|"
    );
    for (n, e) in rows {
        out!(
            s,
            "| {} | {} | {} | {:.1} MB | {} | {:.0} MB/s | `{}` |",
            n,
            secs(e.wall_seconds),
            secs(e.fit_seconds),
            e.csv_bytes as f64 / 1e6,
            secs(e.csv_read_seconds),
            e.csv_read_mb_per_s,
            e.command
        );
    }
}

/// Hold-out RMSE of the fixed fits, ours vs scikit-learn.
fn holdout_rmse(s: &mut String, sizes: &[SizeRun]) {
    out!(s, "Hold-out RMSE of the fixed fits, ours vs scikit-learn (T [°C] / ε [µε] / p [kPa]):\n");
    out!(s, "| samples | features | peer | ours Model-P | sklearn Model-P | ours Model-H | sklearn Model-H | max relative difference (Model-H) |\n|---|---|---|---|---|---|---|---|");
    let missing = [f64::NAN; 3];
    for z in sizes {
        let (fp, fd) = (&z.fixed_paper, &z.fixed_default);
        for (ours, peer, name, how) in [
            (&fp.ours.fit, fp.notebook.as_ref(), "paper", "notebook"),
            (&fp.ours.fit, fp.peer.as_ref().map(|p| &p.fit), "paper", "our subsample"),
            (&fd.ours, fd.peer.as_ref().map(|p| &p.fit), "hysteresis-aware", "our subsample"),
        ] {
            let (p_rmse_p, p_rmse_h) = peer.map_or((&missing, &missing), |p| (&p.rmse_p, &p.rmse_h));
            out!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {:.1} % |",
                z.n_samples,
                name,
                how,
                rmse3(&ours.rmse_p).join(" / "),
                rmse3(p_rmse_p).join(" / "),
                rmse3(&ours.rmse_h).join(" / "),
                rmse3(p_rmse_h).join(" / "),
                100.0 * max_rel_diff(&ours.rmse_h, p_rmse_h)
            );
        }
    }
}

fn inference(s: &mut String, inf: &Inference) {
    out!(s, "## Host inference throughput (`fbg-shared`, criterion)\n");
    out!(s, "`Compensator::step` on a stream of 1 024 samples per iteration, synthetic hysteresis-aware models (`shared/benches/step.rs`); criterion median of 100 samples, one core.\n");
    out!(s, "| precision | K | ns per step | samples per second |\n|---|---|---|---|");
    for row in &inf.rows {
        out!(
            s,
            "| {} | {} | {} | {:.2} M |",
            row.precision,
            row.k,
            f(row.ns_per_step, 0),
            row.samples_per_second / 1e6
        );
    }
    out!(s, "\n    {}\n", inf.command);
}

fn accuracy(s: &mut String, acc: &Accuracy) {
    out!(s, "## Accuracy against black-box peers and the per-sample oracle\n");
    out!(
        s,
        "Hold-out RMSE per channel on the `paper` and `harsh` presets (seed 7, 14 days at 60 s, first half calibrates). Ours: `train`'s selection \
         (default: memory terms fitted on what the core leaves, groups and λ by cross-validation, plus the RBF residual on the latches; `--features paper`: only Eq. 5's inputs, no memory terms). Black boxes: scikit-learn on the same \
         calibration rows with the inputs named; *Model-P + HistGradientBoosting residual* is a hybrid whose residual learner is a gradient-boosting \
         model instead of the RBF ridge, on the latches or on 59 causal history inputs (`bench/sklearn_peer.py`'s `history_features`): how far far more \
         information and a far larger learner get. Size: our `.fbgm` blob; scikit-learn: `len(pickle.dumps(model))`.\n"
    );
    for p in &acc.presets {
        preset(s, p);
    }
    coverage(s, acc);
}

/// One preset's table: our models, the black boxes, the oracle.
fn preset(s: &mut String, p: &PresetRun) {
    out!(s, "### `{}`\n", p.preset);
    out!(s, "| model | inputs | T [°C] | ε [µε] | p [kPa] | below Model-P (T / ε / p) | size |\n|---|---|---|---|---|---|---|");
    let base = p.model_p.rmse;
    let row = |s: &mut String, name: &str, inputs: &str, rm: &Rmse, size: String| {
        let r = rmse3(rm);
        // Rounded first, so that a gain of −0.3 % reads 0 %, not −0 %.
        let gain: Vec<String> =
            (0..3).map(|c| format!("{:.0} %", (100.0 * (1.0 - rm[c] / base[c])).round() + 0.0)).collect();
        out!(s, "| {name} | {inputs} | {} | {} | {} | {} | {size} |", r[0], r[1], r[2], gain.join(" / "));
    };
    row(s, "Model-P", "Δλ, T_amb", &p.model_p.rmse, format!("{} B", p.model_p.bytes));
    let h = &p.model_h_default;
    row(
        s,
        "Model-H (default: memory terms + RBF)",
        &format!("chosen: {}, K = {}", h.chosen.feature_set, h.chosen.k),
        &h.run.rmse,
        format!("{} B", h.run.bytes),
    );
    let hp = &p.model_h_paper;
    row(
        s,
        "Model-H (`--features paper`)",
        &format!("Δλ, T_amb, t; K = {}", hp.chosen.k),
        &hp.run.rmse,
        format!("{} B", hp.run.bytes),
    );
    let mut best = [f64::INFINITY; 3];
    for b in p.blackbox.iter().flat_map(|b| &b.peers) {
        for (c, bst) in best.iter_mut().enumerate() {
            *bst = bst.min(b.rmse[c]);
        }
        let inputs = match b.n_inputs {
            Some(n) => format!("{} ({n} inputs)", b.inputs),
            None => b.inputs.clone(),
        };
        row(s, &format!("scikit-learn {}", b.model), &inputs, &b.rmse, format!("{} B", b.pickle_bytes));
    }
    row(
        s,
        "per-sample oracle",
        "true physics inverted sample by sample, noise-only wavelengths",
        &p.oracle_floor.rmse,
        "–".into(),
    );
    if best[0].is_finite() {
        let (hr, fl) = (&h.run.rmse, &p.oracle_floor.rmse);
        out!(
            s,
            "\nModel-H (default) / best black box: {:.2} / {:.2} / {:.2}; Model-H / per-sample oracle: {:.2} / {:.2} / {:.2}; best black box / oracle: {:.2} / {:.2} / {:.2}.",
            hr[0] / best[0],
            hr[1] / best[1],
            hr[2] / best[2],
            hr[0] / fl[0],
            hr[1] / fl[1],
            hr[2] / fl[2],
            best[0] / fl[0],
            best[1] / fl[1],
            best[2] / fl[2]
        );
    }
    out!(s, "\n    {}\n    {}", h.run.command, hp.run.command);
    if let Some(b) = &p.blackbox {
        out!(s, "    {}", b.command);
    }
    out!(s, "    (per-sample oracle: {})\n", p.oracle_floor.source);
}

/// Gain and band coverage over the coverage seeds, with the ensemble band for reference.
fn coverage(s: &mut String, acc: &Accuracy) {
    let n = COVERAGE_SEEDS.len();
    out!(
        s,
        "### Gain over Model-P and band coverage of Model-H, `paper` preset, seeds {}–{}\n",
        COVERAGE_SEEDS[0],
        COVERAGE_SEEDS[n - 1]
    );
    // The richest gradient-boosting hybrid (most inputs), when the peer ran.
    let richest = acc.gb_hybrids_paper.iter().max_by_key(|g| g.n_inputs.unwrap_or(0));
    let hyb_head = richest.map_or(String::new(), |g| format!(" Model-H / GB hybrid ({}), T / ε / p |", g.inputs));
    let hyb_rule = if richest.is_some() { "---|" } else { "" };
    out!(
        s,
        "| seed | K | gain T | gain ε | gain p | coverage T | coverage ε | coverage p |{hyb_head} command |\n|---|---|---|---|---|---|---|---|{hyb_rule}---|"
    );
    let cp = &acc.coverage_paper;
    for c in &cp.per_seed {
        let hyb = match richest {
            Some(g) => match c.gb_hybrids.iter().find(|p| p.inputs == g.inputs) {
                Some(p) => format!(
                    " {} / {} / {} |",
                    f(c.rmse_h[0] / p.rmse[0], 2),
                    f(c.rmse_h[1] / p.rmse[1], 2),
                    f(c.rmse_h[2] / p.rmse[2], 2)
                ),
                None => " – |".to_string(),
            },
            None => String::new(),
        };
        out!(
            s,
            "| {} | {} | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % |{hyb} `{}` |",
            c.seed,
            c.k,
            c.gain_pct(0),
            c.gain_pct(1),
            c.gain_pct(2),
            100.0 * c.coverage_h[0],
            100.0 * c.coverage_h[1],
            100.0 * c.coverage_h[2],
            c.command
        );
    }
    let gap = if richest.is_some() { " |" } else { "" };
    if let Some(g) = richest {
        out!(
            s,
            "| mean RMSE, Model-H / GB hybrid | | | | | | | | {} / {} / {}; Model-H ahead on {} / {} / {} of {} seeds | target: ahead on every channel |",
            f(g.mean_rmse_h[0] / g.mean_rmse_peer[0], 3),
            f(g.mean_rmse_h[1] / g.mean_rmse_peer[1], 3),
            f(g.mean_rmse_h[2] / g.mean_rmse_peer[2], 3),
            g.seeds_ahead[0],
            g.seeds_ahead[1],
            g.seeds_ahead[2],
            g.seeds
        );
    }
    let g = &acc.gain_paper;
    out!(
        s,
        "| **gain mean** | | **{:.1} %** | **{:.1} %** | **{:.1} %** | | | |{gap} target ≥ 40 / 30 / 40 % |",
        g.mean_pct[0],
        g.mean_pct[1],
        g.mean_pct[2]
    );
    out!(
        s,
        "| gain smallest | | {:.1} % | {:.1} % | {:.1} % | | | |{gap} target ≥ 25 % on every seed |",
        g.min_pct[0],
        g.min_pct[1],
        g.min_pct[2]
    );
    out!(
        s,
        "| **coverage mean** | | | | | **{:.1} %** | **{:.1} %** | **{:.1} %** |{gap} target 95 ± 1 % |",
        100.0 * cp.mean_h[0],
        100.0 * cp.mean_h[1],
        100.0 * cp.mean_h[2]
    );
    out!(
        s,
        "| coverage median | | | | | {:.1} % | {:.1} % | {:.1} % |{gap} |",
        100.0 * cp.median_h[0],
        100.0 * cp.median_h[1],
        100.0 * cp.median_h[2]
    );
    let w = &cp.seeds_within_95_pm_2;
    out!(
        s,
        "| seeds within 95 ± 2 % | | | | | {} of {n} | {} of {n} | {} of {n} |{gap} target ≥ {SEEDS_WITHIN_2} of {n} |",
        w[0],
        w[1],
        w[2]
    );
    // The ensemble band (absent from files written before it was measured: no rows, no note).
    let Some(ens) = cp.ensemble_band.as_ref().filter(|e| e.channels.len() == 3) else {
        out!(s);
        return;
    };
    let ch = &ens.channels;
    out!(
        s,
        "| *reference: ensemble band*, seeds within 95 ± 2 % | | | | | {} of {n} | {} of {n} | {} of {n} |{gap} |",
        ch[0].seeds_within_95_pm_2,
        ch[1].seeds_within_95_pm_2,
        ch[2].seeds_within_95_pm_2
    );
    out!(
        s,
        "| *reference: ensemble band*, lowest seed | | | | | {:.1} % | {:.1} % | {:.1} % |{gap} |\n",
        100.0 * ch[0].min,
        100.0 * ch[1].min,
        100.0 * ch[2].min
    );
    out!(
        s,
        "The *ensemble band* is a reference no model can have: a band that depends on the lead time alone, \
         set to the 95 % quantile of |error| of Model-H over all {n} seeds' hold-outs at once (2-hour lead bins). \
         Its per-seed coverage is the spread that comes from the hold-out week itself (each seed is one drift path; \
         a seed whose error keeps one sign for the whole week falls outside any band of the right average width), \
         not from the band a model estimates from its own calibration batch. Where it stays below {SEEDS_WITHIN_2} of {n}, \
         no band that depends on the lead time alone meets the per-seed target. \
         Per-sample errors and bands: `target/bench/holdout/paper-s<seed>.csv` (`bench-fit --holdout-errors`).\n"
    );
}

fn device(s: &mut String, rep: &Report) {
    out!(s, "## Device (Cortex-M4F under QEMU)\n");
    let dev = match &rep.device {
        super::report::Device::Failed { error } => {
            out!(s, "**The device bench failed:** {error}\n");
            return;
        }
        super::report::Device::Measured(d) => d,
    };
    out!(
        s,
        "{}. Models: the device bench's fixtures at each K (`xtask/src/fixtures.rs`). Lower bound: the arithmetic operations of one f32 `step` counted from the code ({} operations; table in `shared/src/lib.rs`), each at least one instruction.{}\n",
        dev.record.method,
        dev.arithmetic_lower_bound.as_ref().map_or("", |b| &b.formula),
        if dev.reused_existing_results { " **Reused from an earlier run (--no-device).**" } else { "" }
    );
    out!(s, "| model | K | memory terms | instructions per step | new Δt every step | arithmetic lower bound | measured / bound | blob | bench image stack |\n|---|---|---|---|---|---|---|---|---|");
    for st in &dev.record.step {
        step_row(s, st);
    }
    let sz = &dev.record.sizes;
    out!(
        s,
        "\nDevice types (`size_of` on the target, K = {}): memory state `MemoryState<f32>` {} B, stream state (latches + memory) {} B, `MemoryBank<f32>` {} B, `Compensator<f32, {}>` {} B, centre-less parameter slot `ModelParams<f32, 0>` (on the stack during a load; the centres are read from the blob one at a time) {} B, longest staged update {} B (staged in a flash slot outside the image, not in RAM).",
        sz.k,
        sz.memory_state_bytes,
        sz.stream_state_bytes,
        sz.memory_bank_bytes,
        sz.k,
        sz.compensator_bytes,
        sz.model_params_bytes,
        sz.staging_bytes
    );
    let pr = &dev.record.product;
    out!(
        s,
        "\nProduct image (K = {}): flash {} B, static RAM {} B, stack peak {} B at boot, {} B while serving, {} B through a model update; default blob {} B.\n\n    {}\n",
        pr.k,
        pr.flash_bytes,
        pr.static_ram_bytes,
        pr.stack_peak_boot_bytes,
        pr.stack_peak_serving_bytes,
        pr.stack_peak_update_bytes,
        pr.default_blob_bytes,
        dev.command
    );
}

fn step_row(s: &mut String, st: &StepRow) {
    let (i, lb) = (st.instructions_per_step, st.lower_bound_ops as f64);
    out!(
        s,
        "| {} | {} | {} | {} | {} | {} | {:.2} | {} B | {} B |",
        st.name,
        st.k,
        st.memory_terms,
        f(i, 0),
        f(st.instructions_per_step_new_dt_every_step, 0),
        f(lb, 0),
        i / lb,
        st.blob_bytes,
        st.stack_peak_bytes
    );
}

fn fleet(s: &mut String, fl: &Fleet) {
    out!(s, "## Fleet calibration (`fbg-trainer fleet`)\n");
    out!(s, "{} sensor groups, each {}, with `train`'s full selection; every run starts from no outputs; the two pool sizes alternate for {} rounds; time is the fleet's own wall clock (manifest parsed, every group read, fitted and written).\n", fl.groups, fl.scenario, fl.rounds);
    out!(s, "| jobs (cores) | median wall time | groups per second | runs | command |\n|---|---|---|---|---|");
    for run in &fl.runs {
        out!(
            s,
            "| {} | {} | {:.2} | {} | `{}` |",
            run.jobs,
            secs(run.median_seconds),
            run.groups_per_second,
            list2(&run.seconds),
            run.command
        );
    }
    let r = &fl.resume;
    out!(
        s,
        "\nSpeed-up of 2 jobs over 1 (median of the rounds' ratios): **{}×**. A rerun with nothing changed skipped {} groups and trained {} in {} (`{}`).\n\n    {}\n",
        f(fl.speedup_2_over_1_median, 2),
        r.skipped,
        r.trained,
        secs(r.seconds),
        r.command,
        fl.simulate_command
    );
}

fn slurm(s: &mut String, v: &serde_json::Value) {
    let n = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    out!(s, "## Fleet on a real Slurm (`cargo xtask slurm`)\n");
    out!(
        s,
        "A single-node Slurm started on this machine ({} CPUs): `deploy/slurm/fleet.sbatch` as an array of {} tasks (one shard each, `--cpus-per-task={}`) over {} groups (two-day records, `train`'s full grid). One task was cancelled after {} of its groups had finished; after the array, `fleet status` reported {} groups done and the rest missing; the resubmitted task trained {} and skipped {} (finished before the cancel). Every blob equals a single-machine `fleet` run's byte for byte: {}.\n",
        v["cpus"], v["shards"], v["cpus_per_task"], v["groups"], v["done_when_cancelled"], v["done_after_first_submission"],
        v["resubmitted"]["trained"], v["resubmitted"]["skipped"], v["blobs_identical_to_single_machine"]
    );
    out!(
        s,
        "| shard | groups | trained (last run) | skipped | seconds | trained groups/s |\n|---|---|---|---|---|---|"
    );
    for r in v["per_shard_last_run"].as_array().into_iter().flatten() {
        out!(
            s,
            "| {} | {} | {} | {} | {} | {:.2} |",
            r["shard"],
            r["groups"],
            r["trained"],
            r["skipped"],
            secs(r["seconds"].as_f64().unwrap_or(f64::NAN)),
            r["groups_per_s"].as_f64().unwrap_or(f64::NAN)
        );
    }
    out!(
        s,
        "\nWall clock: first submission {} (including Slurm's scheduling), the resubmitted task {}, total {}; the same manifest by one `fleet` process on the whole machine: {}. Command: `{}` (root; installs slurm-wlm and munge when missing).\n",
        secs(n("first_submission_wall_seconds")),
        secs(v["resubmitted"]["wall_seconds"].as_f64().unwrap_or(f64::NAN)),
        secs(n("total_wall_seconds")),
        secs(n("single_machine_wall_seconds")),
        v["command"].as_str().unwrap_or("cargo xtask slurm")
    );
}

// ---------------------------------------------------------------------------------------------
// Static fidelity and pace (issue 26)

/// Values joined by " / ", `digits` decimals each.
fn join(v: &[f64], digits: usize) -> String {
    v.iter().map(|x| f(*x, digits)).collect::<Vec<_>>().join(" / ")
}

/// Fractions as percentages joined by " / ".
fn pcts(v: &[f64]) -> String {
    v.iter().map(|x| f(100.0 * x, 1)).collect::<Vec<_>>().join(" / ")
}

/// RMSE per channel joined by " / ": three decimals for temperature, two for the others.
fn rmses(v: &[f64], channels: &[String]) -> String {
    v.iter()
        .enumerate()
        .map(|(c, x)| f(*x, if channels.get(c).is_some_and(|n| n == "T") { 3 } else { 2 }))
        .collect::<Vec<_>>()
        .join(" / ")
}

/// Gains of Model-H over Model-P [%] per channel.
fn gains(p: &[f64], h: &[f64]) -> String {
    (0..p.len()).map(|c| f(super::report::gain(p, h, c), 1)).collect::<Vec<_>>().join(" / ")
}

/// A channel's short name with its unit (`T [°C]`, `ε [µε]`, `p [kPa]`).
fn channel_unit(name: &str) -> String {
    match name {
        "T" => "T [°C]".into(),
        "strain" => "ε [µε]".into(),
        "strain2" => "ε₂ [µε]".into(),
        "p" => "p [kPa]".into(),
        other => other.into(),
    }
}

/// A channel's short name (`T`, `ε`, `p`).
fn short(name: &str) -> &str {
    match name {
        "strain" => "ε",
        "strain2" => "ε₂",
        other => other,
    }
}

/// The channels of a run, "T / ε / p".
fn channel_names(channels: &[String]) -> String {
    channels.iter().map(|n| short(n)).collect::<Vec<_>>().join(" / ")
}

/// Channel `c`'s short name ("?" when the run names fewer).
fn channel(channels: &[String], c: usize) -> &str {
    channels.get(c).map_or("?", |n| short(n))
}

/// "7–26" for the runs' seeds.
fn seed_range(runs: &[EvalRun]) -> String {
    match (runs.first(), runs.last()) {
        (Some(a), Some(b)) if a.seed != b.seed => format!("{}–{}", a.seed, b.seed),
        (Some(a), _) => a.seed.to_string(),
        _ => "–".into(),
    }
}

/// "**met** on seed 7; **not met** over seeds 7–26 (12 of 20)".
fn seeds_verdict(seed7: bool, ok: usize, runs: &[EvalRun]) -> String {
    let n = runs.len();
    let first = runs.first().map_or(7, |r| r.seed);
    if n <= 1 {
        return format!("{} (seed {first})", yes(seed7));
    }
    format!("{} on seed {first}; {} over seeds {} ({ok} of {n})", yes(seed7), yes(ok == n), seed_range(runs))
}

/// The channels of `row` on which Model-H's RMSE exceeds Model-P's (or is missing), with the gain.
fn channels_h_worse(row: &PaceRow, channels: &[String]) -> Vec<String> {
    (0..row.rmse_p.len())
        .filter(|&c| !at_most(row.rmse_h.get(c).copied().unwrap_or(f64::NAN), row.rmse_p[c]))
        .map(|c| format!("{} {} %", channel(channels, c), f(row.gain_pct(c), 1)))
        .collect()
}

/// The channels of `row` on which Model-H's band coverage is below the pace target.
fn channels_low_coverage(row: &PaceRow, channels: &[String]) -> Vec<String> {
    row.coverage_h
        .iter()
        .enumerate()
        .filter(|(_, v)| !at_most(PACE_MIN_COVERAGE, **v))
        .map(|(c, v)| format!("{} {} %", channel(channels, c), f(100.0 * v, 1)))
        .collect()
}

/// Per channel over `rows`, the smallest of `g(row, c)`.
fn min_per_channel(rows: &[PaceRow], g: impl Fn(&PaceRow, usize) -> f64) -> Vec<f64> {
    let nc = rows.iter().map(|r| r.rmse_p.len()).max().unwrap_or(0);
    (0..nc)
        .map(|c| {
            rows.iter()
                .map(|r| g(r, c))
                .fold(f64::INFINITY, |a, x| if a.is_nan() || x.is_nan() { f64::NAN } else { a.min(x) })
        })
        .collect()
}

/// The target rows of issue 26: static slopes, pace, `field`.
fn pace_targets(s: &mut String, rep: &Report) {
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
                    join(&x.max_slope_dev_p.iter().map(|v| 100.0 * v).collect::<Vec<_>>(), 2),
                    join(&x.max_slope_dev_h.iter().map(|v| 100.0 * v).collect::<Vec<_>>(), 2),
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
            let h_le_p = rows.iter().filter(|r| r.h_le_p()).count();
            let worse: Vec<String> = rows
                .iter()
                .filter(|r| !r.h_le_p())
                .map(|r| format!("{}: {}", r.label, channels_h_worse(r, ch).join(", ")))
                .collect();
            let seeds_rmse =
                pb.runs.iter().filter(|r| r.pace.as_ref().is_some_and(|p| !p.rows.is_empty() && p.rows.iter().all(|x| x.h_le_p()))).count();
            out!(
                s,
                "| pace (`paper`): at ×¼, ×4, ×8 (all measurands, and each alone) and on the steps record, Model-H RMSE ≤ Model-P on every channel | seed {}: on {h_le_p} of {n_rec} records; smallest gain over the records {} % ({}){}; every record on {} of {} seeds | {} | `{}` |",
                run.seed,
                join(&min_per_channel(rows, |r, c| r.gain_pct(c)), 1),
                channel_names(ch),
                if worse.is_empty() { String::new() } else { format!("; Model-H above Model-P (gain) on {}", worse.join("; ")) },
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
        }
    }
    match rep.field.as_ref().filter(|f| !f.runs.is_empty()) {
        None => out!(s, "| `field` preset targets | not measured in this BENCHMARKS.json | – | – |"),
        Some(fb) => {
            let n = fb.runs.len();
            let ch = &fb.runs[0].channels;
            out!(
                s,
                "| `field` preset, seeds {}: Model-H never worse than Model-P on any channel | Model-H worse on {} of {n} seeds ({}: {} of {n}); mean gain {} %, smallest {} % | {} | `{}`, then `{}` (each seed) |",
                seed_range(&fb.runs),
                fb.seeds_h_worse_any,
                channel_names(ch),
                fb.seeds_h_worse.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" / "),
                join(&fb.mean_gain_pct, 1),
                join(&fb.min_gain_pct, 1),
                yes(fb.seeds_h_worse_any == 0 && n == COVERAGE_SEEDS.len()),
                fb.runs[0].train_command,
                fb.runs[0].evaluate_command
            );
            out!(
                s,
                "| `field` preset, seeds {}: mean band coverage of Model-H within 95 ± 2 % per channel | {} % ({}; Model-P {} %) | {} | same runs |",
                seed_range(&fb.runs),
                pcts(&fb.mean_coverage_h),
                channel_names(ch),
                pcts(&fb.mean_coverage_p),
                yes(!fb.mean_coverage_h.is_empty() && fb.mean_coverage_h.iter().all(|c| (100.0 * c - 95.0).abs() <= 2.0))
            );
        }
    }
}

/// The pace study and the `field` preset (absent from files written before them).
fn pace_section(s: &mut String, rep: &Report) {
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
         Targets: Model-H RMSE ≤ Model-P and Model-H band coverage ≥ {:.0} % on every channel of every record; \\|slope − 1\\| ≤ {:.0} % \
         for both models. Per-seed figures: `pace_paper` and `field` in BENCHMARKS.json; models in `target/bench/models/`.\n",
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

fn pace_paper(s: &mut String, pb: &PaceBench) {
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
        ch.iter().map(|c| channel_unit(c)).collect::<Vec<_>>().join(" / ")
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
            if r.h_le_p() && r.coverage_h_at_least(PACE_MIN_COVERAGE) { "yes" } else { "**no**" }
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
        out!(
            s,
            "| seed | Model-H below Model-P at the native pace ({names}) | steps slope, Model-P | steps slope, Model-H | records with Model-H above Model-P | records with Model-H coverage < {:.0} % | both pace targets on every record |\n|---|---|---|---|---|---|---|",
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
                p.rows.iter().filter(|x| !x.h_le_p()).count(),
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
fn pace_summary_table(s: &mut String, summary: &[PaceSummary], ch: &[String], n: usize, seeds_all: usize) {
    let names = channel_names(ch);
    out!(
        s,
        "| record | seeds | Model-H ≤ Model-P on every channel | mean gain ({names}) | smallest gain | Model-H coverage ≥ {:.0} % on every channel | lowest Model-H coverage |\n|---|---|---|---|---|---|---|",
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
            join(&st.max_slope_dev_p.iter().map(|v| 100.0 * v).collect::<Vec<_>>(), 2),
            join(&st.max_slope_dev_h.iter().map(|v| 100.0 * v).collect::<Vec<_>>(), 2),
            100.0 * SLOPE_TOL,
            st.seeds_slopes_within_1pct,
            st.seeds
        );
    }
    out!(s, "Both pace targets on every record: {seeds_all} of {n} seeds.\n");
}

fn field(s: &mut String, fb: &FieldBench) {
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
        ch.iter().map(|c| channel_unit(c)).collect::<Vec<_>>().join(" / ")
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
        fb.seeds_h_worse.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" / "),
        fb.seeds_h_worse_any
    );
    out!(
        s,
        "| **coverage mean** | | | | {} % | **{} %** (target 95 ± 2 %) |\n",
        pcts(&fb.mean_coverage_p),
        pcts(&fb.mean_coverage_h)
    );
    out!(s, "    {}\n    {}\n", first.train_command, first.evaluate_command);
    if !fb.pace_summary.is_empty() {
        out!(s, "Pace study of the `{}` seeds (same records as for `paper`; no target):\n", fb.preset);
        pace_summary_table(s, &fb.pace_summary, ch, n, fb.seeds_pace_targets);
    }
}

const PEER_TEXT: &str = "What the scikit-learn peer computes (`bench/sklearn_peer.py fit`, timed like ours: the CSV read once, then each fit timed alone): \
on the calibration rows, stage 1 `LinearRegression` from [Δλ1..3, T_amb] to [T, ε, p]; stage 2 `StandardScaler` → `PolynomialFeatures(2)` → \
`LinearRegression` on the first guesses (Model-P, the same ten terms as Eq. 3); the RBF inputs z (`paper`: Δλ1..3, T_amb, t; `hysteresis-aware`: \
Δλ1..3, T_amb and the three direction latches, computed by a Python port of `fbg_shared::DirectionLatch` over the whole record *before* the clock \
starts, its time shown separately) through `StandardScaler`; then k-means in one of two ways: the *notebook* pipeline (`--kmeans all`) runs \
`KMeans(K, random_state=seed)` with scikit-learn's defaults (k-means++, one initialisation, up to 300 iterations, tol 1e-4) on every calibration row, \
as DESIGN §4's \"k-means over the calibration batch\" reads and as one writes it in a notebook; the *subsampled* pipeline (`--kmeans subsample`) runs \
`KMeans(K, init=\"k-means++\", n_init=1, max_iter=100)` on every ceil(n/20 000)-th row, our own subsample and iteration cap ported to scikit-learn, \
so that it compares the two implementations of one algorithm; σ = σ-multiplier × the median nearest-neighbour distance of the centres; ψ = `rbf_kernel(z, centres, γ = 1/2σ²)`; \
`Ridge(alpha = α_rel·n, fit_intercept=False)` from ψ to the Model-P residuals. It does not compute the band (our fit's cross-validation of the \
residual variance), the envelope, the weak-support threshold or the variance eigen-directions.";

#[cfg(test)]
mod tests {
    use super::*;

    /// BENCHMARKS.md is what this writer makes of BENCHMARKS.json: after a change to the writer,
    /// `cargo xtask bench --markdown-only` renders it again.
    #[test]
    fn committed_benchmarks_md_is_rendered_from_the_json() {
        let root = crate::cmd::root();
        let report: Report = super::super::runner::read_json(&root.join("BENCHMARKS.json")).unwrap();
        let md = std::fs::read_to_string(root.join("BENCHMARKS.md")).unwrap();
        assert!(
            markdown(&report) == md,
            "BENCHMARKS.md differs from what xtask/src/bench/markdown.rs makes of BENCHMARKS.json: run `cargo xtask bench --markdown-only`"
        );
    }
}
