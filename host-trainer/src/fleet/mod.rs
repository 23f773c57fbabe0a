//! `fbg-trainer fleet`: calibrate many sensor groups in parallel from one manifest.
//!
//! The manifest (TOML; relative paths are relative to the manifest's directory):
//!
//! ```toml
//! [defaults]               # optional: what a group does not say itself
//! features = "memory"      # memory | hysteresis-aware | latch | paper | all (as `train --features`)
//! max_centres = 32         # as `train --max-centres`
//! sign = "keys/lab.key"    # optional: sign every blob (as `train --sign`; `fleet --sign` overrides)
//! serial_state = "state"   # optional: the serial ledger's directory (as `--serial-state`)
//!
//! [[group]]
//! name = "pier-3"          # unique
//! data = "pier-3.csv"      # dataset CSV (DESIGN §3 columns)
//! out = "models/pier-3.fbgm"
//! features = "paper"       # optional, overrides the default
//! max_centres = 16         # optional
//! ```
//!
//! Each group is trained as `train` would (Model-H blob `out`, Model-P blob `<stem>-p.fbgm`,
//! `<stem>.coefficients.json`) and a sidecar `<stem>.fleet.json` records the group's input
//! digest (CRC-64/XZ over the CSV bytes and the group's options) and the digest of the blob
//! written; the four files are one output set ([`crate::data::files::set`]), so the record
//! always describes the blobs beside it. A later run skips a group whose blob exists, decodes, matches the
//! sidecar's blob digest and whose input digest is unchanged; anything else (no sidecar, an
//! interrupted run, a corrupt or replaced blob, changed data or options) is trained again.
//!
//! With a signing key each blob is signed with the next serial of the key (one serial per blob,
//! issued under the key's lock, so concurrent shards never share one) and the signatures are
//! recorded in the group's `coefficients.json`; the key id is part of the input digest, so
//! signing with another key (or starting to sign) redoes the group.
//!
//! Before any work, [`Manifest::check_paths`] refuses an output that is the manifest, a
//! group's data (or its `.meta.json`), the signing key's files or another output (by canonical
//! path and inode, so `sub/../m.fbgm`, symbolic and hard links count), and an output outside the
//! manifest's directory unless `--allow-outside`.
//!
//! Groups run on a local rayon pool of `--jobs` threads (the fit's own parallel loops run in
//! the same pool). A failing group is reported and the others go on; its failure is recorded
//! in `<stem>.fleet-failed.json` (removed when the group later succeeds).
//!
//! Beyond one machine, `--shard I/N` (or a batch engine's array index, see [`shard`])
//! runs only the groups of one shard. Shards write disjoint files, so any number can run at
//! once on shared storage; each writes its report to `<manifest>.shard-I-of-N.json`.
//! `fleet status` gathers every group's record into one table: done, failed (with the
//! reason), stale (the inputs changed since it finished) or missing.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::data::files::{write_bytes_atomically, OutputSet};
use crate::data::Dataset;
use crate::error::{line_col, TrainerError};
use crate::export;
use crate::fit::{self, FeatureChoice, Origin};
use crate::sign::{self, BlobSigner, SignArgs, SignOptions};
pub mod shard;

use crate::sim::meta::SimMeta;
use shard::{Shard, ShardSource};

/// Default largest K of a group: as `train`.
pub const DEFAULT_MAX_CENTRES: usize = 32;
/// Format tag of the per-group sidecar.
pub const SIDECAR_FORMAT: &str = "fbg-trainer fleet group v1";
/// Format tag of the per-group failure record.
pub const FAILURE_FORMAT: &str = "fbg-trainer fleet failure v1";

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    #[serde(default)]
    defaults: Defaults,
    #[serde(default)]
    group: Vec<GroupFile>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Defaults {
    features: Option<String>,
    max_centres: Option<usize>,
    sign: Option<PathBuf>,
    serial_state: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GroupFile {
    name: String,
    data: PathBuf,
    out: PathBuf,
    features: Option<String>,
    max_centres: Option<usize>,
}

/// One sensor group of a manifest, paths resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Group {
    pub name: String,
    pub data: PathBuf,
    pub out: PathBuf,
    pub features: FeatureChoice,
    pub max_centres: usize,
    /// The key id the group's blobs are signed with (hex), when the run signs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub signed_by: Option<String>,
}

impl Group {
    /// The Model-P blob beside the Model-H blob (`<stem>-p.fbgm`, as `train`).
    pub fn baseline_path(&self) -> PathBuf {
        self.out.with_file_name(format!("{}-p.fbgm", self.stem()))
    }
    /// `<stem>.coefficients.json`.
    pub fn coefficients_path(&self) -> PathBuf {
        crate::export::coefficients_path(&self.out)
    }
    /// `<stem>.fleet.json`: the record that the group finished.
    pub fn sidecar_path(&self) -> PathBuf {
        self.out.with_file_name(format!("{}.fleet.json", self.stem()))
    }
    /// `<stem>.fleet-failed.json`: the record of the group's last failure.
    pub fn failure_path(&self) -> PathBuf {
        self.out.with_file_name(format!("{}.fleet-failed.json", self.stem()))
    }
    fn stem(&self) -> String {
        self.out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "model".into())
    }
}

/// A parsed, validated manifest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Manifest {
    pub path: PathBuf,
    pub groups: Vec<Group>,
    /// `[defaults] sign`: the private key every blob is signed with (resolved).
    pub sign: Option<PathBuf>,
    /// `[defaults] serial_state`: the signing state directory (the key id's serial ledger;
    /// resolved; `None`: as `train --sign` finds it, `fbg_trainer::sign::state_dir`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub serial_state: Option<PathBuf>,
    /// Outputs may lie outside the manifest's directory (`fleet --allow-outside`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub allow_outside: bool,
}

fn config_error(origin: &Path, key: impl Into<String>, message: impl Into<String>) -> TrainerError {
    TrainerError::Config { origin: origin.display().to_string(), key: key.into(), message: message.into() }
}

impl Manifest {
    /// Read and validate a manifest file; errors name the file and the key
    /// (`group[2].max_centres`, ...).
    pub fn from_file(path: &Path) -> Result<Manifest, TrainerError> {
        let text = std::fs::read_to_string(path).map_err(|e| TrainerError::io(path, e))?;
        Self::from_str_at(&text, path)
    }

    /// Parse manifest text as if read from `path` (relative paths resolve against its
    /// directory).
    pub fn from_str_at(text: &str, path: &Path) -> Result<Manifest, TrainerError> {
        let raw: ManifestFile = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| line_col(text, s.start)).unwrap_or_default();
            config_error(path, at, e.message().trim_end().to_string())
        })?;
        if raw.group.is_empty() {
            return Err(config_error(path, "group", "no [[group]] in the manifest"));
        }
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let resolve = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
        let mut groups: Vec<Group> = Vec::with_capacity(raw.group.len());
        let mut names: HashMap<String, usize> = HashMap::with_capacity(raw.group.len());
        let mut blobs: HashMap<PathBuf, usize> = HashMap::with_capacity(2 * raw.group.len());
        for (i, g) in raw.group.into_iter().enumerate() {
            let key = |k: &str| format!("group[{i}].{k}");
            if g.name.trim().is_empty() {
                return Err(config_error(path, key("name"), "must not be empty"));
            }
            if let Some(j) = names.insert(g.name.clone(), i) {
                return Err(config_error(path, key("name"), format!("`{}` is also the name of group[{j}]", g.name)));
            }
            if g.out.file_name().is_none() {
                return Err(config_error(path, key("out"), "must name a file"));
            }
            let (own_features, own_max) = (g.features.is_some(), g.max_centres.is_some());
            let max_centres = g.max_centres.or(raw.defaults.max_centres).unwrap_or(DEFAULT_MAX_CENTRES);
            let which = |k: &str, own: bool| if own { key(k) } else { format!("defaults.{k}") };
            let features = match g.features.as_deref().or(raw.defaults.features.as_deref()) {
                None => FeatureChoice::default(),
                Some(name) => FeatureChoice::from_name(name).ok_or_else(|| {
                    config_error(
                        path,
                        which("features", own_features),
                        format!("unknown feature set `{name}` (memory, hysteresis-aware, paper, all)"),
                    )
                })?,
            };
            if let Err(m) = FeatureChoice::default().train_options(max_centres) {
                return Err(config_error(path, which("max_centres", own_max), m));
            }
            let group = Group {
                name: g.name,
                data: resolve(&g.data),
                out: resolve(&g.out),
                features,
                max_centres,
                signed_by: None,
            };
            for p in [lexical(&group.out), lexical(&group.baseline_path())] {
                if let Some(j) = blobs.insert(p, i).filter(|&j| j != i) {
                    let other = &groups[j].name;
                    return Err(config_error(
                        path,
                        key("out"),
                        format!("writes the same file as group[{j}] (`{other}`)"),
                    ));
                }
            }
            groups.push(group);
        }
        let sign = raw.defaults.sign.as_deref().map(resolve);
        let serial_state = raw.defaults.serial_state.as_deref().map(resolve);
        // Outputs that are the same file however spelt (`sub/../m.fbgm`), an input, or
        // outside the manifest's directory are refused by `check_paths` before any work.
        Ok(Manifest { path: path.to_path_buf(), groups, sign, serial_state, allow_outside: false })
    }

    /// Check every file the run may write (each group's blobs, coefficients, record and
    /// failure record; a shard's report) before any work (DESIGN §9): none may be the same
    /// file as another output or as an input (the manifest, any group's data or its
    /// `.meta.json`, the signing key's files), by canonical path or by device and inode; none
    /// may lie outside the manifest's directory unless [`Manifest::allow_outside`]. Returns
    /// the outputs outside it (allowed). Hashing: O(n log n) in the number of groups.
    pub fn check_paths(
        &self,
        signer: Option<&sign::BlobSigner>,
        shard_report: Option<&Path>,
    ) -> Result<Vec<PathBuf>, TrainerError> {
        use crate::data::files::{first_clash, Clash, Resolver};
        let mut r = Resolver::default();
        let mut outputs: Vec<(PathBuf, Option<usize>, &str)> = Vec::with_capacity(5 * self.groups.len() + 1);
        for (i, g) in self.groups.iter().enumerate() {
            outputs.push((g.out.clone(), Some(i), "its Model-H blob"));
            outputs.push((g.baseline_path(), Some(i), "its Model-P blob"));
            outputs.push((g.coefficients_path(), Some(i), "its coefficients"));
            outputs.push((g.sidecar_path(), Some(i), "its record"));
            outputs.push((g.failure_path(), Some(i), "its failure record"));
        }
        if let Some(p) = shard_report {
            outputs.push((p.to_path_buf(), None, "the shard's report"));
        }
        let mut inputs: Vec<(PathBuf, String)> = vec![(self.path.clone(), "the manifest".into())];
        for (i, g) in self.groups.iter().enumerate() {
            inputs.push((g.data.clone(), format!("group[{i}].data")));
            inputs.push((crate::sim::meta::meta_path(&g.data), format!("group[{i}].data's .meta.json")));
        }
        if let Some(s) = signer {
            for p in s.files_read() {
                inputs.push((p, "the signing key's files".into()));
            }
        }
        let outs: Vec<_> = outputs.iter().map(|(p, _, _)| r.resolve(p)).collect();
        let ins: Vec<_> = inputs.iter().map(|(p, _)| r.resolve(p)).collect();
        let key_of = |k: usize| outputs[k].1.map(|i| format!("group[{i}].out")).unwrap_or_else(|| "shard".into());
        if let Some((k, clash)) = first_clash(&outs, &ins) {
            let (p, _, what) = &outputs[k];
            let other = match clash {
                Clash::Input(j) => format!("{} (`{}`)", inputs[j].1, inputs[j].0.display()),
                Clash::Output(j) => format!("{} of {} (`{}`)", outputs[j].2, key_of(j), outputs[j].0.display()),
            };
            return Err(config_error(
                &self.path,
                key_of(k),
                format!("`{}` ({what}) is the same file as {other}; refusing to overwrite it", p.display()),
            ));
        }
        let base = r.resolve(&self.path.parent().map(|d| d.join(".")).unwrap_or_else(|| PathBuf::from("."))).canonical;
        let mut outside = Vec::new();
        for (k, o) in outs.iter().enumerate() {
            if o.canonical.starts_with(&base) {
                continue;
            }
            if !self.allow_outside {
                return Err(config_error(
                    &self.path,
                    key_of(k),
                    format!(
                        "`{}` is outside the manifest's directory `{}`; refusing to write there (pass --allow-outside to allow it)",
                        outputs[k].0.display(),
                        base.display()
                    ),
                ));
            }
            outside.push(outputs[k].0.clone());
        }
        Ok(outside)
    }
}

/// `path` with `.` dropped and `name/..` folded, as text only (the file system check,
/// [`Manifest::check_paths`], also sees symbolic and hard links).
fn lexical(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.components().next_back(), Some(Component::Normal(_))) => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

const CRC64: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_XZ);

/// Digest of a group's inputs: the CSV bytes and the options that shape the fit.
pub fn input_digest(g: &Group, csv: &[u8]) -> String {
    let mut d = CRC64.digest();
    d.update(
        format!("features={};max_centres={};trainer={};", g.features.name(), g.max_centres, env!("CARGO_PKG_VERSION"))
            .as_bytes(),
    );
    // Only when signing, so that the digests of unsigned runs stay what they were.
    if let Some(id) = &g.signed_by {
        d.update(format!("sign={id};").as_bytes());
    }
    d.update(&(csv.len() as u64).to_le_bytes());
    d.update(csv);
    format!("crc64:{:016x}:{}", d.finalize(), csv.len())
}

/// Digest of a written blob.
pub fn blob_digest(bytes: &[u8]) -> String {
    format!("crc64:{:016x}:{}", CRC64.checksum(bytes), bytes.len())
}

/// The per-group record written after a successful fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    pub format: String,
    pub name: String,
    pub input_digest: String,
    pub blob_digest: String,
    pub model_h_bytes: usize,
    pub model_p_bytes: usize,
    pub chosen_k: usize,
    pub chosen_features: String,
    pub cv_rmse_h: Vec<f64>,
    pub train_seconds: f64,
}

/// The record of a group's failed run (removed by its next successful run).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailureRecord {
    pub format: String,
    pub name: String,
    /// Digest of the inputs the run failed on.
    pub input_digest: String,
    pub error: String,
}

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

/// Why group `g` must be (re)trained, or `None` when its outputs are finished for `digest`.
pub fn needs_training(g: &Group, digest: &str) -> Option<String> {
    let side = g.sidecar_path();
    let Ok(text) = std::fs::read_to_string(&side) else { return Some("no record of a finished run".into()) };
    let Ok(rec) = serde_json::from_str::<Sidecar>(&text) else { return Some("unreadable record".into()) };
    if rec.format != SIDECAR_FORMAT || rec.name != g.name {
        return Some("record of another group".into());
    }
    if rec.input_digest != digest {
        return Some("input changed".into());
    }
    let Ok(bytes) = std::fs::read(&g.out) else { return Some("output missing".into()) };
    if blob_digest(&bytes) != rec.blob_digest || fbg_shared::blob::decode::<{ fit::HOST_CAP }>(&bytes).is_err() {
        return Some("output corrupt or replaced".into());
    }
    if export::read_blob(&g.baseline_path()).is_err() {
        return Some("Model-P output missing or corrupt".into());
    }
    None
}

fn train_group(g: &Group, digest: &str, signer: Option<&BlobSigner>) -> Result<Sidecar, TrainerError> {
    let t = Instant::now();
    let opts = g.features.train_options(g.max_centres).map_err(TrainerError::fit)?;
    let d = Dataset::read_csv(&g.data)?;
    let origin = match SimMeta::read_for(&g.data)? {
        Some(m) => Origin { scenario: m.scenario.name.clone(), seed: m.seed },
        None => Origin { scenario: g.name.clone(), seed: 0 },
    };
    let tr = fit::train_source(&d, &g.data.display().to_string(), &opts, &origin)?;
    // The blobs, the coefficients and the record are one output set: a kill or a failure
    // leaves the old group whole (its old record still matching its old blob) or the new one.
    let set = OutputSet::beside(&g.out)?;
    let (blob, sig_h) = sign::maybe_sign(export::blob_bytes(&tr.model_h)?, signer)?;
    let (blob_p, sig_p) = sign::maybe_sign(export::blob_bytes(&tr.model_p)?, signer)?;
    set.stage_bytes(&g.baseline_path(), &blob_p)?;
    let np = blob_p.len();
    let signatures = sig_h.map(|h| serde_json::json!({"model_h": h, "model_p": sig_p}));
    let coefficients = export::coefficients_text(
        &tr.model_p,
        &tr.model_h,
        &tr.core,
        Some(&tr.selection),
        Some(&tr.static_audit),
        signatures,
        &tr.warnings,
    )?;
    set.stage_bytes(&g.coefficients_path(), coefficients.as_bytes())?;
    set.stage_bytes(&g.out, &blob)?;
    let rec = Sidecar {
        format: SIDECAR_FORMAT.into(),
        name: g.name.clone(),
        input_digest: digest.to_string(),
        blob_digest: blob_digest(&blob),
        model_h_bytes: blob.len(),
        model_p_bytes: np,
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
    let sign = m.sign.as_ref().map(|key| SignOptions {
        key: key.clone(),
        state_dir: m.serial_state.clone(),
        ..SignOptions::default()
    });
    run_shard_signed(m, jobs, progress, shard, sign.as_ref())
}

/// The signer of a run (`sign`, else none) and the groups marked with its key id.
fn signed_groups(m: &Manifest, sign: Option<&SignOptions>) -> Result<(Vec<Group>, Option<BlobSigner>), TrainerError> {
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
    let bar = fit::select::progress_bar(progress, mine.len() as u64, "fleet");
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

/// A group's state for `fleet status`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GroupState {
    /// Finished for its current inputs (outputs present and matching the record).
    Done,
    /// The last run on its current inputs failed.
    Failed,
    /// Finished once, but its data or options changed since.
    Stale,
    /// Never finished, or its outputs are gone or damaged.
    Missing,
}

/// One group's line of `fleet status`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupStatus {
    pub name: String,
    pub out: PathBuf,
    /// Its shard, when a shard count was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shard: Option<usize>,
    pub state: GroupState,
    /// Why it is not done (the failure's error, what changed, what is missing).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// `fleet status`: every group of a manifest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatusReport {
    pub manifest: PathBuf,
    pub shards: Option<usize>,
    pub groups: Vec<GroupStatus>,
    /// Groups per state: done, failed, stale, missing.
    pub counts: std::collections::BTreeMap<&'static str, usize>,
    /// Every group done.
    pub all_done: bool,
}

/// The state of every group of `m` from the files on disk (nothing is trained); `shards` adds
/// each group's shard of that many.
/// A signing manifest's digests include the key id: an unreadable key reads as unsigned, so
/// its groups show as stale.
pub fn status(m: &Manifest, shards: Option<usize>) -> StatusReport {
    let sign = m.sign.as_ref().map(|key| SignOptions {
        key: key.clone(),
        state_dir: m.serial_state.clone(),
        ..SignOptions::default()
    });
    match signed_groups(m, sign.as_ref()) {
        Ok((groups, _)) => status_of(m, &groups, shards),
        Err(_) => status_of(m, &m.groups, shards),
    }
}

fn status_of(m: &Manifest, groups: &[Group], shards: Option<usize>) -> StatusReport {
    let groups: Vec<GroupStatus> = groups
        .par_iter()
        .map(|g| {
            let (state, reason) = group_state(g);
            GroupStatus {
                name: g.name.clone(),
                out: g.out.clone(),
                shard: shards.map(|n| shard::shard_of(&g.name, n)),
                state,
                reason,
            }
        })
        .collect();
    let mut counts = std::collections::BTreeMap::new();
    for (k, s) in [
        ("done", GroupState::Done),
        ("failed", GroupState::Failed),
        ("stale", GroupState::Stale),
        ("missing", GroupState::Missing),
    ] {
        counts.insert(k, groups.iter().filter(|g| g.state == s).count());
    }
    let all_done = groups.iter().all(|g| g.state == GroupState::Done);
    StatusReport { manifest: m.path.clone(), shards, groups, counts, all_done }
}

fn group_state(g: &Group) -> (GroupState, Option<String>) {
    let csv = match std::fs::read(&g.data) {
        Ok(b) => b,
        Err(e) => return (GroupState::Failed, Some(TrainerError::io(&g.data, e).to_string())),
    };
    let digest = input_digest(g, &csv);
    let Some(why) = needs_training(g, &digest) else { return (GroupState::Done, None) };
    let failure = std::fs::read_to_string(g.failure_path())
        .ok()
        .and_then(|t| serde_json::from_str::<FailureRecord>(&t).ok())
        .filter(|f| f.format == FAILURE_FORMAT && f.name == g.name && f.input_digest == digest);
    if let Some(f) = failure {
        return (GroupState::Failed, Some(f.error));
    }
    if why == "input changed" {
        return (GroupState::Stale, Some("data or options changed since it finished".into()));
    }
    (GroupState::Missing, Some(why))
}

impl StatusReport {
    /// One line per group that is not done (all of them with `all`), then the counts.
    pub fn text(&self, all: bool) -> String {
        let mut s = String::new();
        for g in self.groups.iter().filter(|g| all || g.state != GroupState::Done) {
            let state = match g.state {
                GroupState::Done => "done",
                GroupState::Failed => "FAILED",
                GroupState::Stale => "stale",
                GroupState::Missing => "missing",
            };
            let shard = g.shard.map(|i| format!(" [shard {i}]")).unwrap_or_default();
            s.push_str(&format!(
                "{:>20}{shard}  {state}{}\n",
                g.name,
                g.reason.as_deref().map(|r| format!(": {r}")).unwrap_or_default()
            ));
        }
        let c = |k: &str| self.counts.get(k).copied().unwrap_or(0);
        s.push_str(&format!(
            "{} groups: {} done, {} failed, {} stale, {} missing{}",
            self.groups.len(),
            c("done"),
            c("failed"),
            c("stale"),
            c("missing"),
            if self.all_done { " — all done" } else { "" }
        ));
        s
    }
}

/// `fbg-trainer fleet`: calibrate the sensor groups of a manifest in parallel.
#[derive(clap::Args, Clone, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct FleetArgs {
    #[command(subcommand)]
    pub command: Option<FleetCommand>,
    /// Manifest (TOML): `[[group]]` tables with name, data, out and optional features /
    /// max_centres; `[defaults]` for the options groups leave out.
    #[arg(long, required = true)]
    pub manifest: Option<PathBuf>,
    /// Groups calibrated at once (threads of the pool; 0: one per core).
    #[arg(long, default_value_t = 0)]
    pub jobs: usize,
    /// Run only the groups of shard I of N (I from 0; a group's shard is CRC-64/XZ of its name
    /// mod N). Without it, a Slurm array task or Kubernetes Indexed Job index is used when set.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// The shard count N for an index taken from the batch engine (Slurm's
    /// SLURM_ARRAY_TASK_ID, Kubernetes' JOB_COMPLETION_INDEX); needed for Kubernetes and for a
    /// resubmitted subset of a Slurm array.
    #[arg(long, value_name = "N")]
    pub shards: Option<usize>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Let groups write outside the manifest's directory (`../x`, absolute paths elsewhere);
    /// refused by default, and said on stderr when allowed.
    #[arg(long)]
    pub allow_outside: bool,
    #[command(flatten)]
    pub sign: SignArgs,
}

/// `fleet` subcommands.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum FleetCommand {
    /// Every group's state from the files on disk (done, failed with the reason, stale because
    /// its inputs changed, missing); exits non-zero unless all are done. Trains nothing.
    Status(StatusArgs),
}

/// `fbg-trainer fleet status`.
#[derive(clap::Args, Clone, Debug)]
pub struct StatusArgs {
    /// The manifest the groups come from.
    #[arg(long)]
    pub manifest: PathBuf,
    /// Also show each group's shard of N.
    #[arg(long, value_name = "N")]
    pub shards: Option<usize>,
    /// List every group, done ones included.
    #[arg(long)]
    pub all: bool,
    /// Print the status as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

impl FleetArgs {
    /// Read the manifest and run the fleet (the shard this task runs, when there is one).
    pub fn run(&self) -> Result<FleetReport, TrainerError> {
        let path = self.manifest.as_deref().ok_or_else(|| TrainerError::Config {
            origin: "fleet".into(),
            key: "manifest".into(),
            message: "--manifest is required".into(),
        })?;
        let m = Manifest { allow_outside: self.allow_outside, ..Manifest::from_file(path)? };
        let shard = Shard::resolve(self.shard.as_deref(), self.shards, |k| std::env::var(k).ok())?;
        let sign = self
            .sign
            .options()
            .map(|o| SignOptions { state_dir: o.state_dir.clone().or_else(|| m.serial_state.clone()), ..o })
            .or_else(|| {
                m.sign.as_ref().map(|key| SignOptions {
                    key: key.clone(),
                    serial: self.sign.serial,
                    allow_rollback: self.sign.allow_rollback,
                    replaces: self.sign.replaces,
                    state_dir: self.sign.serial_state.clone().or_else(|| m.serial_state.clone()),
                })
            });
        run_shard_signed(&m, self.jobs, !self.json, shard, sign.as_ref())
    }
}

impl StatusArgs {
    /// Read the manifest and every group's records.
    pub fn run(&self) -> Result<StatusReport, TrainerError> {
        if self.shards == Some(0) {
            return Err(TrainerError::Config {
                origin: "fleet status".into(),
                key: "shards".into(),
                message: "must be at least 1".into(),
            });
        }
        Ok(status(&Manifest::from_file(&self.manifest)?, self.shards))
    }
}
