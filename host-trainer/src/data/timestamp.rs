//! Calendar timestamps as seconds since 1970-01-01 and back: read from a file's time cells,
//! a map or the command line, written for a record's start and a model's end of calibration.
//! A timestamp without an offset is taken as it is, with no time-zone conversion.

use chrono::{DateTime, NaiveDateTime};

/// Timestamp layouts tried when no `format` is given.
const NAIVE_FORMATS: [&str; 6] = [
    "%Y-%m-%dT%H:%M:%S%.f",
    "%Y-%m-%d %H:%M:%S%.f",
    "%Y/%m/%d %H:%M:%S%.f",
    "%Y-%m-%dT%H:%M",
    "%Y-%m-%d %H:%M",
    "%Y/%m/%d %H:%M",
];

/// Parse a calendar timestamp: ISO-8601 / RFC 3339 (with or without an offset, `T` or space),
/// `YYYY-MM-DD hh:mm:ss[.fff]`, `YYYY/MM/DD hh:mm:ss[.fff]`, or a chrono `format`.
pub fn parse_timestamp(s: &str, format: Option<&str>) -> Option<f64> {
    let s = s.trim();
    if let Some(f) = format {
        if f.contains("%z") || f.contains("%:z") || f.contains("%#z") {
            return DateTime::parse_from_str(s, f).ok().map(|d| secs(d.naive_utc()));
        }
        return NaiveDateTime::parse_from_str(s, f).ok().map(secs);
    }
    // Cheap guard: every layout starts with a four-digit year.
    if s.len() < 10 || !s.as_bytes()[..4].iter().all(u8::is_ascii_digit) {
        return None;
    }
    if let Ok(d) = DateTime::parse_from_rfc3339(s) {
        return Some(secs(d.naive_utc()));
    }
    for f in ["%Y-%m-%d %H:%M:%S%.f%#z", "%Y-%m-%dT%H:%M:%S%.f%#z"] {
        if let Ok(d) = DateTime::parse_from_str(s, f) {
            return Some(secs(d.naive_utc()));
        }
    }
    let s = s.strip_suffix('Z').unwrap_or(s);
    NAIVE_FORMATS.iter().find_map(|f| NaiveDateTime::parse_from_str(s, f).ok()).map(secs)
}

/// Seconds since 1970-01-01 of a time in the file's own clock.
pub(crate) fn secs(d: NaiveDateTime) -> f64 {
    let u = d.and_utc();
    u.timestamp() as f64 + f64::from(u.timestamp_subsec_nanos()) * 1e-9
}

/// [`format_timestamp`] marked as UTC (`…Z`): how a record's start and a model's end of
/// calibration are written for people and files.
pub fn format_utc(t: f64) -> String {
    format!("{}Z", format_timestamp(t))
}

/// A time on the axis, written back as `YYYY-MM-DDThh:mm:ss.fff` (for summaries).
pub fn format_timestamp(t: f64) -> String {
    let whole = t.floor();
    let nanos = ((t - whole) * 1e9).round().min(999_999_999.0) as u32;
    match DateTime::from_timestamp(whole as i64, nanos) {
        Some(d) => d.naive_utc().format("%Y-%m-%dT%H:%M:%S%.3f").to_string(),
        None => format!("{t} s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts() {
        let a = parse_timestamp("2024-03-01 10:00:00", None).unwrap();
        assert_eq!(parse_timestamp("2024-03-01T10:00:00", None), Some(a));
        assert_eq!(parse_timestamp("2024-03-01T10:00:00Z", None), Some(a));
        assert_eq!(parse_timestamp("2024-03-01T11:00:00+01:00", None), Some(a));
        assert_eq!(parse_timestamp("2024-03-01 11:00:00+01:00", None), Some(a));
        assert_eq!(parse_timestamp("2024/03/01 10:00:00", None), Some(a));
        assert!((parse_timestamp("2024-03-01 10:00:00.2500", None).unwrap() - a - 0.25).abs() < 1e-6);
        assert_eq!(parse_timestamp("01.03.2024 10:00:00", Some("%d.%m.%Y %H:%M:%S")), Some(a));
        assert_eq!(parse_timestamp("1535.2", None), None);
        assert_eq!(parse_timestamp("Timestamp", None), None);
        assert_eq!(format_timestamp(a + 0.25), "2024-03-01T10:00:00.250");
    }
}
