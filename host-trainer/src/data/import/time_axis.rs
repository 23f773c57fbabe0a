//! Time cells: seconds (or ms, min, h) or calendar timestamps, on one axis of f64 seconds
//! (timestamps: seconds since 1970-01-01 in the file's own clock; a timestamp without an
//! offset is taken as it is, with no time-zone conversion).

use chrono::{DateTime, NaiveDateTime};
use serde::{Deserialize, Serialize};

/// How the time column is written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeUnit {
    /// Numbers are seconds, anything else a timestamp (decided on the first data row).
    #[default]
    Auto,
    S,
    Ms,
    Min,
    H,
    /// Calendar timestamps only.
    Timestamp,
}

/// What the time axis of a file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeKind {
    /// Numbers of seconds from an arbitrary origin.
    Seconds,
    /// Calendar timestamps.
    Timestamp,
}

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

fn secs(d: NaiveDateTime) -> f64 {
    let u = d.and_utc();
    u.timestamp() as f64 + f64::from(u.timestamp_subsec_nanos()) * 1e-9
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

/// Parses the time cells of one file; the kind is fixed by the first cell parsed.
#[derive(Clone, Debug)]
pub(crate) struct TimeParser {
    unit: TimeUnit,
    format: Option<String>,
    /// Timestamp of t = 0 for a file in seconds (so it can be joined with a timestamped one).
    start: Option<f64>,
    pub kind: Option<TimeKind>,
}

impl TimeParser {
    pub fn new(unit: TimeUnit, format: Option<String>, start: Option<f64>) -> Self {
        let kind = match unit {
            TimeUnit::Auto => None,
            TimeUnit::Timestamp => Some(TimeKind::Timestamp),
            _ => Some(TimeKind::Seconds),
        };
        let kind = if format.is_some() { Some(TimeKind::Timestamp) } else { kind };
        TimeParser { unit, format, start, kind }
    }

    /// True when the axis is calendar time (timestamps, or seconds with a `start`).
    pub fn absolute(&self) -> bool {
        self.kind == Some(TimeKind::Timestamp) || self.start.is_some()
    }

    /// Whether `cell` would parse, without fixing the kind (to find the first data line).
    pub fn probe(&self, cell: &str) -> bool {
        self.clone().parse(cell).is_ok()
    }

    /// The time of `cell` on the axis [s], or why it is not a time.
    pub fn parse(&mut self, cell: &str) -> Result<f64, String> {
        let cell = cell.trim();
        if cell.is_empty() {
            return Err("empty time cell".into());
        }
        let kind = match self.kind {
            Some(k) => k,
            None if cell.parse::<f64>().is_ok() => TimeKind::Seconds,
            None => TimeKind::Timestamp,
        };
        let t = match kind {
            TimeKind::Seconds => {
                let v: f64 = cell.parse().map_err(|_| format!("`{cell}` is not a number of seconds"))?;
                if !v.is_finite() {
                    return Err(format!("`{cell}` is not a finite time"));
                }
                let scale = match self.unit {
                    TimeUnit::Ms => 1e-3,
                    TimeUnit::Min => 60.0,
                    TimeUnit::H => 3600.0,
                    _ => 1.0,
                };
                v * scale + self.start.unwrap_or(0.0)
            }
            TimeKind::Timestamp => parse_timestamp(cell, self.format.as_deref()).ok_or_else(|| match &self.format {
                Some(f) => format!("`{cell}` is not a timestamp of the form `{f}`"),
                None => format!(
                    "`{cell}` is not a timestamp (YYYY-MM-DD hh:mm:ss[.fff], ISO-8601; other layouts: set a chrono `format`)"
                ),
            })?,
        };
        self.kind = Some(kind);
        Ok(t)
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

    #[test]
    fn seconds_and_units() {
        let mut p = TimeParser::new(TimeUnit::Auto, None, None);
        assert_eq!(p.parse("12.5"), Ok(12.5));
        assert!(p.parse("2024-03-01 10:00:00").is_err());
        let mut p = TimeParser::new(TimeUnit::Ms, None, Some(100.0));
        assert_eq!(p.parse("1500"), Ok(101.5));
        assert!(p.absolute());
    }
}
