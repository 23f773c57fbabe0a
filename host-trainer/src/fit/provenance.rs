//! What a model records of its making (`fbg_shared::Provenance`): the scenario and seed of its
//! data, the trainer's version, the date, the calibration samples.

use chrono::{DateTime, Datelike};

use fbg_shared::Provenance;

/// What the training knows about its data, for the model's provenance.
#[derive(Clone, Debug, Default)]
pub struct Origin {
    /// The scenario's (or the data file's) name.
    pub scenario: String,
    /// The simulation seed (0 for measured data).
    pub seed: u64,
}

/// The provenance of a model trained today on `n_cal` calibration samples of `origin`.
pub(crate) fn provenance(origin: &Origin, n_cal: usize) -> Provenance {
    let mut scenario = heapless::String::new();
    for ch in origin.scenario.chars() {
        if scenario.push(ch).is_err() {
            break;
        }
    }
    let mut trainer_version = heapless::String::new();
    for ch in env!("CARGO_PKG_VERSION").chars() {
        if trainer_version.push(ch).is_err() {
            break;
        }
    }
    Provenance { seed: origin.seed, scenario, trainer_version, date_yyyymmdd: today_yyyymmdd(), n_cal: n_cal as u32 }
}

/// Today's date (UTC) as YYYYMMDD, or `SOURCE_DATE_EPOCH`'s for reproducible builds (0 for an
/// epoch beyond the dates chrono represents).
pub(crate) fn today_yyyymmdd() -> u32 {
    let secs = std::env::var("SOURCE_DATE_EPOCH").ok().and_then(|s| s.parse::<u64>().ok()).unwrap_or_else(|| {
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0)
    });
    yyyymmdd(secs)
}

/// The UTC date of `secs` since the Unix epoch as YYYYMMDD (0 beyond chrono's range).
fn yyyymmdd(secs: u64) -> u32 {
    let Some(t) = i64::try_from(secs).ok().and_then(|s| DateTime::from_timestamp(s, 0)) else {
        return 0;
    };
    let d = t.date_naive();
    u32::try_from(d.year()).map_or(0, |y| y * 10_000 + d.month() * 100 + d.day())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_of_epoch_seconds() {
        assert_eq!(yyyymmdd(0), 19700101);
        // The last second of a leap day, and the first of the day after.
        assert_eq!(yyyymmdd(951_868_799), 20000229);
        assert_eq!(yyyymmdd(951_868_800), 20000301);
        assert_eq!(yyyymmdd(1_798_761_599), 20261231);
        assert_eq!(yyyymmdd(u64::MAX), 0);
    }
}
