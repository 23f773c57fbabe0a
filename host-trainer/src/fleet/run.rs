//! A fleet run: every group of a manifest (or of one shard) trained on a local pool, each
//! group's outputs written as one set, failures recorded and reported, not fatal.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::records::{blob_digest, input_digest, needs_training, FailureRecord, Sidecar};
use super::shard::{Shard, ShardSource};
use super::{manifest_sign, Group, Manifest, FAILURE_FORMAT, SIDECAR_FORMAT};
use crate::data::files::{write_bytes_atomically, OutputSet};
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::export::ModelFiles;
use crate::fit::{self, Origin};
use crate::sign::{BlobSigner, SignOptions};
use crate::sim::meta::SimMeta;

/// What happened to one group.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "status")]
pub enum Outcome {
    /// Trained and written now.
    Trained { seconds: f64, model_h_bytes: usize, chosen_k: usize, chosen_features: String, cv_rmse_h: Vec<f64> },
    /// Finished by an earlier run: nothing redone.
    Skipped,
    /// Failed; the other groups went on.
    Failed { error: String },
}

/// One group's line in the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupReport {
    pub name: String,
    pub out: PathBuf,
    #[serde(flatten)]
    pub outcome: Outcome,
    /// Why the group was (re)trained, when it was: `no record`, `input changed`, ...
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// The shard a run covered.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShardInfo {
    pub index: usize,
    pub count: usize,
    /// `option`, `slurm` or `kubernetes`.
    pub source: ShardSource,
    /// Groups of the manifest in this shard, and in all.
    pub groups_in_shard: usize,
    pub groups_in_manifest: usize,
    /// The report written for this shard.
    pub summary: PathBuf,
}

/// The whole run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FleetReport {
    pub manifest: PathBuf,
    /// The shard this run covered (none: the whole manifest).
    pub shard: Option<ShardInfo>,
    pub jobs: usize,
    pub groups: Vec<GroupReport>,
    pub trained: usize,
    pub skipped: usize,
    pub failed: usize,
    pub seconds: f64,
    /// Trained groups per second of wall time.
    pub trained_per_second: f64,
}

impl FleetReport {
    /// A human-readable summary, one line per group.
    pub fn text(&self) -> String {
        let mut s = String::new();
        for g in &self.groups {
            let line = match &g.outcome {
                Outcome::Trained { seconds, model_h_bytes, chosen_k, chosen_features, .. } => format!(
                    "trained in {seconds:.1} s ({}): {chosen_features} features, K = {chosen_k}, {} ({model_h_bytes} B)",
                    g.reason.as_deref().unwrap_or("new"),
                    g.out.display()
                ),
                Outcome::Skipped => format!("up to date, skipped ({})", g.out.display()),
                Outcome::Failed { error } => format!("FAILED: {error}"),
            };
            s.push_str(&format!("{:>20}  {line}\n", g.name));
        }
        if let Some(sh) = &self.shard {
            s.push_str(&format!(
                "shard {}/{} (from {}): {} of the manifest's {} groups; report in {}\n",
                sh.index,
                sh.count,
                match sh.source {
                    ShardSource::Option => "--shard",
                    ShardSource::Slurm => "the Slurm array task",
                    ShardSource::Kubernetes => "the Kubernetes completion index",
                },
                sh.groups_in_shard,
                sh.groups_in_manifest,
                sh.summary.display()
            ));
        }
        s.push_str(&format!(
            "{} groups: {} trained, {} skipped (finished earlier), {} failed in {:.1} s on {} jobs ({:.2} trained groups/s)",
            self.groups.len(),
            self.trained,
            self.skipped,
            self.failed,
            self.seconds,
            self.jobs,
            self.trained_per_second
        ));
        s
    }
}

fn train_group(g: &Group, digest: &str, signer: Option<&BlobSigner>) -> Result<Sidecar, TrainerError> {
    let t = Instant::now();
    let opts = g.train_options()?;
    let d = Dataset::read_csv(&g.data)?;
    let origin = match SimMeta::read_for(&g.data)? {
        Some(m) => Origin { scenario: m.scenario.name.clone(), seed: m.seed },
        None => Origin { scenario: g.name.clone(), seed: 0 },
    };
    let tr = fit::train_source(&d, &g.data.display().to_string(), &opts, &origin)?;
    let files = ModelFiles::of(&tr, signer)?;
    // The blobs, the coefficients and the record are one output set: a kill or a failure
    // leaves the old group whole (its old record still matching its old blob) or the new one.
    let set = OutputSet::beside(&g.out)?;
    files.stage(&set, &g.out)?;
    let rec = Sidecar {
        format: SIDECAR_FORMAT.into(),
        name: g.name.clone(),
        input_digest: digest.to_string(),
        blob_digest: blob_digest(&files.model_h),
        model_h_bytes: files.model_h.len(),
        model_p_bytes: files.model_p.len(),
        chosen_k: tr.selection.chosen.k,
        chosen_features: tr.selection.chosen.feature_set.name().into(),
        cv_rmse_h: tr.selection.cv_rmse_h,
        train_seconds: t.elapsed().as_secs_f64(),
    };
    let text = serde_json::to_string_pretty(&rec).map_err(|e| TrainerError::fit(e.to_string()))?;
    set.stage_bytes(&g.sidecar_path(), text.as_bytes())?;
    set.commit()?;
    let failed = g.failure_path();
    if failed.exists() {
        std::fs::remove_file(&failed).map_err(|e| TrainerError::io(&failed, e))?;
    }
    Ok(rec)
}

fn run_group(g: &Group, signer: Option<&BlobSigner>) -> GroupReport {
    let report = |outcome, reason| GroupReport { name: g.name.clone(), out: g.out.clone(), outcome, reason };
    let csv = match std::fs::read(&g.data) {
        Ok(b) => b,
        Err(e) => return report(Outcome::Failed { error: TrainerError::io(&g.data, e).to_string() }, None),
    };
    let digest = input_digest(g, &csv);
    let Some(reason) = needs_training(g, &digest) else { return report(Outcome::Skipped, None) };
    let result = catch_unwind(AssertUnwindSafe(|| train_group(g, &digest, signer)));
    let outcome = match result {
        Ok(Ok(r)) => Outcome::Trained {
            seconds: r.train_seconds,
            model_h_bytes: r.model_h_bytes,
            chosen_k: r.chosen_k,
            chosen_features: r.chosen_features,
            cv_rmse_h: r.cv_rmse_h,
        },
        Ok(Err(e)) => Outcome::Failed { error: e.to_string() },
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            Outcome::Failed { error: format!("internal error (panic): {msg}") }
        }
    };
    if let Outcome::Failed { error } = &outcome {
        // Best effort: `fleet status` reads it; the run's report has the error either way.
        let rec = FailureRecord {
            format: FAILURE_FORMAT.into(),
            name: g.name.clone(),
            input_digest: digest.clone(),
            error: error.clone(),
        };
        if let Ok(text) = serde_json::to_string_pretty(&rec) {
            let _ = write_bytes_atomically(&g.failure_path(), text.as_bytes());
        }
    }
    report(outcome, Some(reason))
}

/// Calibrate every group of `m` on a pool of `jobs` threads (0: one per core), skipping the
/// finished ones. Group failures are in the report, not an `Err`; `Err` is only for a pool
/// that cannot start.
pub fn run(m: &Manifest, jobs: usize, progress: bool) -> Result<FleetReport, TrainerError> {
    run_shard(m, jobs, progress, None)
}

/// `<manifest>.shard-I-of-N.json`, beside the manifest.
pub fn shard_summary_path(manifest: &Path, shard: Shard) -> PathBuf {
    let name = manifest.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "fleet".into());
    manifest.with_file_name(format!("{name}.shard-{}-of-{}.json", shard.index, shard.count))
}

/// [`run`] restricted to the groups of `shard` (all groups when `None`); a sharded run also
/// writes its report to [`shard_summary_path`] (atomically).
pub fn run_shard(
    m: &Manifest,
    jobs: usize,
    progress: bool,
    shard: Option<(Shard, ShardSource)>,
) -> Result<FleetReport, TrainerError> {
    run_shard_signed(m, jobs, progress, shard, manifest_sign(m).as_ref())
}

/// The signer of a run (`sign`, else none) and the groups marked with its key id.
pub(super) fn signed_groups(
    m: &Manifest,
    sign: Option<&SignOptions>,
) -> Result<(Vec<Group>, Option<BlobSigner>), TrainerError> {
    let signer = sign.map(BlobSigner::load).transpose()?;
    let id = signer.as_ref().map(|s| s.key_id().to_string());
    let groups = m.groups.iter().map(|g| Group { signed_by: id.clone(), ..g.clone() }).collect();
    Ok((groups, signer))
}

/// [`run_shard`] signing every blob as `sign` says (overriding the manifest's key).
pub fn run_shard_signed(
    m: &Manifest,
    jobs: usize,
    progress: bool,
    shard: Option<(Shard, ShardSource)>,
    sign: Option<&SignOptions>,
) -> Result<FleetReport, TrainerError> {
    let (all, signer) = signed_groups(m, sign)?;
    let signer = signer.as_ref();
    let summary = shard.map(|(s, _)| shard_summary_path(&m.path, s));
    let outside = m.check_paths(signer, summary.as_deref())?;
    if !outside.is_empty() {
        let shown: Vec<String> = outside.iter().take(3).map(|p| format!("`{}`", p.display())).collect();
        eprintln!(
            "note: {} output(s) outside the manifest's directory, allowed by --allow-outside: {}{}",
            outside.len(),
            shown.join(", "),
            if outside.len() > 3 { ", …" } else { "" }
        );
    }
    let mine: Vec<&Group> = all.iter().filter(|g| shard.is_none_or(|(s, _)| s.contains(&g.name))).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| TrainerError::fit(format!("thread pool: {e}")))?;
    let bar = crate::progress::bar(progress, mine.len() as u64, "fleet");
    let t = Instant::now();
    let groups: Vec<GroupReport> = pool.install(|| {
        mine.par_iter()
            .with_max_len(1)
            .map(|g| {
                let r = run_group(g, signer);
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();
    let count = |f: fn(&Outcome) -> bool| groups.iter().filter(|g| f(&g.outcome)).count();
    let trained = count(|o| matches!(o, Outcome::Trained { .. }));
    let shard = shard.map(|(s, source)| ShardInfo {
        index: s.index,
        count: s.count,
        source,
        groups_in_shard: mine.len(),
        groups_in_manifest: m.groups.len(),
        summary: shard_summary_path(&m.path, s),
    });
    let report = FleetReport {
        manifest: m.path.clone(),
        shard,
        jobs: pool.current_num_threads(),
        trained,
        skipped: count(|o| matches!(o, Outcome::Skipped)),
        failed: count(|o| matches!(o, Outcome::Failed { .. })),
        trained_per_second: if seconds > 0.0 { trained as f64 / seconds } else { 0.0 },
        seconds,
        groups,
    };
    if let Some(sh) = &report.shard {
        let text = serde_json::to_string_pretty(&report).map_err(|e| TrainerError::fit(e.to_string()))?;
        write_bytes_atomically(&sh.summary, text.as_bytes())?;
    }
    Ok(report)
}

/// What `fbg-trainer fleet` runs: a manifest, its shard and how to sign.
#[derive(Clone, Debug, Default)]
pub struct FleetOptions {
    /// The manifest (TOML).
    pub manifest: PathBuf,
    /// Groups calibrated at once (threads of the pool; 0: one per core).
    pub jobs: usize,
    /// Run only shard `I/N` ([`Shard::resolve`]; else a batch engine's index, when set).
    pub shard: Option<String>,
    /// The shard count N for an index taken from the batch engine.
    pub shards: Option<usize>,
    /// Let groups write outside the manifest's directory ([`Manifest::allow_outside`]).
    pub allow_outside: bool,
    /// Sign with these options instead of the manifest's key; their serial ledger defaults to
    /// the manifest's `serial_state`.
    pub sign: Option<SignOptions>,
    /// A progress bar ([`crate::progress`]).
    pub progress: bool,
}

/// Read the manifest of `o` and run the fleet (the shard this task runs, when there is one).
pub fn run_manifest(o: &FleetOptions) -> Result<FleetReport, TrainerError> {
    // The shard first: a bad `--shard` is refused before the manifest is read.
    let shard = Shard::resolve(o.shard.as_deref(), o.shards, |k| std::env::var(k).ok())?;
    let m = Manifest { allow_outside: o.allow_outside, ..Manifest::from_file(&o.manifest)? };
    let sign = match &o.sign {
        Some(s) => Some(SignOptions { state_dir: s.state_dir.clone().or_else(|| m.serial_state.clone()), ..s.clone() }),
        None => manifest_sign(&m),
    };
    run_shard_signed(&m, o.jobs, o.progress, shard, sign.as_ref())
}
