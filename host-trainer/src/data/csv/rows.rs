//! The streaming reader of a dataset CSV: metadata, header layout, then one checked row at a
//! time.

use std::path::Path;

use fbg_shared::Sample;

use super::line_limit::{line_error, line_too_long, LineLimit};
use crate::data::dataset::check_input_row;
use crate::data::measurand::{grating_column, parse_grating_column};
use crate::data::record_meta::{Digesting, SidecarTable};
use crate::data::units::UnitSource;
use crate::data::{
    check_next_time, Dataset, Measurand, RecordMeta, Reference, Split, MAX_GRATINGS, MAX_MEASURANDS, T_AMB_COLUMN,
};
use crate::error::TrainerError;

/// Appended to a unit-check message on a dataset CSV: the check and its words are `import`'s.
const REIMPORT: &str =
    " (the unit check of `fbg-trainer import`: convert the column, or re-import the export with that map key)";

pub use crate::error::{quote_cell, QUOTE_CHARS};

/// One data row of a dataset CSV as [`RowReader`] reads it: NaN for an empty cell (a gap, a
/// missing reference) and for a column the file does not have.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Row {
    /// Time since the start \[s\].
    pub t_s: f64,
    /// The references in canonical order ([`RowReader::header_dataset`]); NaN beyond them.
    pub refs: [f64; MAX_MEASURANDS],
    /// Ambient thermometer [°C].
    pub t_amb_c: f64,
    /// Shifts \[pm\] of the gratings; NaN beyond them.
    pub dl_pm: [f64; MAX_GRATINGS],
    /// Number of gratings.
    pub gratings: u8,
    pub split: Split,
}

impl Row {
    /// The model inputs (as [`Dataset::sample`]).
    pub fn sample(&self) -> Sample<f64> {
        let mut dl_pm = [0.0; MAX_GRATINGS];
        for (o, &v) in dl_pm.iter_mut().zip(&self.dl_pm).take(usize::from(self.gratings)) {
            *o = v;
        }
        Sample { dl_pm, gratings: self.gratings, t_amb_c: self.t_amb_c, t_s: self.t_s }
    }

    /// True when the row can be used for fitting ([`Dataset::usable`]): finite inputs and
    /// every reference the file has (`n_refs`) present; `ambient`: the file has `T_amb_C`.
    pub fn usable(&self, n_refs: usize, ambient: bool) -> bool {
        self.dl_pm.iter().take(usize::from(self.gratings)).all(|v| v.is_finite())
            && (!ambient || self.t_amb_c.is_finite())
            && self.t_s.is_finite()
            && self.refs.iter().take(n_refs).all(|v| v.is_finite())
    }
}

/// Streaming reader of a dataset CSV: the comment lines' metadata and the header first, then
/// one row at a time with the checks and errors of [`Dataset::read_csv`]; it holds one row,
/// never more than [`MAX_LINE_BYTES`](super::MAX_LINE_BYTES) of a line, and a few numbers per grating for the
/// whole-column checks of [`RowReader::finish`].
pub(crate) struct RowReader {
    /// The file's name in messages.
    pub name: String,
    rdr: csv::Reader<LineLimit<Digesting<std::fs::File>>>,
    /// What the sidecar says of the table it was written with: checked against the digest of
    /// the bytes read once the last row is read.
    table: Option<SidecarTable>,
    headers: csv::StringRecord,
    layout: Layout,
    unit_keys: Vec<String>,
    meta: RecordMeta,
    rec: csv::StringRecord,
    file_len: u64,
    ends_with_newline: bool,
    prev_t: Option<f64>,
    first_line: u64,
    rows: usize,
    /// Per grating: whether the column looks like absolute wavelengths so far.
    abs_nm: Vec<crate::data::units::AbsNmCheck>,
}

impl RowReader {
    /// Open a dataset CSV and read its metadata and header.
    pub fn open(path: &Path) -> Result<RowReader, TrainerError> {
        let name = path.display().to_string();
        let mut file = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
        let file_len = file.metadata().map_err(|e| TrainerError::io(path, e))?.len();
        let ends_with_newline = last_byte(&mut file).map_err(|e| TrainerError::io(path, e))? == Some(b'\n');
        let meta = read_meta(&mut file, &name)?;
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(LineLimit::new(Digesting::new(file)));
        let headers = match rdr.headers() {
            Ok(h) => h.clone(),
            Err(e) => {
                if let csv::ErrorKind::Io(io) = e.kind() {
                    if let Some(l) = line_too_long(io) {
                        return Err(line_error(&name, l));
                    }
                }
                return Err(TrainerError::data(&name, 1, "-", format!("cannot read the header: {e}")));
            }
        };
        let layout = Layout::of(&headers).map_err(|(col, m)| TrainerError::data(&name, 1, &quote_cell(&col), m))?;
        let n_g = layout.gratings.len();
        let (meta, table) = with_sidecar(meta, path, n_g, file_len)?;
        Ok(RowReader {
            name,
            rdr,
            table,
            headers,
            unit_keys: (1..=n_g).map(|g| format!("grating[{g}].unit")).collect(),
            abs_nm: vec![crate::data::units::AbsNmCheck::default(); n_g],
            layout,
            meta,
            rec: csv::StringRecord::new(),
            file_len,
            ends_with_newline,
            prev_t: None,
            first_line: 0,
            rows: 0,
        })
    }

    /// A dataset with this file's columns and metadata and no rows: what the header says
    /// ([`Dataset::shape`], [`Dataset::inputs_for`], [`Dataset::reference_of`] work on it).
    pub fn header_dataset(&self) -> Dataset {
        Dataset {
            refs: self.layout.refs.iter().map(|&(m, _)| Reference { measurand: m, values: Vec::new() }).collect(),
            t_amb_c: self.layout.ambient.map(|_| Vec::new()),
            dl_pm: vec![Vec::new(); self.layout.gratings.len()],
            meta: self.meta.clone(),
            ..Dataset::default()
        }
    }

    /// Rows read so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Bytes of the file read so far (for progress).
    pub fn byte_position(&self) -> u64 {
        self.rdr.position().byte()
    }

    /// The file's length \[bytes\].
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// The next data row, `None` at the end; errors name the file, line and column.
    pub fn next_row(&mut self) -> Result<Option<Row>, TrainerError> {
        let name = self.name.as_str();
        let more = self.rdr.read_record(&mut self.rec).map_err(|e| {
            if let csv::ErrorKind::Io(io) = e.kind() {
                if let Some(l) = line_too_long(io) {
                    return line_error(name, l);
                }
            }
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            TrainerError::data(name, line, "-", format!("malformed row: {}", quote_cell(&e.to_string())))
        })?;
        if !more {
            // The whole file is read: its bytes must be the ones its sidecar was written with.
            if let Some(t) = &self.table {
                t.check_digest(self.rdr.get_ref().get_ref().digest())?;
            }
            return Ok(None);
        }
        let (rec, headers, layout) = (&self.rec, &self.headers, &self.layout);
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        if self.first_line == 0 {
            self.first_line = line;
        }
        if !self.ends_with_newline && self.rdr.position().byte() >= self.file_len {
            // The file ends inside this row, so its last cell may be cut short
            // (`1545.0440` read as `1545.04`): `ragged_row`, as `import` says.
            let last = headers.get(rec.len().saturating_sub(1)).unwrap_or("-");
            return Err(TrainerError::data(
                name,
                line,
                &quote_cell(last),
                format!(
                    "truncated last row (no line end): the file ends inside this row, so its last cell `{}` may be cut short (ragged_row)",
                    quote_cell(rec.get(rec.len().saturating_sub(1)).unwrap_or(""))
                ),
            ));
        }
        // `blank_ok`: an empty cell is a missing value (NaN) rather than an error.
        let num = |c: usize, blank_ok: bool| -> Result<f64, TrainerError> {
            let col = headers.get(c).unwrap_or("-");
            let cell = rec.get(c).ok_or_else(|| {
                TrainerError::data(
                    name,
                    line,
                    &quote_cell(col),
                    format!("row has {} cells, column `{}` is number {}", rec.len(), quote_cell(col), c + 1),
                )
            })?;
            if cell.is_empty() {
                return if blank_ok { Ok(f64::NAN) } else { Err(TrainerError::data(name, line, col, "empty cell")) };
            }
            let v: f64 = cell
                .parse()
                .map_err(|_| TrainerError::data(name, line, col, format!("`{}` is not a number", quote_cell(cell))))?;
            if !v.is_finite() {
                return Err(TrainerError::data(name, line, col, format!("`{}` is not finite", quote_cell(cell))));
            }
            Ok(v)
        };
        let t = num(layout.t_s, false)?;
        check_next_time(self.prev_t, t).map_err(|m| TrainerError::data(name, line, "t_s", m))?;
        let mut row = Row {
            t_s: t,
            refs: [f64::NAN; MAX_MEASURANDS],
            t_amb_c: f64::NAN,
            dl_pm: [f64::NAN; MAX_GRATINGS],
            gratings: layout.gratings.len() as u8,
            split: Split::Cal,
        };
        for (r, &(_, c)) in row.refs.iter_mut().zip(&layout.refs) {
            *r = num(c, true)?;
        }
        // An empty ambient reading is a gap like an empty dl cell (not fitted, flagged).
        if let Some(c) = layout.ambient {
            row.t_amb_c = num(c, true)?;
        }
        for (g, &c) in layout.gratings.iter().enumerate() {
            let v = num(c, true)?;
            row.dl_pm[g] = v;
            self.abs_nm[g].push(v);
        }
        // Magnitudes get the record's input rule, with the unit checks' words of `import`
        // (kelvin for °C, nm or absolute wavelengths for shifts in pm).
        let keys = &self.unit_keys;
        let source = |g: Option<usize>| match g {
            Some(g) => UnitSource::MapKey(keys.get(g).map_or("grating.unit", String::as_str)),
            None => UnitSource::MapKey("ambient"),
        };
        check_input_row(row.t_amb_c, &row.dl_pm[..layout.gratings.len()], source)
            .map_err(|(column, m)| TrainerError::data(name, line, &column, format!("{m}{REIMPORT}")))?;
        if let Some(c) = layout.split {
            row.split = match rec.get(c).unwrap_or("") {
                "cal" => Split::Cal,
                "holdout" => Split::Holdout,
                other => {
                    return Err(TrainerError::data(
                        name,
                        line,
                        "split",
                        format!("`{}` is neither `cal` nor `holdout`", quote_cell(other)),
                    ))
                }
            };
        }
        self.prev_t = Some(t);
        self.rows += 1;
        Ok(Some(row))
    }

    /// The checks on the whole file, after its last row: at least one row, and no shift
    /// column that holds absolute wavelengths.
    pub fn finish(&self) -> Result<(), TrainerError> {
        if self.rows == 0 {
            return Err(TrainerError::data(&self.name, 2, "-", "no data rows"));
        }
        for (g, (a, key)) in self.abs_nm.iter().zip(&self.unit_keys).enumerate() {
            if a.looks_absolute_nm() {
                return Err(TrainerError::data(
                    &self.name,
                    self.first_line,
                    &grating_column(g + 1),
                    format!("{}{REIMPORT}", a.message(UnitSource::MapKey(key))),
                ));
            }
        }
        Ok(())
    }
}

/// Where the dataset columns are in a header (0-based cell indices).
struct Layout {
    t_s: usize,
    /// Canonical order.
    refs: Vec<(Measurand, usize)>,
    ambient: Option<usize>,
    /// dl1_pm, dl2_pm, ... in order.
    gratings: Vec<usize>,
    split: Option<usize>,
}

impl Layout {
    /// Classify the header's columns by name; the error is (column, message).
    fn of(headers: &csv::StringRecord) -> Result<Layout, (String, String)> {
        let mut t_s = None;
        let mut refs: Vec<(Measurand, usize)> = Vec::new();
        let mut ambient = None;
        let mut gratings: Vec<(usize, usize)> = Vec::new();
        let mut split = None;
        let dup = |h: &str| (h.to_string(), format!("column `{}` appears twice in the header", quote_cell(h)));
        for (c, h) in headers.iter().enumerate() {
            let set = |slot: &mut Option<usize>| if slot.replace(c).is_some() { Err(dup(h)) } else { Ok(()) };
            match h {
                "t_s" => set(&mut t_s)?,
                T_AMB_COLUMN => set(&mut ambient)?,
                "split" => set(&mut split)?,
                _ => {
                    if let Some(m) =
                        Measurand::parse(h).map_err(|e| (h.to_string(), format!("column `{}`: {e}", quote_cell(h))))?
                    {
                        if refs.iter().any(|&(o, _)| o == m) {
                            return Err(dup(h));
                        }
                        refs.push((m, c));
                    } else if let Some(g) = parse_grating_column(h)
                        .map_err(|e| (h.to_string(), format!("column `{}`: {e}", quote_cell(h))))?
                    {
                        if gratings.iter().any(|&(o, _)| o == g) {
                            return Err(dup(h));
                        }
                        gratings.push((g, c));
                    }
                }
            }
        }
        let required = "required: t_s and the gratings dl1_pm..dlN_pm (N from 1 to 8); optional: T_amb_C, the references (T_C, strain_ue, p_kPa, T2_C, strain2_ue, ...), split";
        let Some(t_s) = t_s else { return Err(("t_s".into(), format!("missing column `t_s` ({required})"))) };
        gratings.sort();
        for (k, &(g, _)) in gratings.iter().enumerate() {
            if g != k + 1 {
                let want = grating_column(k + 1);
                return Err((want.clone(), format!("missing column `{want}` while `{}` is there: gratings are numbered dl1_pm..dlN_pm without holes", grating_column(g))));
            }
        }
        if gratings.is_empty() {
            return Err(("dl1_pm".into(), format!("missing column `dl1_pm` ({required})")));
        }
        refs.sort();
        if refs.len() > MAX_MEASURANDS {
            let names: Vec<String> = refs.iter().map(|(m, _)| m.column()).collect();
            return Err((
                refs[MAX_MEASURANDS].0.column(),
                format!(
                    "{} reference columns ({}); at most {MAX_MEASURANDS} measurands are supported",
                    refs.len(),
                    names.join(", ")
                ),
            ));
        }
        Ok(Layout { t_s, refs, ambient, gratings: gratings.into_iter().map(|(_, c)| c).collect(), split })
    }
}

/// The record metadata in the comment lines at the top of a dataset CSV (errors name the
/// line); the read position is restored to the start.
fn read_meta(f: &mut std::fs::File, name: &str) -> Result<RecordMeta, TrainerError> {
    use std::io::{BufRead, BufReader, Seek, SeekFrom};
    let mut meta = RecordMeta::default();
    let mut r = BufReader::new(LineLimit::new(&mut *f));
    let mut line = String::new();
    let mut n = 0u64;
    loop {
        line.clear();
        // A non-UTF-8 first line, or one over the line limit, is the CSV reader's to report.
        if r.read_line(&mut line).unwrap_or(0) == 0 {
            break;
        }
        n += 1;
        let l = line.trim_start_matches('\u{feff}');
        if !l.starts_with('#') {
            break;
        }
        meta.read_comment(l.trim_end()).map_err(|m| TrainerError::data(name, n, "#", m))?;
        meta.comment_lines = n;
    }
    drop(r);
    f.seek(SeekFrom::Start(0)).map_err(|e| TrainerError::data(name, 1, "-", e.to_string()))?;
    Ok(meta)
}

/// The record's zero and clock: its sidecar's when there is one (a record with comment lines
/// too must say the same in both), else its comment lines'; with what the sidecar says of the
/// table it was written with (`file_len`: the CSV's length, checked here).
fn with_sidecar(
    mut meta: RecordMeta,
    path: &Path,
    gratings: usize,
    file_len: u64,
) -> Result<(RecordMeta, Option<SidecarTable>), TrainerError> {
    let Some((side, table)) = RecordMeta::read_sidecar(path, gratings, file_len)? else { return Ok((meta, None)) };
    if !meta.is_empty() && meta != side {
        return Err(TrainerError::data(
            &path.display().to_string(),
            1,
            "#",
            format!(
                "the comment lines before the header state another zero or clock than {}: keep one of them (the tool writes the sidecar)",
                side.sidecar.as_deref().unwrap_or(path).display()
            ),
        ));
    }
    meta.zero = side.zero;
    meta.t0_unix_s = side.t0_unix_s;
    meta.sidecar = side.sidecar;
    Ok((meta, Some(table)))
}

/// The last byte of a file (`None` when empty); the read position is restored to the start.
fn last_byte(f: &mut std::fs::File) -> std::io::Result<Option<u8>> {
    use std::io::{Read, Seek, SeekFrom};
    let len = f.metadata()?.len();
    if len == 0 {
        return Ok(None);
    }
    let mut b = [0u8];
    f.seek(SeekFrom::Start(len - 1))?;
    f.read_exact(&mut b)?;
    f.seek(SeekFrom::Start(0))?;
    Ok(Some(b[0]))
}
