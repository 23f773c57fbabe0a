//! `fleet status`: every group's state from the files on disk, nothing trained.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::records::{input_digest, needs_training, FailureRecord};
use super::run::signed_groups;
use super::{manifest_sign, shard, Group, Manifest, FAILURE_FORMAT};
use crate::error::TrainerError;

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
    match signed_groups(m, manifest_sign(m).as_ref()) {
        Ok((groups, _)) => status_of(m, &groups, shards),
        Err(_) => status_of(m, &m.groups, shards),
    }
}

/// Read the manifest at `path` and every group's records; `shards` as [`status`] (at least 1).
pub fn status_from_file(path: &Path, shards: Option<usize>) -> Result<StatusReport, TrainerError> {
    if shards == Some(0) {
        return Err(TrainerError::Config {
            origin: "fleet status".into(),
            key: "shards".into(),
            message: "must be at least 1".into(),
        });
    }
    Ok(status(&Manifest::from_file(path)?, shards))
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
