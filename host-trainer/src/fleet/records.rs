//! What a fleet leaves beside each group's blobs: the record of a finished fit (with the
//! digests of its inputs and of its blob) or of a failure, and whether a group is finished.

use serde::{Deserialize, Serialize};

use super::{Group, SIDECAR_FORMAT};
use crate::export;
use crate::fit;

pub(super) const CRC64: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_XZ);

/// Digest of a group's inputs: the CSV bytes, its `.record.json` sidecar's and the options
/// that shape the fit (features, K limit, stated drift, signing key).
pub(crate) fn input_digest(g: &Group, csv: &[u8]) -> String {
    let mut d = CRC64.digest();
    d.update(
        format!("features={};max_centres={};trainer={};", g.features.name(), g.max_centres, env!("CARGO_PKG_VERSION"))
            .as_bytes(),
    );
    // Only when signing, so that the digests of unsigned runs stay what they were.
    if let Some(id) = &g.signed_by {
        d.update(format!("sign={id};").as_bytes());
    }
    // Likewise only when stated, so that the digests of groups without it stay what they were.
    if let Some(spec) = g.drift_spec_pm_per_sqrt_day {
        d.update(format!("drift_spec_pm_per_sqrt_day={spec:?};").as_bytes());
    }
    if let Some(gains) = &g.drift_gains {
        d.update(format!("drift_gains={gains:?};").as_bytes());
    }
    d.update(&(csv.len() as u64).to_le_bytes());
    d.update(csv);
    // The record's zero and clock shape the blob too; only when there is a sidecar, so that
    // the digests of records without one stay what they were.
    if let Ok(side) = std::fs::read(crate::data::record_meta::sidecar_path(&g.data)) {
        d.update(b"record sidecar;");
        d.update(&(side.len() as u64).to_le_bytes());
        d.update(&side);
    }
    format!("crc64:{:016x}:{}", d.finalize(), csv.len())
}

/// Digest of a written blob.
pub(crate) fn blob_digest(bytes: &[u8]) -> String {
    format!("crc64:{:016x}:{}", CRC64.checksum(bytes), bytes.len())
}

/// The per-group record written after a successful fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Sidecar {
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
pub(crate) struct FailureRecord {
    pub format: String,
    pub name: String,
    /// Digest of the inputs the run failed on.
    pub input_digest: String,
    pub error: String,
}

/// Why group `g` must be (re)trained, or `None` when its outputs are finished for `digest`.
pub(crate) fn needs_training(g: &Group, digest: &str) -> Option<String> {
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
