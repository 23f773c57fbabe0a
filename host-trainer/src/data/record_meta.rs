//! What a record knows beyond its columns: each grating's zero (λ_ref, the wavelength its
//! shifts are taken from, and where it came from) and the absolute time of its `t_s = 0`.
//!
//! They travel in a sidecar beside the CSV, `NAME.record.json` for `NAME.csv`
//! ([`sidecar_path`]), so that the CSV itself is a plain table (one header line, then rows)
//! that `pandas.read_csv`, `numpy.genfromtxt(..., names=True)` and a spreadsheet open without
//! options. Every writer of a dataset CSV writes both in one output set (never one without the
//! other); a reader reads the sidecar when it is there:
//!
//! ```text
//! {
//!   "format": "fbg-trainer record v1",
//!   "record": "data.csv",
//!   "zero": [
//!     { "column": "dl1_pm", "lambda_ref_nm": 1530.0, "source": "simulated" },
//!     { "column": "dl2_pm", "lambda_ref_nm": null, "source": "unknown" }
//!   ],
//!   "t0_utc": "2026-01-05T00:00:00.000Z"
//! }
//! ```
//!
//! `zero` is empty when the record says nothing of its zero (its shifts are then taken as from
//! the model's), `t0_utc` null when its clock is unknown; otherwise `zero` lists every grating
//! column of the CSV in order, and a sidecar that does not fit its CSV is an error naming the
//! sidecar and the field.
//!
//! Records written before the sidecar carried the same as comment lines before the header;
//! they are still read:
//!
//! ```text
//! # lambda_ref_nm: 1530.000000 simulated; 1545.031200 first reading; unknown
//! # t0_utc: 2026-01-05T00:00:00.000Z
//! t_s,T_C,...
//! ```
//!
//! Other comment lines are ignored; a comment line with one of these keys that does not parse
//! is an error naming its line. A record with both says the same in both, or is refused.

use std::path::{Path, PathBuf};

use fbg_shared::ZeroSource;
use serde::{Deserialize, Serialize};

use crate::data::measurand::grating_column;
use crate::error::TrainerError;

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

    /// A zero as the sidecar states it: λ_ref \[nm\] (`None` when unknown) and its source
    /// (`map`, `first reading`, `model`, `simulated`, `unknown`); the error says what is wrong.
    pub fn parse(lambda_ref_nm: Option<f64>, source: &str) -> Result<GratingZero, String> {
        match (parse_source(source)?, lambda_ref_nm) {
            (ZeroSource::Unknown, None) => Ok(GratingZero::UNKNOWN),
            (ZeroSource::Unknown, Some(v)) => Err(format!(
                "lambda_ref_nm {} with source `unknown` (None when unknown)",
                crate::error::quote_number(v)
            )),
            (_, None) => Err(format!("lambda_ref_nm None with source `{source}` (a wavelength in nm)")),
            (source, Some(nm)) => Ok(GratingZero { nm: plausible_nm(nm)?, source }),
        }
    }

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
    /// The sidecar the zero and clock were read from (`None`: the CSV's comment lines, or
    /// nothing read), for messages.
    #[serde(skip)]
    pub sidecar: Option<PathBuf>,
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

    /// The comment lines a CSV written before the sidecar started with (none when nothing is
    /// known): what [`read_comment`](Self::read_comment) still reads.
    #[cfg(test)]
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
            out.push(format!("# {T0_KEY} {}", crate::data::timestamp::format_utc(t0)));
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
            self.t0_unix_s = Some(parse_t0(rest).map_err(|m| format!("{T0_KEY} {m}"))?);
            Ok(true)
        } else {
            Ok(false)
        }
    }

    /// The rows `idx` of a record keep its zero; their clock moves with the first row kept
    /// (`t_s` of the new first row is `t_first_s` on the old clock).
    pub fn shifted(&self, t_first_s: f64) -> RecordMeta {
        RecordMeta {
            zero: self.zero.clone(),
            t0_unix_s: self.t0_unix_s.map(|t| t + t_first_s),
            comment_lines: 0,
            sidecar: None,
        }
    }

    /// True when the record says nothing beyond its columns.
    pub fn is_empty(&self) -> bool {
        self.zero.is_empty() && self.t0_unix_s.is_none()
    }

    /// The sidecar's text for the CSV `csv` (its file name is recorded, for a reader).
    pub fn sidecar_json(&self, csv: &Path) -> String {
        let side = Sidecar {
            format: SIDECAR_FORMAT.into(),
            record: csv.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            zero: self
                .zero
                .iter()
                .enumerate()
                .map(|(g, z)| SidecarZero {
                    column: grating_column(g + 1),
                    lambda_ref_nm: z.known(),
                    source: z.source.name().into(),
                })
                .collect(),
            t0_utc: self.t0_unix_s.map(crate::data::timestamp::format_utc),
        };
        let mut text = serde_json::to_string_pretty(&side).unwrap_or_default();
        text.push('\n');
        text
    }

    /// The sidecar of the CSV `csv` ([`sidecar_path`]) when there is one; `gratings`: the
    /// CSV's grating columns, which a stated zero must list in order. Errors name the sidecar
    /// and the field.
    pub fn read_sidecar(csv: &Path, gratings: usize) -> Result<Option<RecordMeta>, TrainerError> {
        let path = sidecar_path(csv);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(TrainerError::io(&path, e)),
        };
        let name = path.display().to_string();
        let side: Sidecar = serde_json::from_str(&text).map_err(|e| TrainerError::Data {
            path: name.clone(),
            line: e.line() as u64,
            column: e.column().to_string(),
            message: format!("not a record sidecar: {}", crate::error::quote_cell(&e.to_string())),
        })?;
        let bad = |key: String, message: String| TrainerError::Config { origin: name.clone(), key, message };
        if side.format != SIDECAR_FORMAT {
            return Err(bad(
                "format".into(),
                format!("`{}` is not `{SIDECAR_FORMAT}`", crate::error::quote_cell(&side.format)),
            ));
        }
        if !side.zero.is_empty() && side.zero.len() != gratings {
            return Err(bad(
                "zero".into(),
                format!(
                    "{} gratings, but {} has {gratings} (dl1_pm..): the sidecar belongs to another version of the record",
                    side.zero.len(),
                    csv.display()
                ),
            ));
        }
        let mut meta = RecordMeta { sidecar: Some(path.clone()), ..RecordMeta::default() };
        for (g, z) in side.zero.iter().enumerate() {
            let key = |f: &str| format!("zero[{g}].{f}");
            let want = grating_column(g + 1);
            if z.column != want {
                return Err(bad(
                    key("column"),
                    format!("`{}` where `{want}` belongs (the gratings in order)", crate::error::quote_cell(&z.column)),
                ));
            }
            let source = parse_source(&z.source).map_err(|m| bad(key("source"), m))?;
            let zero = match (source, z.lambda_ref_nm) {
                (ZeroSource::Unknown, None) => GratingZero::UNKNOWN,
                (ZeroSource::Unknown, Some(v)) => {
                    return Err(bad(key("lambda_ref_nm"), format!("{v} with source `unknown` (null when unknown)")))
                }
                (_, None) => {
                    return Err(bad(
                        key("lambda_ref_nm"),
                        format!("null with source `{}` (a wavelength in nm)", z.source),
                    ))
                }
                (source, Some(nm)) => {
                    GratingZero { nm: plausible_nm(nm).map_err(|m| bad(key("lambda_ref_nm"), m))?, source }
                }
            };
            meta.zero.push(zero);
        }
        if let Some(t) = &side.t0_utc {
            meta.t0_unix_s = Some(parse_t0(t).map_err(|m| bad("t0_utc".into(), m))?);
        }
        Ok(Some(meta))
    }
}

/// The sidecar of the dataset CSV `csv`: `data.csv` → `data.record.json`.
pub fn sidecar_path(csv: &Path) -> PathBuf {
    csv.with_extension("record.json")
}

/// The sidecar's format tag.
const SIDECAR_FORMAT: &str = "fbg-trainer record v1";

/// The sidecar as written (see the module doc).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Sidecar {
    format: String,
    /// The CSV's file name when written (for a reader; not checked: the pair may be renamed).
    record: String,
    zero: Vec<SidecarZero>,
    t0_utc: Option<String>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SidecarZero {
    column: String,
    lambda_ref_nm: Option<f64>,
    source: String,
}

fn parse_t0(v: &str) -> Result<f64, String> {
    crate::data::timestamp::parse_timestamp(v.trim().trim_end_matches('Z'), None).ok_or_else(|| {
        format!("`{}` is not a UTC timestamp like 2026-01-05T00:00:00.000Z", crate::error::quote_cell(v))
    })
}

fn plausible_nm(nm: f64) -> Result<f64, String> {
    if !(nm.is_finite() && (100.0..=10_000.0).contains(&nm)) {
        return Err(format!(
            "{} nm is not a plausible Bragg wavelength (100–10 000 nm)",
            crate::error::quote_number(nm)
        ));
    }
    Ok(nm)
}

fn parse_source(s: &str) -> Result<ZeroSource, String> {
    Ok(match s.trim() {
        "unknown" => ZeroSource::Unknown,
        "map" => ZeroSource::Map,
        "first reading" => ZeroSource::FirstReading,
        "model" => ZeroSource::Model,
        "simulated" => ZeroSource::Simulated,
        other => {
            return Err(format!(
                "`{}` is not a source (map, first reading, model, simulated, unknown)",
                crate::error::quote_cell(other)
            ))
        }
    })
}

fn parse_zero(cell: &str) -> Result<GratingZero, String> {
    if cell.eq_ignore_ascii_case("unknown") {
        return Ok(GratingZero::UNKNOWN);
    }
    let (num, source) = cell.split_once(' ').unwrap_or((cell, ""));
    let nm: f64 = num.parse().map_err(|_| format!("`{}` is not a wavelength in nm", crate::error::quote_cell(num)))?;
    let nm = plausible_nm(nm)?;
    match parse_source(source)? {
        ZeroSource::Unknown => Err("a wavelength with source `unknown`".into()),
        source => Ok(GratingZero { nm, source }),
    }
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
            sidecar: None,
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
