//! Warnings as data: what `train`, `evaluate`, `compensate` and `recalibrate` find worth a
//! user's attention, with a stable code, the channel it concerns and the numbers behind it.
//! The terminal prints [`Warning::message`]; `coefficients.json`, `metrics.json` and the report
//! carry the whole record, so nothing a command said is lost once the terminal is closed.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// One warning.
///
/// ```
/// use fbg_report::Warning;
/// let w = Warning::new("model_h_worse_cv", "Model-H is worse than Model-P on T in cross-validation")
///     .on_channel("T")
///     .with("cv_rmse_h_c", 0.31)
///     .with("cv_rmse_p_c", 0.25);
/// assert_eq!(w.to_string(), "Model-H is worse than Model-P on T in cross-validation");
/// assert_eq!(w.numbers["cv_rmse_h_c"], 0.31);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Warning {
    /// Stable machine-readable code (`snake_case`), e.g. `model_h_worse_cv`.
    pub code: String,
    /// The output channel it concerns (`T`, `strain2`, …), when it concerns one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel: Option<String>,
    /// The sentence shown to a person.
    pub message: String,
    /// The figures behind it, named with their unit (`rmse_c`, `coverage_pct`, …).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub numbers: BTreeMap<String, f64>,
}

impl Warning {
    /// A warning with a code and a message, no channel and no numbers.
    pub fn new(code: impl Into<String>, message: impl Into<String>) -> Warning {
        Warning { code: code.into(), channel: None, message: message.into(), numbers: BTreeMap::new() }
    }

    /// The same warning about `channel`.
    pub fn on_channel(mut self, channel: impl Into<String>) -> Warning {
        self.channel = Some(channel.into());
        self
    }

    /// The same warning with one more named figure (non-finite figures are kept out: JSON has
    /// no NaN).
    pub fn with(mut self, name: impl Into<String>, value: f64) -> Warning {
        if value.is_finite() {
            self.numbers.insert(name.into(), value);
        }
        self
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}
