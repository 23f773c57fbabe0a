//! Time cells: seconds (or ms, min, h) or calendar timestamps, on one axis of f64 seconds
//! (timestamps: seconds since 1970-01-01 in the file's own clock; a timestamp without an
//! offset is taken as it is, with no time-zone conversion).
//!
//! Numeric dates written in a locale's order (`01.03.2024 10:00:00`, `3/1/2024 10:00:00 AM`)
//! are read only when the caller says in which order (`Dmy`): `01/03/2024` is the 1st of March
//! day-first and January the 3rd month-first, and nothing in the cell tells which.

use chrono::{NaiveDate, NaiveTime};
use serde::{Deserialize, Serialize};

use crate::data::timestamp::{parse_timestamp, secs};
use crate::error::quote_cell;

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

/// Day/month order of a numeric date such as `01/03/2024`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DateOrder {
    /// `dd/mm/yyyy` (de-DE `dd.MM.yyyy`, en-GB and fr-FR `dd/MM/yyyy`).
    DayFirst,
    /// `mm/dd/yyyy` (en-US `M/d/yyyy`).
    MonthFirst,
}

impl DateOrder {
    /// `day-first (dd/mm/yyyy)` or `month-first (mm/dd/yyyy)`.
    pub fn words(self) -> &'static str {
        match self {
            DateOrder::DayFirst => "day-first (dd/mm/yyyy)",
            DateOrder::MonthFirst => "month-first (mm/dd/yyyy)",
        }
    }
}

/// Whether (and how) a [`TimeParser`] reads numeric dates in a locale's day/month order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Dmy {
    /// Not read (only year-first layouts and a chrono `format`).
    Off,
    /// Either order (to find the first data row before the order is known; never to read a
    /// value).
    Probe,
    /// In this order.
    Order(DateOrder),
}

/// The two leading fields `a`, `b` of a numeric date `a/b/yyyy` (or `a.b.yyyy`, `a-b-yyyy`,
/// fields of 1 or 2 digits) at the start of `cell`, if it is one.
pub(crate) fn dmy_fields(cell: &str) -> Option<(u32, u32)> {
    let date = cell.trim().split([' ', 'T']).next()?;
    let sep = date.chars().find(|c| matches!(c, '.' | '/' | '-'))?;
    let f: Vec<&str> = date.split(sep).collect();
    let digits =
        |s: &str, n: std::ops::RangeInclusive<usize>| n.contains(&s.len()) && s.bytes().all(|b| b.is_ascii_digit());
    if f.len() != 3 || !digits(f[0], 1..=2) || !digits(f[1], 1..=2) || !digits(f[2], 4..=4) {
        return None;
    }
    Some((f[0].parse().ok()?, f[1].parse().ok()?))
}

/// A numeric date in `order` with an optional time: `dd.mm.yyyy[ hh:mm[:ss[.fff|,fff]]]`
/// (separators `.`, `/` or `-`; fields of 1 or 2 digits; an optional `AM`/`PM`).
pub(crate) fn parse_dmy(cell: &str, order: DateOrder) -> Result<f64, String> {
    let cell = cell.trim();
    let q = quote_cell(cell);
    let (a, b) = dmy_fields(cell).ok_or_else(|| format!("`{q}` is not a date of the form dd/mm/yyyy or mm/dd/yyyy"))?;
    let (day, month) = match order {
        DateOrder::DayFirst => (a, b),
        DateOrder::MonthFirst => (b, a),
    };
    let (date, rest) = cell.split_at(cell.find([' ', 'T']).unwrap_or(cell.len()));
    let year: i32 = date[date.len() - 4..].parse().map_err(|_| format!("`{q}`: no year"))?;
    let d = NaiveDate::from_ymd_opt(year, month, day).ok_or_else(|| {
        let what = if month > 12 { format!("month {month}") } else { format!("day {day} of month {month}") };
        format!("`{q}` is not a date read {}: there is no {what}", order.words())
    })?;
    let t = parse_clock(rest.trim_start_matches('T').trim()).ok_or_else(|| {
        format!("`{q}`: `{}` is not a time of day (hh:mm[:ss[.fff]] [AM|PM])", quote_cell(rest.trim()))
    })?;
    Ok(secs(d.and_time(t)))
}

/// `hh:mm[:ss[.fff|,fff]]` with an optional `AM`/`PM`; empty is midnight.
fn parse_clock(s: &str) -> Option<NaiveTime> {
    if s.is_empty() {
        return NaiveTime::from_hms_opt(0, 0, 0);
    }
    let upper = s.to_ascii_uppercase();
    let (clock, pm) = match upper.strip_suffix("AM").or_else(|| upper.strip_suffix("PM")) {
        Some(c) => (c.trim_end().to_string(), Some(upper.ends_with("PM"))),
        None => (upper.clone(), None),
    };
    let f: Vec<&str> = clock.split(':').collect();
    if !(2..=3).contains(&f.len()) {
        return None;
    }
    let int = |s: &str| -> Option<u32> {
        (1..=2).contains(&s.len()).then_some(())?;
        s.parse().ok()
    };
    let (mut h, m) = (int(f[0])?, int(f[1])?);
    let (sec, nanos) = match f.get(2) {
        None => (0, 0),
        Some(x) => {
            let (whole, frac) = x.split_once(['.', ',']).unwrap_or((x, ""));
            if !frac.bytes().all(|b| b.is_ascii_digit()) || frac.len() > 9 {
                return None;
            }
            let nanos = if frac.is_empty() { 0 } else { format!("{frac:0<9}").parse().ok()? };
            (int(whole)?, nanos)
        }
    };
    if let Some(pm) = pm {
        if !(1..=12).contains(&h) {
            return None;
        }
        h = match (h, pm) {
            (12, false) => 0,
            (12, true) => 12,
            (h, true) => h + 12,
            (h, false) => h,
        };
    }
    NaiveTime::from_hms_nano_opt(h, m, sec, nanos)
}

/// `cell` as a number written with a decimal comma (`1535,012`): a point is refused (it would
/// be a thousands separator in such a culture, or a sign that the culture is wrong).
pub(crate) fn decimal_comma_number(cell: &str) -> Result<f64, String> {
    let c = cell.trim();
    if c.contains('.') {
        return Err(format!(
            "`{}` has a point, but the file's culture writes a decimal comma (a point would be a thousands separator there): check the Culture line",
            quote_cell(c)
        ));
    }
    c.replace(',', ".").parse::<f64>().map_err(|_| format!("`{}` is not a number", quote_cell(c)))
}

/// Parses the time cells of one file; the kind is fixed by the first cell parsed.
#[derive(Clone, Debug)]
pub(crate) struct TimeParser {
    unit: TimeUnit,
    format: Option<String>,
    /// Timestamp of t = 0 for a file in seconds (so it can be joined with a timestamped one).
    start: Option<f64>,
    pub kind: Option<TimeKind>,
    /// Numbers of seconds are written with a decimal comma.
    decimal_comma: bool,
    /// Numeric dates in a locale's day/month order.
    pub dmy: Dmy,
}

impl TimeParser {
    pub fn new(unit: TimeUnit, format: Option<String>, start: Option<f64>) -> Self {
        let kind = match unit {
            TimeUnit::Auto => None,
            TimeUnit::Timestamp => Some(TimeKind::Timestamp),
            _ => Some(TimeKind::Seconds),
        };
        let kind = if format.is_some() { Some(TimeKind::Timestamp) } else { kind };
        TimeParser { unit, format, start, kind, decimal_comma: false, dmy: Dmy::Off }
    }

    /// The same parser reading seconds with a decimal comma (if `decimal_comma`) and numeric
    /// dates as `dmy` says.
    pub(crate) fn with_locale(mut self, decimal_comma: bool, dmy: Dmy) -> Self {
        self.decimal_comma = decimal_comma;
        self.dmy = dmy;
        self
    }

    /// `cell` as a number of seconds in this parser's decimal mark.
    fn seconds(&self, cell: &str) -> Result<f64, String> {
        if self.decimal_comma {
            decimal_comma_number(cell)
        } else {
            cell.parse().map_err(|_| format!("`{}` is not a number of seconds", quote_cell(cell)))
        }
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
            None if self.seconds(cell).is_ok() => TimeKind::Seconds,
            None => TimeKind::Timestamp,
        };
        let t = match kind {
            TimeKind::Seconds => {
                let v: f64 = self.seconds(cell)?;
                if !v.is_finite() {
                    return Err(format!("`{}` is not a finite time", quote_cell(cell)));
                }
                let scale = match self.unit {
                    TimeUnit::Ms => 1e-3,
                    TimeUnit::Min => 60.0,
                    TimeUnit::H => 3600.0,
                    _ => 1.0,
                };
                v * scale + self.start.unwrap_or(0.0)
            }
            TimeKind::Timestamp if self.format.is_none() && self.dmy != Dmy::Off && dmy_fields(cell).is_some() => {
                match self.dmy {
                    Dmy::Order(o) => parse_dmy(cell, o)?,
                    _ => parse_dmy(cell, DateOrder::DayFirst).or_else(|_| parse_dmy(cell, DateOrder::MonthFirst))?,
                }
            }
            TimeKind::Timestamp => parse_timestamp(cell, self.format.as_deref()).ok_or_else(|| match &self.format {
                Some(f) => format!("`{}` is not a timestamp of the form `{f}`", quote_cell(cell)),
                None => format!(
                    "`{}` is not a timestamp (YYYY-MM-DD hh:mm:ss[.fff], ISO-8601; other layouts: set a chrono `format`)",
                    quote_cell(cell)
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
    fn numeric_dates_in_either_order() {
        let a = parse_timestamp("2024-03-01 10:00:00", None).unwrap();
        assert_eq!(dmy_fields("01.03.2024 10:00:00"), Some((1, 3)));
        assert_eq!(dmy_fields("3/1/2024 10:00:00 AM"), Some((3, 1)));
        assert_eq!(dmy_fields("2024-03-01 10:00:00"), None);
        assert_eq!(dmy_fields("1535.012"), None);
        assert_eq!(parse_dmy("01.03.2024 10:00:00", DateOrder::DayFirst), Ok(a));
        assert_eq!(parse_dmy("3/1/2024 10:00:00 AM", DateOrder::MonthFirst), Ok(a));
        assert_eq!(parse_dmy("03/01/2024 10:00:00 PM", DateOrder::MonthFirst), Ok(a + 12.0 * 3600.0));
        assert_eq!(parse_dmy("3/1/2024 12:00:00 AM", DateOrder::MonthFirst), Ok(a - 10.0 * 3600.0));
        assert!((parse_dmy("01.03.2024 10:00:00,25", DateOrder::DayFirst).unwrap() - a - 0.25).abs() < 1e-6);
        assert_eq!(parse_dmy("01/03/2024 10:00", DateOrder::DayFirst), Ok(a));
        let e = parse_dmy("03/13/2024 10:00:00", DateOrder::DayFirst).unwrap_err();
        assert!(e.contains("month 13") && e.contains("day-first"), "{e}");
        assert!(parse_dmy("31/02/2024 10:00:00", DateOrder::DayFirst).unwrap_err().contains("day 31 of month 2"));
        assert!(parse_dmy("01/03/2024 25:00:00", DateOrder::DayFirst).is_err());
        assert!(parse_dmy("01/03/2024 13:00:00 PM", DateOrder::DayFirst).is_err());
        // Off: a numeric date is not read at all; Order: in that order only.
        let mut p = TimeParser::new(TimeUnit::Auto, None, None);
        assert!(p.parse("01/03/2024 10:00:00").is_err());
        let mut p = TimeParser::new(TimeUnit::Auto, None, None).with_locale(false, Dmy::Order(DateOrder::MonthFirst));
        assert_eq!(p.parse("03/01/2024 10:00:00"), Ok(a));
        assert_eq!(p.parse("2024-03-01 10:00:00"), Ok(a));
        assert!(p.parse("13/01/2024 10:00:00").is_err());
        let p = TimeParser::new(TimeUnit::Auto, None, None).with_locale(false, Dmy::Probe);
        assert!(p.probe("13/01/2024 10:00:00") && p.probe("01/13/2024 10:00:00"));
    }

    #[test]
    fn seconds_with_a_decimal_comma() {
        let mut p = TimeParser::new(TimeUnit::Auto, None, None).with_locale(true, Dmy::Off);
        assert_eq!(p.parse("12,5"), Ok(12.5));
        assert!(p.parse("12.5").unwrap_err().contains("decimal comma"));
        assert_eq!(decimal_comma_number("1535,0120"), Ok(1535.012));
        assert!(decimal_comma_number("1.535,0120").is_err());
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
