//! The intensity scale of a spectrum file: linear (counts, mW) or dB.

use serde::{Deserialize, Serialize};

/// How a file writes its intensities. The detector works on linear intensities: dB levels are
/// converted with `fbg_shared::spectrum::from_db` (10^(dB/10)) as they are read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// Linear intensities (raw counts, mW, any linear unit).
    #[default]
    Linear,
    /// Levels in dB (dBm, or dB against any reference).
    Db,
}

impl Scale {
    /// `linear` or `db`.
    pub fn name(self) -> &'static str {
        match self {
            Scale::Linear => "linear",
            Scale::Db => "db",
        }
    }
}

impl std::str::FromStr for Scale {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "linear" | "lin" => Ok(Scale::Linear),
            "db" | "dbm" => Ok(Scale::Db),
            other => Err(format!("`{other}` is neither `linear` nor `db`")),
        }
    }
}
