//! `fbg-trainer fleet`: calibrate many sensor groups in parallel from one manifest.
//!
//! The manifest (TOML; relative paths are relative to the manifest's directory):
//!
//! ```toml
//! [defaults]               # optional: what a group does not say itself
//! features = "memory"      # memory | hysteresis-aware | latch | paper | all (as `train --features`)
//! max_centres = 32         # as `train --max-centres`
//! drift_spec_pm_per_sqrt_day = 1.9  # optional: as `train --drift-spec` (0 to 1000 pm/√day)
//! drift_gains = [1.0, 1.1, 1.2]     # optional: as `train --drift-gains` (one per grating)
//! sign = "keys/lab.key"    # optional: sign every blob (as `train --sign`; `fleet --sign` overrides)
//! serial_state = "state"   # optional: the serial ledger's directory (as `--serial-state`)
//!
//! [[group]]
//! name = "pier-3"          # unique
//! data = "pier-3.csv"      # dataset CSV (DESIGN §3 columns)
//! out = "models/pier-3.fbgm"
//! features = "paper"       # optional, overrides the default
//! max_centres = 16         # optional
//! drift_spec_pm_per_sqrt_day = 0.5  # optional, overrides the default
//! drift_gains = [1.0, 1.2, 0.9]     # optional, overrides the default
//! ```
//!
//! Each group is trained as `train` would (Model-H blob `out`, Model-P blob `<stem>-p.fbgm`,
//! `<stem>.coefficients.json`) and a sidecar `<stem>.fleet.json` records the group's input
//! digest (CRC-64/XZ over the CSV bytes and the group's options, the stated drift among them)
//! and the digest of the blob written; the four files are one output set ([`crate::data::files::set`]), so the record
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

mod manifest;
mod records;
mod run;
pub mod shard;
mod status;

pub use manifest::{Group, Manifest};

pub use run::{
    run, run_manifest, run_shard, run_shard_signed, shard_summary_path, FleetOptions, FleetReport, GroupReport,
    Outcome, ShardInfo,
};
pub use status::{status, status_from_file, GroupState, GroupStatus, StatusReport};

use crate::sign::SignOptions;

/// Default largest K of a group: as `train`.
pub const DEFAULT_MAX_CENTRES: usize = 32;
/// Format tag of the per-group sidecar.
pub(crate) const SIDECAR_FORMAT: &str = "fbg-trainer fleet group v1";
/// Format tag of the per-group failure record.
pub(crate) const FAILURE_FORMAT: &str = "fbg-trainer fleet failure v1";

/// The signing options a manifest's `[defaults]` give (`sign`, `serial_state`), when it signs.
fn manifest_sign(m: &Manifest) -> Option<SignOptions> {
    m.sign.as_ref().map(|key| SignOptions {
        key: key.clone(),
        state_dir: m.serial_state.clone(),
        ..SignOptions::default()
    })
}
