//! The host sections: training times, inference throughput, the fleet and Slurm.

use super::*;

pub(super) fn training(s: &mut String, tr: &Training, datasets: &[String]) {
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
    holdout_rmse(s, &tr.sizes, &tr.channels);
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
pub(super) fn train_end_to_end(s: &mut String, sizes: &[SizeRun]) {
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
pub(super) fn holdout_rmse(s: &mut String, sizes: &[SizeRun], ch: &[String]) {
    out!(s, "Hold-out RMSE of the fixed fits, ours vs scikit-learn ({}):\n", channel_units(ch));
    out!(s, "| samples | features | peer | ours Model-P | sklearn Model-P | ours Model-H | sklearn Model-H | max relative difference (Model-H) |\n{}", rule(8));
    let missing = vec![f64::NAN; ch.len()];
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
                rmses(&ours.rmse_p, ch),
                rmses(p_rmse_p, ch),
                rmses(&ours.rmse_h, ch),
                rmses(p_rmse_h, ch),
                100.0 * max_rel_diff(&ours.rmse_h, p_rmse_h)
            );
        }
    }
}

pub(super) fn inference(s: &mut String, inf: &Inference) {
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

pub(super) fn fleet(s: &mut String, fl: &Fleet) {
    out!(s, "## Fleet calibration (`fbg-trainer fleet`)\n");
    out!(s, "{} sensor groups, each {}, with `train`'s full selection; every run starts from no outputs; the two pool sizes alternate for {} rounds; time is the fleet's own wall clock (manifest parsed, every group read, fitted and written).\n", fl.groups, fl.scenario, fl.rounds);
    out!(s, "| jobs (cores) | median wall time | groups per second | runs | command |\n{}", rule(5));
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

pub(super) fn slurm(s: &mut String, v: &serde_json::Value) {
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

pub(super) const PEER_TEXT: &str = "What the scikit-learn peer computes (`bench/sklearn_peer.py fit`, timed like ours: the CSV read once, then each fit timed alone): \
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
