//! The model variant a user picks with `--features`: `train` and `bench-fit --select` on the
//! command line, a group's `features` in a fleet manifest.

use fbg_shared::layout::FeatureSet;

use super::host::HOST_CAP;
use super::memory_core::MemoryOptions;
use super::options::TrainOptions;

/// The model variant of a `--features` name: the RBF feature sets cross-validation may choose
/// from and whether the memory bank is on the menu.
///
/// - `memory` (the default): memory terms fitted on what the core leaves, plus an RBF residual on
///   [Δλ, T_amb, latches];
/// - `hysteresis-aware`: no memory terms, RBF on latches (and time if CV keeps it);
/// - `latch`: the same as `hysteresis-aware` (its name when it was the default);
/// - `paper`: paper Eq. 5 exactly;
/// - `all`: memory terms and every feature set.
///
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FeatureChoice {
    #[default]
    Memory,
    HysteresisAware,
    Latch,
    Paper,
    All,
}

impl FeatureChoice {
    /// Every variant, in the order `--help` lists them.
    pub const ALL: [FeatureChoice; 5] = [
        FeatureChoice::Memory,
        FeatureChoice::HysteresisAware,
        FeatureChoice::Latch,
        FeatureChoice::Paper,
        FeatureChoice::All,
    ];

    /// The name on the command line and in a manifest.
    pub fn name(self) -> &'static str {
        match self {
            FeatureChoice::Memory => "memory",
            FeatureChoice::HysteresisAware => "hysteresis-aware",
            FeatureChoice::Latch => "latch",
            FeatureChoice::Paper => "paper",
            FeatureChoice::All => "all",
        }
    }

    /// The variant of a name as [`FeatureChoice::name`] spells it (`None` for an unknown name).
    pub(crate) fn from_name(name: &str) -> Option<FeatureChoice> {
        FeatureChoice::ALL.into_iter().find(|c| c.name() == name)
    }

    /// The RBF feature sets cross-validation may choose from.
    pub(crate) fn feature_sets(self) -> Vec<FeatureSet> {
        match self {
            FeatureChoice::Memory => vec![FeatureSet::HysteresisAware],
            FeatureChoice::Paper => vec![FeatureSet::Paper],
            FeatureChoice::HysteresisAware | FeatureChoice::Latch => {
                vec![FeatureSet::HysteresisAware, FeatureSet::HysteresisAwareTime]
            }
            FeatureChoice::All => FeatureSet::ALL.to_vec(),
        }
    }

    /// Whether memory terms are on the menu.
    pub fn memory(self) -> bool {
        matches!(self, FeatureChoice::Memory | FeatureChoice::All)
    }

    /// Training options for this variant and a largest number of centres: the grid of
    /// `train --features F --max-centres K`.
    pub fn train_options(self, max_centres: usize) -> Result<TrainOptions, String> {
        if max_centres == 0 || max_centres > HOST_CAP {
            return Err(format!("max centres must be in 1..={HOST_CAP} (got {max_centres})"));
        }
        let mut o = TrainOptions::builder().feature_sets(self.feature_sets());
        let mut centres = TrainOptions::default().grid().centres().to_vec();
        if !self.memory() {
            // Without memory terms the RBF residual carries the model: the grid goes to 32.
            o = o.memory(MemoryOptions::off());
            centres = vec![8, 16, 32];
        }
        centres.retain(|&k| k <= max_centres);
        if centres.is_empty() {
            centres.push(max_centres);
        }
        o.centres(centres).check().map_err(|e| e.to_string())
    }
}

/// By its name ([`FeatureChoice::name`]); the error lists the names.
impl std::str::FromStr for FeatureChoice {
    type Err = String;
    fn from_str(name: &str) -> Result<Self, Self::Err> {
        FeatureChoice::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = FeatureChoice::ALL.iter().map(|c| c.name()).collect();
            format!("unknown feature set `{name}` ({})", names.join(", "))
        })
    }
}

/// As its name (a fleet group's `features` in `fleet --json`).
impl serde::Serialize for FeatureChoice {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for c in FeatureChoice::ALL {
            assert_eq!(FeatureChoice::from_name(c.name()), Some(c));
            assert_eq!(c.name().parse::<FeatureChoice>(), Ok(c));
        }
        assert_eq!(FeatureChoice::from_name("magic"), None);
        assert!("magic".parse::<FeatureChoice>().unwrap_err().contains("memory, hysteresis-aware, latch, paper, all"));
        assert_eq!(FeatureChoice::default(), FeatureChoice::Memory);
    }

    #[test]
    fn latch_is_hysteresis_aware() {
        assert_eq!(FeatureChoice::Latch.feature_sets(), FeatureChoice::HysteresisAware.feature_sets());
        assert_eq!(FeatureChoice::Latch.memory(), FeatureChoice::HysteresisAware.memory());
    }

    #[test]
    fn max_centres_bounds() {
        assert!(FeatureChoice::Memory.train_options(0).is_err());
        assert!(FeatureChoice::Memory.train_options(HOST_CAP + 1).is_err());
        assert_eq!(FeatureChoice::Paper.train_options(16).unwrap().grid().centres(), vec![8, 16]);
        assert_eq!(FeatureChoice::Paper.train_options(4).unwrap().grid().centres(), vec![4]);
    }
}
