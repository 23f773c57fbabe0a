//! What a record knows beyond its columns: each grating's zero (λ_ref, the wavelength its
//! shifts are taken from, and where it came from) and the absolute time of its `t_s = 0`.
//!
//! A bare dataset CSV carries them as comment lines before its header, so they travel with the
//! file through any copy:
//!
//! ```text
//! # lambda_ref_nm: 1530.000000 simulated; 1545.031200 first reading; unknown
//! # t0_utc: 2026-01-05T00:00:00.000Z
//! t_s,T_C,...
//! ```
//!
//! Other comment lines are ignored; a comment line with one of these keys that does not parse
//! is an error naming its line.

use fbg_shared::ZeroSource;

/// Prefix of the λ_ref line.
const LAMBDA_REF_KEY: &str = "lambda_ref_nm:";
/// Prefix of the start-time line.
const T0_KEY: &str = "t0_utc:";

/// One grating's zero.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GratingZero {
    /// λ_ref \[nm\] (0 when unknown).
    pub nm: f64,
    /// Where it came from.
    pub source: ZeroSource,
}

impl GratingZero {
    /// No zero known (the record holds shifts).
    pub const UNKNOWN: GratingZero = GratingZero { nm: 0.0, source: ZeroSource::Unknown };

    /// λ_ref when known.
    pub fn known(&self) -> Option<f64> {
        (self.source != ZeroSource::Unknown).then_some(self.nm)
    }
}

/// A record's zero and absolute clock.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RecordMeta {
    /// Per grating, in grating order; empty when the record says nothing.
    pub zero: Vec<GratingZero>,
    /// Absolute time of `t_s = 0`, Unix seconds (UTC), when known.
    pub t0_unix_s: Option<f64>,
    /// Comment lines before the header of the CSV the record was read from (0 otherwise): a
    /// data row's line is its index + 2 + this.
    #[serde(skip)]
    pub comment_lines: u64,
}

/// Two records say the same when their zero and clock agree (where a copy was read from does
/// not matter).
impl PartialEq for RecordMeta {
    fn eq(&self, other: &Self) -> bool {
        self.zero == other.zero && self.t0_unix_s == other.t0_unix_s
    }
}

impl RecordMeta {
    /// λ_ref of grating `g` (0-based) when known.
    pub fn lambda_ref(&self, g: usize) -> Option<f64> {
        self.zero.get(g).and_then(GratingZero::known)
    }

    /// The comment lines a CSV starts with (none when nothing is known).
    pub(crate) fn comment_lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.zero.is_empty() {
            let cells: Vec<String> = self
                .zero
                .iter()
                .map(|z| match z.source {
                    ZeroSource::Unknown => "unknown".to_string(),
                    s => format!("{:.6} {}", z.nm, s.name()),
                })
                .collect();
            out.push(format!("# {LAMBDA_REF_KEY} {}", cells.join("; ")));
        }
        if let Some(t0) = self.t0_unix_s {
            out.push(format!("# {T0_KEY} {}", crate::data::import::time_axis::format_utc(t0)));
        }
        out
    }

    /// Read one comment line (with or without its `#`) into `self`; `Ok(false)` for a comment
    /// this module does not know. The error says what is wrong with the line.
    pub(crate) fn read_comment(&mut self, line: &str) -> Result<bool, String> {
        let text = line.trim_start_matches('#').trim();
        if let Some(rest) = text.strip_prefix(LAMBDA_REF_KEY) {
            let mut zero = Vec::new();
            for (g, cell) in rest.split(';').enumerate() {
                zero.push(parse_zero(cell.trim()).map_err(|e| format!("{LAMBDA_REF_KEY} grating {}: {e}", g + 1))?);
            }
            self.zero = zero;
            Ok(true)
        } else if let Some(rest) = text.strip_prefix(T0_KEY) {
            let v = rest.trim();
            let t =
                crate::data::import::time_axis::parse_timestamp(v.trim_end_matches('Z'), None).ok_or_else(|| {
                    format!(
                        "{T0_KEY} `{}` is not a UTC timestamp like 2026-01-05T00:00:00.000Z",
                        crate::error::quote_cell(v)
                    )
                })?;
            self.t0_unix_s = Some(t);
            Ok(true)
        } else {
            Ok(false)
        }
    }

    /// The rows `idx` of a record keep its zero; their clock moves with the first row kept
    /// (`t_s` of the new first row is `t_first_s` on the old clock).
    pub fn shifted(&self, t_first_s: f64) -> RecordMeta {
        RecordMeta { zero: self.zero.clone(), t0_unix_s: self.t0_unix_s.map(|t| t + t_first_s), comment_lines: 0 }
    }
}

fn parse_zero(cell: &str) -> Result<GratingZero, String> {
    if cell.eq_ignore_ascii_case("unknown") {
        return Ok(GratingZero::UNKNOWN);
    }
    let (num, source) = cell.split_once(' ').unwrap_or((cell, ""));
    let nm: f64 = num.parse().map_err(|_| format!("`{num}` is not a wavelength in nm"))?;
    if !(nm.is_finite() && (100.0..=10_000.0).contains(&nm)) {
        return Err(format!("{nm} nm is not a plausible Bragg wavelength (100–10 000 nm)"));
    }
    let source = match source.trim() {
        "map" => ZeroSource::Map,
        "first reading" => ZeroSource::FirstReading,
        "model" => ZeroSource::Model,
        "simulated" => ZeroSource::Simulated,
        other => return Err(format!("`{other}` is not a source (map, first reading, model, simulated)")),
    };
    Ok(GratingZero { nm, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comment_lines_round_trip() {
        let m = RecordMeta {
            zero: vec![
                GratingZero { nm: 1530.123456, source: ZeroSource::Map },
                GratingZero::UNKNOWN,
                GratingZero { nm: 1550.5, source: ZeroSource::FirstReading },
            ],
            t0_unix_s: Some(1_767_571_200.25),
            comment_lines: 0,
        };
        let mut back = RecordMeta::default();
        for l in m.comment_lines() {
            assert!(back.read_comment(&l).unwrap(), "{l}");
        }
        assert_eq!(back, m);
        assert!(!back.read_comment("# something else").unwrap());
        assert!(back.read_comment("# lambda_ref_nm: 15.0 map").is_err());
        assert!(back.read_comment("# lambda_ref_nm: 1550.0 guessed").is_err());
        assert!(back.read_comment("# t0_utc: yesterday").is_err());
    }
}
