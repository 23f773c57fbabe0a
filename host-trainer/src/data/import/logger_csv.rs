//! A logger CSV read through the map's column mapping: the data file of `--format csv`, or the
//! `--refs` file of `--format enlight`.

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use super::mapping::{CsvGrating, Map, RefMap};
use super::problems::{OnError, Problems, Reason, RowError};
use super::time_axis::{TimeKind, TimeParser};
use super::{number, TextLines, READ_BUFFER};
use crate::data::measurand::{grating_column, parse_grating_column, Measurand, MAX_MEASURANDS};
use crate::data::timestamp::parse_timestamp;
use crate::data::units::{
    absolute_nm_column_message, check_ambient, check_wavelength, looks_absolute_nm, UnitSource, WlUnit,
};
use crate::error::TrainerError;

/// Time column names tried when the map names none (case-insensitive).
const TIME_NAMES: [&str; 5] = ["t_s", "time", "timestamp", "datetime", "date_time"];
/// Delimiters tried on the header line when the map names none.
const DELIMITERS: [u8; 4] = [b',', b'\t', b';', b'|'];

/// One value column as read: header name, map key and values (NaN where missing).
#[derive(Clone, Debug)]
pub(crate) struct Column {
    pub name: String,
    pub values: Vec<f64>,
}

/// What a logger CSV gave.
pub(crate) struct LoggerTable {
    /// Physical line of each accepted row.
    pub lines: Vec<u64>,
    /// Time on the file's axis [s].
    pub t: Vec<f64>,
    pub time_column: String,
    pub time_kind: TimeKind,
    /// Calendar time (timestamps, or seconds with `time.start`).
    pub absolute: bool,
    /// The ambient thermometer, where the file has one.
    pub ambient: Option<Column>,
    /// The references the file has (the map's, then columns named like dataset measurands).
    pub refs: Vec<(Measurand, Column)>,
    /// Wavelengths per grating: absolute nm, or shift pm for shift units.
    pub gratings: Vec<Column>,
    /// The gratings read (the map's, or the file's `dl1_pm..dlN_pm`).
    pub grating_specs: Vec<CsvGrating>,
    pub header_line: u64,
    pub problems: Problems,
}

/// Read `path` with `map`'s columns. `gratings`: the wavelength columns wanted (`None` for a
/// refs file; an empty list takes the file's `dl1_pm..dlN_pm` columns as shifts in pm).
pub(crate) fn read(
    path: &Path,
    map: &Map,
    gratings: Option<&[CsvGrating]>,
    policy: OnError,
) -> Result<LoggerTable, TrainerError> {
    let name = path.display().to_string();
    let time_names: Vec<String> = match &map.time.column {
        Some(c) => vec![c.clone()],
        None => TIME_NAMES.iter().map(|s| s.to_string()).collect(),
    };
    // Read as a stream: the header found line by line, the rows by the CSV reader from the
    // header's byte on, so that only the parsed columns grow with the file.
    let (header_idx, delim, offset) = header_position(path, map, &name, &time_names)?;
    let header_line = header_idx as u64 + 1;
    // A last line without a line end is truncated: the file ends inside the row, so its last
    // cell may be cut short (`ragged_row`).
    let truncated_line = unended_last_line(path)?;
    let mut file = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
    file.seek(SeekFrom::Start(offset)).map_err(|e| TrainerError::io(path, e))?;
    let rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .delimiter(delim)
        .from_reader(std::io::BufReader::with_capacity(READ_BUFFER, file));
    // Invalid UTF-8 replaced, as in a text file read whole; each row keeps its position.
    let mut records = rdr.into_byte_records().map(|r| {
        r.map(|b| {
            let position = b.position().cloned();
            let mut rec = csv::StringRecord::from_byte_record_lossy(b);
            rec.set_position(position);
            rec
        })
    });
    let header = match records.next() {
        Some(Ok(h)) => h,
        Some(Err(e)) => {
            return Err(TrainerError::data(&name, header_line, "-", format!("cannot read the header: {e}")))
        }
        None => return Err(TrainerError::data(&name, header_line, "-", "no header row")),
    };
    let h = Header { name: &name, cols: header.iter().map(|s| s.to_string()).collect(), line: header_line };
    let c = Columns::of(&h, map, &time_names, gratings)?;
    let out = read_rows(records, &h, &c, map, policy, truncated_line)?;
    if map.check_units() {
        refuse_absolute_nm_shifts(&h, &c, &out)?;
    }
    if out.t.is_empty() {
        let why =
            if out.problems.rows_read == 0 { "no data rows after the header" } else { "every data row was skipped" };
        return Err(TrainerError::data(&name, header_line + 1, "-", why));
    }
    Ok(out)
}

/// The header's index (from 0), the delimiter and the byte where the header line starts: the
/// line `header_lines` of the map, else the first line naming the time column, read line by
/// line (the byte is after a first-line header's byte-order mark).
fn header_position(
    path: &Path,
    map: &Map,
    name: &str,
    time_names: &[String],
) -> Result<(usize, u8, u64), TrainerError> {
    let map_delim = match &map.delimiter {
        Some(d) => Some(super::mapping::delimiter(d).map_err(|m| TrainerError::data(name, 1, "-", m))?),
        None => None,
    };
    let mut lines = TextLines::open(path)?;
    let (mut count, mut ended) = (0usize, true);
    while let Some((number, text, line_ended)) = lines.next_line()? {
        let idx = (number - 1) as usize;
        (count, ended) = (idx + 1, line_ended);
        let found = match map.header_lines {
            Some(n) if n == idx => Some(map_delim.unwrap_or_else(|| most_frequent_delimiter(text))),
            Some(_) => None,
            None => header_delimiter(text, time_names, map_delim),
        };
        if let Some(d) = found {
            return Ok((idx, d, lines.text_start()));
        }
    }
    // As the text split at its line ends counts them: a last line end starts an empty line.
    let count = count + usize::from(ended);
    match map.header_lines {
        // The empty line after the last line end, named as the header: no header row.
        Some(n) if n + 1 == count => Ok((n, map_delim.unwrap_or(b','), lines.consumed())),
        Some(n) => Err(TrainerError::data(
            name,
            n as u64 + 1,
            "-",
            format!("the file has {count} lines, so there is no header after header_lines = {n}"),
        )),
        None => {
            let what = match &map.time.column {
                Some(c) => format!("`{c}` (map key time.column)"),
                None => format!("any of {} (or name it with the map key time.column)", TIME_NAMES.join(", ")),
            };
            Err(TrainerError::data(
                name,
                1,
                &time_names[0],
                format!("no header line has a cell naming the time column {what}"),
            ))
        }
    }
}

/// The number of the file's last line when it is not blank and has no line end (the file
/// ends inside it), read in blocks: only the last line is held.
fn unended_last_line(path: &Path) -> Result<Option<u64>, TrainerError> {
    let mut f = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
    let mut buf = vec![0u8; READ_BUFFER];
    let (mut line_ends, mut tail) = (0u64, Vec::new());
    loop {
        let n = f.read(&mut buf).map_err(|e| TrainerError::io(path, e))?;
        let Some(block) = buf.get(..n).filter(|b| !b.is_empty()) else { break };
        match block.iter().rposition(|&b| b == b'\n') {
            Some(last) => {
                line_ends += block.iter().filter(|&&b| b == b'\n').count() as u64;
                tail.clear();
                tail.extend_from_slice(block.get(last + 1..).unwrap_or_default());
            }
            None => tail.extend_from_slice(block),
        }
    }
    Ok((!String::from_utf8_lossy(&tail).trim().is_empty()).then_some(line_ends + 1))
}

/// The header row: its cells and its physical line.
struct Header<'a> {
    name: &'a str,
    cols: Vec<String>,
    line: u64,
}

impl Header<'_> {
    /// The cell index of column `want` (exact name first, then ignoring ASCII case).
    fn find(&self, want: &str) -> Option<usize> {
        let cols = &self.cols;
        cols.iter().position(|h| h == want).or_else(|| cols.iter().position(|h| h.eq_ignore_ascii_case(want)))
    }

    /// The error of a column the map (key `key`) names but the header lacks.
    fn missing(&self, want: &str, key: &str) -> TrainerError {
        TrainerError::data(
            self.name,
            self.line,
            want,
            format!("no column `{want}` in the header (map key `{key}`); the header has: {}", self.cols.join(", ")),
        )
    }
}

/// Where each wanted column is in the header (cell indices), with how to read it.
struct Columns {
    time: usize,
    /// The ambient thermometer, where the file has one.
    ambient: Option<(usize, RefMap)>,
    /// The references, in canonical order.
    refs: Vec<(Measurand, usize, RefMap)>,
    gratings: Vec<CsvGrating>,
    g_idx: Vec<usize>,
}

impl Columns {
    fn of(
        h: &Header,
        map: &Map,
        time_names: &[String],
        gratings: Option<&[CsvGrating]>,
    ) -> Result<Columns, TrainerError> {
        let time = time_names.iter().find_map(|n| h.find(n)).ok_or_else(|| h.missing(&time_names[0], "time.column"))?;
        // The ambient thermometer: the map's column (which must be there), else `T_amb_C` if the
        // file has it; an installation without one has none.
        let default_ambient = RefMap { column: crate::data::T_AMB_COLUMN.into(), gain: 1.0, offset: 0.0 };
        let ambient: Option<(usize, RefMap)> = match &map.ambient {
            Some(a) => Some((h.find(&a.column).ok_or_else(|| h.missing(&a.column, "ambient.column"))?, a.clone())),
            None => h.find(&default_ambient.column).map(|i| (i, default_ambient.clone())),
        };
        let refs = reference_columns(h, map, ambient.as_ref())?;
        let gratings = grating_columns(h, gratings)?;
        let mut g_idx = Vec::with_capacity(gratings.len());
        for (i, g) in gratings.iter().enumerate() {
            let key = if map.grating.is_empty() {
                format!("grating[{}].column (default `{}`)", i + 1, g.column)
            } else {
                format!("grating[{}].column", i + 1)
            };
            g_idx.push(h.find(&g.column).ok_or_else(|| h.missing(&g.column, &key))?);
        }
        Ok(Columns { time, ambient, refs, gratings, g_idx })
    }
}

/// The map's measurands (their columns must be there), then every column named like a
/// dataset measurand (`T_C`, `strain2_ue`, ...) that the map does not already give.
fn reference_columns(
    h: &Header,
    map: &Map,
    amb: Option<&(usize, RefMap)>,
) -> Result<Vec<(Measurand, usize, RefMap)>, TrainerError> {
    let cols = &h.cols;
    let mut ref_cols: Vec<(Measurand, usize, RefMap)> = Vec::new();
    for (m, r, key) in map.measurands() {
        let i = h.find(&r.column).ok_or_else(|| h.missing(&r.column, &format!("{key}.column")))?;
        ref_cols.push((m, i, r));
    }
    for (i, c) in cols.iter().enumerate() {
        if let Ok(Some(m)) = Measurand::parse(c) {
            if !ref_cols.iter().any(|(o, oi, _)| *o == m || *oi == i) && amb.is_none_or(|(a, _)| *a != i) {
                ref_cols.push((m, i, RefMap { column: c.clone(), gain: 1.0, offset: 0.0 }));
            }
        }
    }
    ref_cols.sort_by_key(|(m, _, _)| *m);
    if ref_cols.len() > MAX_MEASURANDS {
        let names: Vec<String> = ref_cols.iter().map(|(m, i, _)| format!("{m} ← `{}`", cols[*i])).collect();
        return Err(TrainerError::data(
            h.name,
            h.line,
            &cols[ref_cols[MAX_MEASURANDS].1],
            format!(
                "{} reference columns ({}); at most {MAX_MEASURANDS} measurands are supported",
                ref_cols.len(),
                names.join(", ")
            ),
        ));
    }
    Ok(ref_cols)
}

/// The wavelength columns: the caller's; none for a refs file (`None`); without map gratings
/// (an empty list), the file's own dl1_pm..dlN_pm (shifts in pm).
fn grating_columns(h: &Header, gratings: Option<&[CsvGrating]>) -> Result<Vec<CsvGrating>, TrainerError> {
    match gratings {
        None => Ok(Vec::new()),
        Some(g) if !g.is_empty() => Ok(g.to_vec()),
        Some(_) => {
            let mut found: Vec<usize> = Vec::new();
            for c in &h.cols {
                match parse_grating_column(c) {
                    Ok(Some(g)) => found.push(g),
                    Ok(None) => {}
                    Err(e) => {
                        return Err(TrainerError::data(
                            h.name,
                            h.line,
                            c,
                            format!("column `{}`: {e}", crate::error::quote_cell(c)),
                        ))
                    }
                }
            }
            found.sort_unstable();
            let n = found.iter().enumerate().take_while(|&(k, &g)| g == k + 1).count();
            if n == 0 {
                return Err(h.missing("dl1_pm", "grating[1].column (default `dl1_pm`, `dl2_pm`, ...)"));
            }
            Ok((1..=n)
                .map(|i| CsvGrating {
                    column: grating_column(i),
                    unit: WlUnit::ShiftPm,
                    ref_nm: None,
                    unit_key: format!("grating[{i}].unit"),
                })
                .collect())
        }
    }
}

/// Every data row after the header, checked and parsed; bad rows fail or are counted as
/// `policy` says.
fn read_rows(
    records: impl Iterator<Item = Result<csv::StringRecord, csv::Error>>,
    h: &Header,
    c: &Columns,
    map: &Map,
    policy: OnError,
    truncated_line: Option<u64>,
) -> Result<LoggerTable, TrainerError> {
    let cols = &h.cols;
    let start = map.time.start.as_deref().and_then(|s| parse_timestamp(s, None));
    let mut clock = TimeParser::new(map.time.unit, map.time.format.clone(), start);
    let check = map.check_units();
    let mut problems = Problems::new(h.name, policy);
    let mut out = LoggerTable {
        lines: Vec::new(),
        t: Vec::new(),
        time_column: cols[c.time].clone(),
        time_kind: TimeKind::Seconds,
        absolute: false,
        ambient: c.ambient.as_ref().map(|(i, _)| Column { name: cols[*i].clone(), values: Vec::new() }),
        refs: c.refs.iter().map(|(m, i, _)| (*m, Column { name: cols[*i].clone(), values: Vec::new() })).collect(),
        gratings: c.g_idx.iter().map(|&i| Column { name: cols[i].clone(), values: Vec::new() }).collect(),
        grating_specs: c.gratings.clone(),
        header_line: h.line,
        problems: Problems::new(h.name, policy),
    };
    for rec in records {
        let rec = match rec {
            Ok(r) => r,
            Err(e) => {
                let line = h.line + e.position().map_or(1, |p| p.line()) - 1;
                problems.rows_read += 1;
                problems.reject(RowError::new(Reason::RaggedRow, line, "-", format!("malformed row: {e}")))?;
                continue;
            }
        };
        if rec.len() == 1 && rec[0].is_empty() {
            continue;
        }
        let line = h.line + rec.position().map_or(1, |p| p.line()) - 1;
        problems.rows_read += 1;
        if truncated_line == Some(line) {
            let last = rec.len().saturating_sub(1);
            let col = cols.get(last).cloned().unwrap_or_else(|| format!("{} (beyond the header)", last + 1));
            problems.reject(RowError::new(
                Reason::RaggedRow,
                line,
                col,
                format!("truncated last row (no line end): the file ends inside this row, so its last cell `{}` may be cut short", rec.get(last).unwrap_or("")),
            ))?;
            continue;
        }
        let row =
            parse_row(&rec, line, cols, c, &mut clock, check).and_then(|r| in_order(r, &rec, line, cols, c, &out));
        match row {
            Ok(r) => out.push(line, &r),
            Err(e) => problems.reject(e)?,
        }
    }
    problems.refuse_wrong_unit_columns()?;
    out.time_kind = clock.kind.unwrap_or(TimeKind::Seconds);
    out.absolute = clock.absolute();
    out.problems = problems;
    Ok(out)
}

/// `r`, refused when its time is not after the last accepted row's.
fn in_order(
    r: Row,
    rec: &csv::StringRecord,
    line: u64,
    cols: &[String],
    c: &Columns,
    out: &LoggerTable,
) -> Result<Row, RowError> {
    if let (Some(&prev), Some(&prev_line)) = (out.t.last(), out.lines.last()) {
        if r.t < prev {
            return Err(RowError::new(
                Reason::TimeBackwards,
                line,
                &cols[c.time],
                format!("time goes backwards: `{}` is earlier than line {prev_line}", rec[c.time].trim()),
            ));
        }
        if r.t == prev {
            return Err(RowError::new(
                Reason::DuplicateTime,
                line,
                &cols[c.time],
                format!("duplicated time `{}` (same as line {prev_line})", rec[c.time].trim()),
            ));
        }
    }
    Ok(r)
}

impl LoggerTable {
    /// Append an accepted row read on physical line `line`.
    fn push(&mut self, line: u64, r: &Row) {
        self.lines.push(line);
        self.t.push(r.t);
        if let Some(a) = &mut self.ambient {
            a.values.push(r.ambient);
        }
        for ((_, col), v) in self.refs.iter_mut().zip(&r.refs) {
            col.values.push(*v);
        }
        for (col, v) in self.gratings.iter_mut().zip(&r.gratings) {
            col.values.push(*v);
        }
    }
}

/// A column declared as shifts in pm whose values look like absolute wavelengths in nm is
/// refused (the unit check).
fn refuse_absolute_nm_shifts(h: &Header, c: &Columns, out: &LoggerTable) -> Result<(), TrainerError> {
    for (i, g) in c.gratings.iter().enumerate() {
        if g.unit == WlUnit::ShiftPm && looks_absolute_nm(&out.gratings[i].values) {
            let first = out.lines.first().copied().unwrap_or(h.line + 1);
            return Err(TrainerError::data(
                h.name,
                first,
                &g.column,
                absolute_nm_column_message(&out.gratings[i].values, &g.unit_key),
            ));
        }
    }
    Ok(())
}

struct Row {
    t: f64,
    ambient: f64,
    refs: Vec<f64>,
    gratings: Vec<f64>,
}

fn parse_row(
    rec: &csv::StringRecord,
    line: u64,
    cols: &[String],
    c: &Columns,
    clock: &mut TimeParser,
    check: bool,
) -> Result<Row, RowError> {
    let (time_idx, amb, refs, gratings, g_idx) = (c.time, c.ambient.as_ref(), &c.refs, &c.gratings, &c.g_idx);
    if rec.len() != cols.len() {
        let (col, what) = if rec.len() < cols.len() {
            (cols[rec.len()].clone(), "truncated or ragged row")
        } else {
            (format!("{} (beyond the header)", rec.len()), "ragged row")
        };
        return Err(RowError::new(
            Reason::RaggedRow,
            line,
            col,
            format!("{what}: {} cells where the header has {}", rec.len(), cols.len()),
        ));
    }
    let bad = |i: usize, m: String| RowError::new(Reason::NonNumeric, line, &cols[i], m);
    let t = clock.parse(&rec[time_idx]).map_err(|m| bad(time_idx, m))?;
    let val = |i: usize| number(&rec[i]).map_err(|m| bad(i, m));
    let ambient = match amb {
        Some((amb_idx, amb)) => match val(*amb_idx)? {
            Some(v) => {
                let v = amb.gain * v + amb.offset;
                if check {
                    check_ambient(v, UnitSource::MapKey("ambient"))
                        .map_err(|m| RowError::new(Reason::UnitMismatch, line, &cols[*amb_idx], m))?;
                }
                v
            }
            None => f64::NAN,
        },
        None => f64::NAN,
    };
    let mut r = Vec::with_capacity(refs.len());
    for (_, i, m) in refs {
        r.push(val(*i)?.map_or(f64::NAN, |v| m.gain * v + m.offset));
    }
    let mut g = Vec::with_capacity(gratings.len());
    for (spec, &i) in gratings.iter().zip(g_idx) {
        g.push(match val(i)? {
            Some(v) => {
                if check {
                    check_wavelength(spec.unit, v, UnitSource::MapKey(&spec.unit_key))
                        .map_err(|m| RowError::new(Reason::UnitMismatch, line, &cols[i], m))?;
                }
                spec.unit.convert(v)
            }
            None => f64::NAN,
        });
    }
    Ok(Row { t, ambient, refs: r, gratings: g })
}

/// Split a line for header detection (no quoting rules beyond trimming quotes).
fn cells(line: &str, d: u8) -> Vec<&str> {
    line.split(d as char).map(|c| c.trim().trim_matches('"').trim()).collect()
}

/// The delimiter by which `line` has a cell naming the time column (`names`), the one giving
/// the most cells where several do; `None` when none does.
fn header_delimiter(line: &str, names: &[String], map_delim: Option<u8>) -> Option<u8> {
    let delims: Vec<u8> = map_delim.map_or_else(|| DELIMITERS.to_vec(), |d| vec![d]);
    delims
        .iter()
        .map(|&d| (d, cells(line, d)))
        .filter(|(_, cs)| cs.iter().any(|c| names.iter().any(|n| c.eq_ignore_ascii_case(n))))
        .max_by_key(|(_, cs)| cs.len())
        .map(|(d, _)| d)
}

fn most_frequent_delimiter(line: &str) -> u8 {
    DELIMITERS.iter().copied().max_by_key(|&d| line.bytes().filter(|&b| b == d).count()).unwrap_or(b',')
}
