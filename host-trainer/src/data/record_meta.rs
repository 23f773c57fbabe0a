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
//!   "t0_utc": "2026-01-05T00:00:00.000Z",
//!   "csv_bytes": 1048576,
//!   "csv_crc32c": "1c291ca3"
//! }
//! ```
//!
//! `csv_bytes` and `csv_crc32c` identify the table the sidecar was written with (its length
//! and the CRC-32C of its bytes), so that a CSV rewritten by another tool is not read with
//! the zero and clock of the table it replaced: a reader refuses a CSV of another length as
//! it opens it, and one of other bytes when it has read it to the end (the digest is computed
//! as the rows stream, never in a pass of its own). Sidecars written before these fields
//! existed are read without the check.
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

    /// The sidecar's text for the CSV `csv` (its file name is recorded, for a reader), whose
    /// bytes are `table` (their length and digest are recorded: [`TableDigest`]).
    pub fn sidecar_json(&self, csv: &Path, table: &TableDigest) -> String {
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
            csv_bytes: Some(table.bytes()),
            csv_crc32c: Some(format!("{:08x}", table.crc32c())),
        };
        let mut text = serde_json::to_string_pretty(&side).unwrap_or_default();
        text.push('\n');
        text
    }

    /// The sidecar of the CSV `csv` ([`sidecar_path`]) when there is one, with the digest of
    /// the table it was written with ([`SidecarTable::check_digest`], `None` in a sidecar
    /// older than the digest); `gratings`: the CSV's grating columns, which a stated zero must
    /// list in order; `csv_bytes`: the CSV's length, which must be the one the sidecar records.
    /// Errors name the sidecar and the field.
    pub fn read_sidecar(
        csv: &Path,
        gratings: usize,
        csv_bytes: u64,
    ) -> Result<Option<(RecordMeta, SidecarTable)>, TrainerError> {
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
        let table = SidecarTable { sidecar: path.clone(), csv: csv.to_path_buf(), crc32c: None };
        if let Some(want) = side.csv_bytes {
            if want != csv_bytes {
                return Err(bad("csv_bytes".into(), table.stale(&format!("{want} bytes, but it has {csv_bytes}"))));
            }
        }
        let table = match &side.csv_crc32c {
            None => table,
            Some(hex) => {
                let crc = u32::from_str_radix(hex, 16).ok().filter(|_| hex.len() == 8).ok_or_else(|| {
                    bad(
                        "csv_crc32c".into(),
                        format!("`{}` is not a CRC-32C (8 hex digits)", crate::error::quote_cell(hex)),
                    )
                })?;
                SidecarTable { crc32c: Some(crc), ..table }
            }
        };
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
        Ok(Some((meta, table)))
    }
}

/// What a sidecar says of the table it was written with, for the check a reader makes once
/// it has read the whole CSV ([`check_digest`](Self::check_digest)).
#[derive(Clone, Debug)]
pub struct SidecarTable {
    sidecar: PathBuf,
    csv: PathBuf,
    /// The CRC-32C of the CSV's bytes (`None`: a sidecar older than the digest).
    crc32c: Option<u32>,
}

impl SidecarTable {
    /// Refuse the CSV when its bytes (`digest`, of the whole file) are not the ones the sidecar
    /// was written with.
    pub fn check_digest(&self, digest: &TableDigest) -> Result<(), TrainerError> {
        match self.crc32c {
            Some(want) if want != digest.crc32c() => Err(TrainerError::Config {
                origin: self.sidecar.display().to_string(),
                key: "csv_crc32c".into(),
                message: self.stale(&format!("CRC-32C {want:08x}, but its bytes give {:08x}", digest.crc32c())),
            }),
            _ => Ok(()),
        }
    }

    /// The message of a CSV that is not the table its sidecar describes (`what`: how it differs).
    fn stale(&self, what: &str) -> String {
        format!(
            "{} is not the table this sidecar was written with ({what}): it was rewritten since, so the zero and clock here may not be its own; write the pair again with the tool that writes both (`fbg-trainer simulate`/`import`, Python `write_dataset`), or delete {} to read the table with no stated zero or clock",
            self.csv.display(),
            self.sidecar.display()
        )
    }
}

/// CRC-32C (Castagnoli), sliced by 16: the digest of a CSV's bytes in its sidecar.
static CRC32C: crc::Crc<u32, crc::Table<16>> = crc::Crc::<u32, crc::Table<16>>::new(&crc::CRC_32_ISCSI);

/// The length and CRC-32C of a CSV's bytes, computed as they are written or read
/// ([`Digesting`]): what its sidecar records to identify it.
#[derive(Clone)]
pub struct TableDigest {
    bytes: u64,
    crc: crc::Digest<'static, u32, crc::Table<16>>,
}

impl Default for TableDigest {
    fn default() -> Self {
        TableDigest { bytes: 0, crc: CRC32C.digest() }
    }
}

impl TableDigest {
    /// Add the next bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        self.bytes += bytes.len() as u64;
        self.crc.update(bytes);
    }

    /// Bytes so far.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// The CRC-32C of the bytes so far.
    pub fn crc32c(&self) -> u32 {
        self.crc.clone().finalize()
    }
}

/// A reader or writer that digests the bytes that pass through it ([`TableDigest`]).
pub struct Digesting<T> {
    inner: T,
    digest: TableDigest,
}

impl<T> Digesting<T> {
    pub fn new(inner: T) -> Self {
        Digesting { inner, digest: TableDigest::default() }
    }

    /// The digest of the bytes so far.
    pub fn digest(&self) -> &TableDigest {
        &self.digest
    }
}

impl<R: std::io::Read> std::io::Read for Digesting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.digest.update(&buf[..n]);
        Ok(n)
    }
}

impl<W: std::io::Write> std::io::Write for Digesting<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.digest.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
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
    /// The CSV's length \[bytes\] when written (absent in sidecars written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    csv_bytes: Option<u64>,
    /// The CRC-32C of the CSV's bytes when written, 8 hex digits (absent likewise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    csv_crc32c: Option<String>,
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
