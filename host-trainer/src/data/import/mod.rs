//! `fbg-trainer import`: real interrogator exports into the dataset CSV of DESIGN §3.
//!
//! - `--format enlight`: a Micron Optics ENLIGHT / Hyperion peaks export (`enlight.rs`),
//!   optionally with a `--refs` CSV holding the ambient temperature and the references, joined
//!   onto the peak times by linear interpolation (`join.rs`);
//! - `--format csv`: any logger CSV whose columns a map names (`logger_csv.rs`).
//!
//! Both take 1 to 8 gratings and up to 4 measurands. References and the ambient thermometer are
//! optional: a record without references is imported row for row (every row kept, gaps as
//! gaps) for `compensate`, not for training, and the summary says so.
//!
//! The map is described in [`mapping`]. Bad rows are an error naming file, line and column, or
//! counted skips ([`problems`]); the output is written atomically (`Dataset::write_csv`).

mod enlight;
mod join;
mod logger_csv;
pub mod mapping;
pub mod problems;
pub mod time_axis;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::data::measurand::{grating_column, Measurand};
use crate::data::{Dataset, GratingZero, RecordMeta, Reference, Split, T_AMB_COLUMN};
use crate::error::TrainerError;
use fbg_shared::ZeroSource;
pub use mapping::Map;
pub use problems::{FileSkips, OnError, Reason, ReasonCount};
pub use time_axis::TimeKind;

use mapping::For;
use time_axis::{format_timestamp, parse_timestamp};

/// The input layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    Enlight,
    Csv,
}

impl std::str::FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "enlight" => Ok(Format::Enlight),
            "csv" => Ok(Format::Csv),
            other => Err(format!("`{other}` is neither `enlight` nor `csv`")),
        }
    }
}

/// How the calibration / hold-out split is drawn.
#[derive(Clone, Debug, PartialEq)]
pub enum SplitChoice {
    /// Rows up to this fraction of the record's duration calibrate.
    Fraction(f64),
    /// Rows up to this time calibrate: seconds from the first written row, or a timestamp
    /// (for files with calendar time).
    Until(String),
}

impl Default for SplitChoice {
    fn default() -> Self {
        SplitChoice::Fraction(0.5)
    }
}

/// Everything `import` needs.
#[derive(Clone, Debug)]
pub struct ImportOptions {
    pub format: Format,
    pub input: PathBuf,
    pub map: Option<PathBuf>,
    pub refs: Option<PathBuf>,
    pub split: SplitChoice,
    pub on_error: OnError,
    /// `--on-error skip`: the largest fraction of a file's rows that may be skipped as bad;
    /// above it the import fails with the counts by reason ([`DEFAULT_MAX_SKIPPED`]).
    pub max_skipped: f64,
    /// `--model`: zero absolute wavelengths on a model's λ_ref instead of the map's or the
    /// first reading (a field record read against the calibration's zero).
    pub zero_from: Option<ModelZero>,
    /// `--start`: absolute time (Unix s) of the first row, for a record whose times are plain
    /// seconds.
    pub start_unix_s: Option<f64>,
}

/// A model's zero, for [`ImportOptions::zero_from`].
#[derive(Clone, Debug, PartialEq)]
pub struct ModelZero {
    /// The model file (for messages).
    pub model: String,
    /// λ_ref per grating \[nm\], `None` where the model does not know it.
    pub lambda_ref_nm: Vec<Option<f64>>,
}

/// Default of [`ImportOptions::max_skipped`]: 5 % of a file's rows.
pub const DEFAULT_MAX_SKIPPED: f64 = 0.05;

/// Rows left out because no ambient temperature was known at their time.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Dropped {
    pub count: usize,
    pub first_lines: Vec<u64>,
}

/// One output grating.
#[derive(Clone, Debug, Serialize)]
pub struct GratingSummary {
    /// Output column (`dl1_pm`, ...).
    pub output: String,
    /// Where it comes from (column and unit, or channel and window).
    pub source: String,
    /// Reference wavelength \[nm\] the shift is taken from (absent for shift columns).
    pub ref_nm: Option<f64>,
    /// `map`, `first reading (line N)` or `shifts in the file`.
    pub ref_source: String,
    /// Rows with no reading (empty dl cell).
    pub gaps: usize,
    /// Range of the shifts written \[pm\].
    pub min_pm: Option<f64>,
    pub max_pm: Option<f64>,
}

/// One reference column found.
#[derive(Clone, Debug, Serialize)]
pub struct RefSummary {
    /// The source column (in the input or the refs file).
    pub column: String,
    /// Written rows that have a value.
    pub values: usize,
}

/// The ambient temperature and the references found. In JSON, one key per dataset column:
/// `T_amb_C` (null without a thermometer) and each measurand found (`T_C`, `strain2_ue`, ...).
#[derive(Clone, Debug)]
pub struct References {
    /// The ambient thermometer, if the record has one.
    pub ambient: Option<RefSummary>,
    /// The measurands found, in canonical order.
    pub measurands: Vec<(Measurand, RefSummary)>,
}

impl References {
    /// The source of measurand `m`, if found.
    pub fn get(&self, m: Measurand) -> Option<&RefSummary> {
        self.measurands.iter().find(|(x, _)| *x == m).map(|(_, r)| r)
    }
}

impl Serialize for References {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(1 + self.measurands.len()))?;
        map.serialize_entry(T_AMB_COLUMN, &self.ambient)?;
        for (m, r) in &self.measurands {
            map.serialize_entry(&m.column(), r)?;
        }
        map.end()
    }
}

/// What the imported record is good for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Purpose {
    /// References present: `train`, `evaluate` (and `compensate`, which also scores).
    Training,
    /// No references: every row kept, for `compensate` only.
    Compensation,
}

/// The written record's time span.
#[derive(Clone, Debug, Serialize)]
pub struct TimeSummary {
    /// Timestamps or seconds in the input.
    pub kind: TimeKind,
    /// First and last written row as timestamps (calendar time only).
    pub start: Option<String>,
    pub end: Option<String>,
    pub span_s: f64,
    /// Median sampling interval \[s\].
    pub median_dt_s: f64,
}

/// The split written.
#[derive(Clone, Debug, Serialize)]
pub struct SplitSummary {
    /// `fraction 0.5` or `until <TIME>`.
    pub rule: String,
    /// Rows with t_s at or before this calibrate.
    pub cal_until_s: f64,
    pub cal_rows: usize,
    pub holdout_rows: usize,
}

/// ENLIGHT file facts.
#[derive(Clone, Debug, Serialize)]
pub struct EnlightInfo {
    pub channels: usize,
    pub delimiter: String,
    /// Lines before the first data row.
    pub metadata_lines: usize,
    /// Without a map: rows where a channel's peak count differed from its usual count (that
    /// channel's gratings are gaps there).
    pub unassigned_rows: usize,
    /// The culture the file was read in and where it came from (`de-DE (line 2)`), if any.
    pub culture: Option<String>,
    /// Day/month order of numeric dates (`day_first`, `month_first`; absent for year-first
    /// dates or seconds) ...
    pub date_order: Option<time_axis::DateOrder>,
    /// ... and what decided it (the culture, or a date with a day above 12).
    pub date_order_from: Option<String>,
}

/// How the references were joined onto the peak times.
#[derive(Clone, Debug, Serialize)]
pub struct JoinInfo {
    pub max_gap_s: f64,
    /// `map` or `3 × median refs spacing`.
    pub max_gap_source: String,
    pub refs_rows: usize,
    pub refs_start: String,
    pub refs_end: String,
}

/// What an import did; `--json` prints it.
#[derive(Clone, Debug, Serialize)]
pub struct ImportSummary {
    pub format: Format,
    pub input: String,
    pub map: Option<String>,
    pub refs: Option<String>,
    pub out: Option<String>,
    /// Data rows in the input.
    pub rows_read: usize,
    pub rows_written: usize,
    /// Bad input rows left out (`--on-error skip`).
    pub rows_skipped: usize,
    /// Bad rows per file (the input, then the refs) and reason.
    pub skipped: Vec<FileSkips>,
    /// What the record is for: training (references present) or compensation (none; every
    /// row kept).
    pub purpose: Purpose,
    /// Rows without an ambient temperature (outside the refs, or in a gap longer than
    /// max_gap_s, or an empty ambient cell) — dropped only from a record with references and
    /// an ambient thermometer.
    pub dropped_no_ambient: Dropped,
    /// Gaps per grating (dl1..dlN).
    pub gaps: Vec<usize>,
    pub gratings: Vec<GratingSummary>,
    pub references: References,
    pub time: TimeSummary,
    pub split: SplitSummary,
    pub enlight: Option<EnlightInfo>,
    pub join: Option<JoinInfo>,
}

/// Import and write `out` atomically; the summary names `out`.
pub fn import_to_csv(opts: &ImportOptions, out: &Path) -> Result<ImportSummary, TrainerError> {
    let (d, mut s) = import(opts)?;
    d.write_csv(out)?;
    s.out = Some(out.display().to_string());
    Ok(s)
}

/// Read the input (and refs) into a dataset with its split, without writing anything.
pub fn import(opts: &ImportOptions) -> Result<(Dataset, ImportSummary), TrainerError> {
    let input_name = opts.input.display().to_string();
    let map_origin = opts.map.as_ref().map(|p| p.display().to_string());
    let map = match &opts.map {
        Some(p) => Some(Map::load(p)?),
        None => None,
    };
    let what = match opts.format {
        Format::Csv => For::Csv,
        Format::Enlight => For::Enlight,
    };
    if let (Some(m), Some(o)) = (&map, &map_origin) {
        m.validate(o, what)?;
    }
    let default_map = Map::default();
    let m = map.as_ref().unwrap_or(&default_map);

    let merged = match opts.format {
        Format::Csv => {
            if opts.refs.is_some() {
                return Err(TrainerError::Config {
                    origin: input_name,
                    key: "--refs".into(),
                    message: "--refs is for --format enlight; a logger CSV carries its ambient temperature and references in its own columns (name them in the map)".into(),
                });
            }
            let gratings = m.csv_gratings();
            let tab = logger_csv::read(&opts.input, m, Some(&gratings), opts.on_error)?;
            let n = tab.t.len();
            let skips = vec![tab.problems.summary()];
            let specs = &tab.grating_specs;
            Merged {
                input: input_name.clone(),
                lines: tab.lines,
                t: tab.t,
                kind: tab.time_kind,
                absolute: tab.absolute,
                time_column: tab.time_column,
                empty_hint: format!(
                    "{input_name}: every row lacks an ambient temperature (column `{}`)",
                    tab.ambient.as_ref().map_or(T_AMB_COLUMN, |a| a.name.as_str())
                ),
                ambient: tab.ambient.map(|a| (a.name, a.values)),
                refs: tab.refs.into_iter().map(|(m, c)| (m, c.name, c.values)).collect(),
                is_shift: specs.iter().map(|g| g.unit.is_shift()).collect(),
                ref_nm: specs.iter().map(|g| g.ref_nm).collect(),
                sources: tab
                    .gratings
                    .iter()
                    .zip(specs)
                    .map(|(c, g)| format!("column `{}` ({})", c.name, g.unit.name()))
                    .collect(),
                wl: tab.gratings.into_iter().map(|c| c.values).collect(),
                rows_read: skips[0].rows_read,
                skips,
                enlight: None,
                join: None,
                n_before_drop: n,
            }
        }
        Format::Enlight => {
            let peaks =
                enlight::read(&opts.input, map.as_ref(), map_origin.as_deref().unwrap_or("map"), opts.on_error)?;
            let window_map = map.as_ref().is_some_and(|m| !m.grating.is_empty());
            let n_g = peaks.nm.len();
            let mut merged = Merged {
                input: input_name.clone(),
                lines: peaks.lines.clone(),
                t: peaks.t.clone(),
                kind: peaks.time_kind,
                absolute: peaks.absolute,
                time_column: "1 (time)".into(),
                ambient: None,
                refs: Vec::new(),
                wl: peaks.nm.clone(),
                is_shift: vec![false; n_g],
                ref_nm: (0..n_g).map(|g| if window_map { m.grating[g].ref_nm } else { None }).collect(),
                sources: peaks.layout.clone(),
                rows_read: peaks.problems.rows_read,
                skips: vec![peaks.problems.summary()],
                enlight: Some(EnlightInfo {
                    channels: peaks.channels,
                    delimiter: if peaks.delimiter == '\t' { "tab".into() } else { peaks.delimiter.to_string() },
                    metadata_lines: peaks.metadata_lines,
                    unassigned_rows: peaks.unassigned_rows,
                    culture: peaks.culture.clone(),
                    date_order: peaks.date_order.as_ref().map(|d| d.0),
                    date_order_from: peaks.date_order.as_ref().map(|d| d.1.clone()),
                }),
                join: None,
                empty_hint: String::new(),
                n_before_drop: peaks.t.len(),
            };
            // ENLIGHT files carry no ambient temperature and no references: they come from
            // --refs when the installation has them; without, the peaks are a field record.
            if let Some(refs_path) = &opts.refs {
                let refs = logger_csv::read(refs_path, m, None, opts.on_error)?;
                let refs_name = refs_path.display().to_string();
                if refs.ambient.is_none() && refs.refs.is_empty() {
                    return Err(TrainerError::data(
                        &refs_name,
                        refs.header_line,
                        T_AMB_COLUMN,
                        "the refs file has neither an ambient temperature (T_amb_C, or the map's [ambient]) nor a reference column (T_C, strain_ue, p_kPa, strain2_ue, ..., or the map's [temperature], [strain], [pressure], [[measurand]]): nothing to join",
                    ));
                }
                if peaks.absolute != refs.absolute {
                    let (p, r) = (kind_words(peaks.absolute), kind_words(refs.absolute));
                    let fix = if refs.absolute {
                        "export the peaks with timestamps"
                    } else {
                        "set the map key time.start to the timestamp of t = 0 in the refs (or export the refs with timestamps)"
                    };
                    return Err(TrainerError::data(
                        &refs_name,
                        refs.header_line,
                        &refs.time_column,
                        format!("the peaks file's times are {p} but the refs' time column holds {r}, so they cannot be joined: {fix}"),
                    ));
                }
                let (max_gap_s, max_gap_source) = match m.max_gap_s {
                    Some(g) => (g, "map".to_string()),
                    None => (3.0 * join::median_spacing(&refs.t), "3 × median refs spacing".to_string()),
                };
                let at = |v: &[f64]| {
                    let s = join::Series::new(&refs.t, v);
                    peaks.t.iter().map(|&t| s.at(t, max_gap_s)).collect::<Vec<f64>>()
                };
                let show = |t: f64| if peaks.absolute { format_timestamp(t) } else { format!("{t} s") };
                let join = JoinInfo {
                    max_gap_s,
                    max_gap_source,
                    refs_rows: refs.t.len(),
                    refs_start: show(refs.t[0]),
                    refs_end: show(refs.t[refs.t.len() - 1]),
                };
                merged.empty_hint = format!(
                    "{input_name}: no peak row has an ambient temperature from {refs_name}: the peaks span {} – {}, the refs {} – {} (max_gap_s = {max_gap_s})",
                    show(peaks.t[0]),
                    show(peaks.t[peaks.t.len() - 1]),
                    join.refs_start,
                    join.refs_end
                );
                merged.ambient = refs.ambient.as_ref().map(|a| (a.name.clone(), at(&a.values)));
                merged.refs = refs.refs.iter().map(|(mm, c)| (*mm, c.name.clone(), at(&c.values))).collect();
                merged.skips.push(refs.problems.summary());
                merged.join = Some(join);
            }
            merged
        }
    };
    refuse_too_many_skipped(&merged.skips, opts.max_skipped)?;
    finish(merged, opts, map_origin)
}

/// Under `--on-error skip`, a file that loses more than `max` of its rows is not imported: so
/// large a loss means a wrong map or a damaged export, not a few bad rows.
fn refuse_too_many_skipped(skips: &[FileSkips], max: f64) -> Result<(), TrainerError> {
    for f in skips {
        if f.rows_read == 0 || (f.rows_skipped as f64) <= max * f.rows_read as f64 {
            continue;
        }
        let reasons: Vec<String> = f
            .by_reason
            .iter()
            .map(|(r, c)| {
                let lines: Vec<String> = c.first_lines.iter().map(u64::to_string).collect();
                let more = if c.count > c.first_lines.len() { ", …" } else { "" };
                format!("{} × {} (lines {}{more})", c.count, r.as_str(), lines.join(", "))
            })
            .collect();
        return Err(TrainerError::Config {
            origin: f.file.clone(),
            key: "--max-skipped".into(),
            message: format!(
                "{} of {} rows ({:.1} %) would be skipped as bad, more than the {} % allowed: {}; nothing written (fix the export or the map, or raise --max-skipped)",
                f.rows_skipped,
                f.rows_read,
                100.0 * f.rows_skipped as f64 / f.rows_read as f64,
                100.0 * max,
                reasons.join(", ")
            ),
        });
    }
    Ok(())
}

fn kind_words(absolute: bool) -> &'static str {
    if absolute {
        "calendar timestamps"
    } else {
        "plain seconds"
    }
}

/// The rows of either importer before the common steps.
struct Merged {
    input: String,
    lines: Vec<u64>,
    t: Vec<f64>,
    kind: TimeKind,
    absolute: bool,
    time_column: String,
    /// The ambient thermometer (source column, values), if the record has one.
    ambient: Option<(String, Vec<f64>)>,
    /// The references (measurand, source column, values), in canonical order.
    refs: Vec<(Measurand, String, Vec<f64>)>,
    /// Absolute nm, or shift pm where `is_shift`; one per grating.
    wl: Vec<Vec<f64>>,
    is_shift: Vec<bool>,
    ref_nm: Vec<Option<f64>>,
    sources: Vec<String>,
    rows_read: usize,
    skips: Vec<FileSkips>,
    enlight: Option<EnlightInfo>,
    join: Option<JoinInfo>,
    /// Error when no row has an ambient temperature.
    empty_hint: String,
    n_before_drop: usize,
}

/// Drop rows without ambient temperature (from a record with references), take shifts, build
/// the dataset and its split.
fn finish(
    m: Merged,
    opts: &ImportOptions,
    map_origin: Option<String>,
) -> Result<(Dataset, ImportSummary), TrainerError> {
    // A record with references is for training: a row without its ambient reading cannot be
    // fitted and is dropped (counted). A record without references is for `compensate`: every
    // row is kept, a missing ambient reading a gap like a missing peak.
    let purpose = if m.refs.is_empty() { Purpose::Compensation } else { Purpose::Training };
    let drops = |i: usize| purpose == Purpose::Training && m.ambient.as_ref().is_some_and(|(_, a)| !a[i].is_finite());
    let keep: Vec<usize> = (0..m.n_before_drop).filter(|&i| !drops(i)).collect();
    let mut dropped = Dropped::default();
    for i in (0..m.n_before_drop).filter(|&i| drops(i)) {
        dropped.count += 1;
        if dropped.first_lines.len() < problems::FIRST_LINES {
            dropped.first_lines.push(m.lines[i]);
        }
    }
    if keep.is_empty() {
        return Err(TrainerError::Dataset { message: m.empty_hint });
    }
    let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let t0 = m.t[keep[0]];
    let t_s: Vec<f64> = keep.iter().map(|&i| m.t[i] - t0).collect();
    // The dataset CSV writes t_s with ms resolution; faster sampling would collide.
    for w in 1..t_s.len() {
        if (t_s[w] * 1e3).round() <= (t_s[w - 1] * 1e3).round() {
            return Err(TrainerError::data(
                &m.input,
                m.lines[keep[w]],
                &m.time_column,
                format!("this row is {:.3} ms after the previous one; the dataset's t_s has millisecond resolution, so rows must be at least 1 ms apart", 1e3 * (t_s[w] - t_s[w - 1])),
            ));
        }
    }

    let n_g = m.wl.len();
    if let Some(z) = &opts.zero_from {
        if z.lambda_ref_nm.len() != n_g {
            return Err(TrainerError::Config {
                origin: "--model".into(),
                key: String::new(),
                message: format!(
                    "{} has {} gratings but {} has {n_g}: the model cannot zero this record",
                    z.model,
                    z.lambda_ref_nm.len(),
                    m.input
                ),
            });
        }
    }
    let mut dl: Vec<Vec<f64>> = Vec::with_capacity(n_g);
    let mut gratings = Vec::with_capacity(n_g);
    let mut zero = Vec::with_capacity(n_g);
    for g in 0..n_g {
        let v = pick(&m.wl[g]);
        let model_ref = opts.zero_from.as_ref().map(|z| (z.model.as_str(), z.lambda_ref_nm[g]));
        let (ref_nm, ref_source, source) = if m.is_shift[g] {
            (None, "shifts in the file".to_string(), ZeroSource::Unknown)
        } else if let Some((model, r)) = model_ref {
            let Some(r) = r else {
                return Err(TrainerError::Config {
                    origin: "--model".into(),
                    key: String::new(),
                    message: format!("{model} does not know grating {}'s reference wavelength (it was calibrated on shifts): zero the record with the calibration's map instead", g + 1),
                });
            };
            (Some(r), format!("model {model}"), ZeroSource::Model)
        } else if let Some(r) = m.ref_nm[g] {
            (Some(r), "map".to_string(), ZeroSource::Map)
        } else {
            match v.iter().position(|x| x.is_finite()) {
                Some(k) => (Some(v[k]), format!("first reading (line {})", m.lines[keep[k]]), ZeroSource::FirstReading),
                None => (None, "no reading".to_string(), ZeroSource::Unknown),
            }
        };
        zero.push(match ref_nm {
            Some(nm) => GratingZero { nm, source },
            None => GratingZero::UNKNOWN,
        });
        let shifts: Vec<f64> = match ref_nm {
            Some(r) => v.iter().map(|&x| (x - r) * 1e3).collect(),
            None => v,
        };
        let finite = shifts.iter().copied().filter(|x| x.is_finite());
        let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        gratings.push(GratingSummary {
            output: grating_column(g + 1),
            source: m.sources[g].clone(),
            ref_nm,
            ref_source,
            gaps: shifts.iter().filter(|x| !x.is_finite()).count(),
            min_pm: lo.is_finite().then_some(lo),
            max_pm: hi.is_finite().then_some(hi),
        });
        dl.push(shifts);
    }
    let n = keep.len();
    let mut d = Dataset {
        t_s,
        refs: m.refs.iter().map(|(measurand, _, v)| Reference { measurand: *measurand, values: pick(v) }).collect(),
        t_amb_c: m.ambient.as_ref().map(|(_, a)| pick(a)),
        dl_pm: dl,
        split: vec![Split::Cal; n],
        meta: RecordMeta { zero, ..RecordMeta::default() },
    };
    d.sort_refs();
    d.meta.t0_unix_s = match (m.absolute, opts.start_unix_s) {
        (true, None) => Some(t0),
        (false, start) => start,
        (true, Some(_)) => {
            return Err(TrainerError::Config {
                origin: "--start".into(),
                key: String::new(),
                message: format!("{} has calendar timestamps: its start is known, drop --start", m.input),
            })
        }
    };

    let (rule, cal_until_s) = match &opts.split {
        SplitChoice::Fraction(f) => {
            if !(f.is_finite() && *f > 0.0 && *f <= 1.0) {
                return Err(TrainerError::Config {
                    origin: "--cal-fraction".into(),
                    key: String::new(),
                    message: format!("{f} is not a fraction in (0, 1]"),
                });
            }
            (format!("fraction {f}"), f * d.t_s[n - 1])
        }
        SplitChoice::Until(s) => {
            let until = if let Ok(v) = s.trim().parse::<f64>() {
                if !v.is_finite() {
                    return Err(TrainerError::Config {
                        origin: "--cal-until".into(),
                        key: String::new(),
                        message: format!("`{s}` is not a finite time"),
                    });
                }
                v
            } else if let Some(ts) = parse_timestamp(s, None) {
                if !m.absolute {
                    return Err(TrainerError::Config {
                        origin: "--cal-until".into(),
                        key: String::new(),
                        message: format!("`{s}` is a timestamp but the input's times are plain seconds: give seconds from the first row"),
                    });
                }
                ts - t0
            } else {
                return Err(TrainerError::Config {
                    origin: "--cal-until".into(),
                    key: String::new(),
                    message: format!(
                        "`{s}` is neither seconds from the first row nor a timestamp (YYYY-MM-DD hh:mm:ss[.fff])"
                    ),
                });
            };
            (format!("until {s}"), until)
        }
    };
    d.split_at_time(cal_until_s);
    let cal_rows = d.split.iter().filter(|&&s| s == Split::Cal).count();

    let time = TimeSummary {
        kind: m.kind,
        start: m.absolute.then(|| format_timestamp(t0)),
        end: m.absolute.then(|| format_timestamp(t0 + d.t_s[n - 1])),
        span_s: d.t_s[n - 1],
        median_dt_s: join::median_spacing(&d.t_s),
    };
    let count = |v: &[f64]| v.iter().filter(|x| x.is_finite()).count();
    let mut found: Vec<(Measurand, RefSummary)> = m
        .refs
        .iter()
        .map(|(mm, name, _)| (*mm, RefSummary { column: name.clone(), values: d.reference(*mm).map_or(0, count) }))
        .collect();
    found.sort_by_key(|(mm, _)| *mm);
    let references = References {
        ambient: m.ambient.as_ref().map(|(name, _)| RefSummary { column: name.clone(), values: count(d.ambient()) }),
        measurands: found,
    };
    let summary = ImportSummary {
        format: opts.format,
        input: m.input.clone(),
        map: map_origin,
        refs: opts.refs.as_ref().map(|p| p.display().to_string()),
        out: None,
        rows_read: m.rows_read,
        rows_written: n,
        rows_skipped: m.skips[0].rows_skipped,
        skipped: m.skips,
        purpose,
        dropped_no_ambient: dropped,
        gaps: gratings.iter().map(|g| g.gaps).collect(),
        gratings,
        references,
        time,
        split: SplitSummary { rule, cal_until_s, cal_rows, holdout_rows: n - cal_rows },
        enlight: m.enlight,
        join: m.join,
    };
    Ok((d, summary))
}

impl ImportSummary {
    /// A few lines for a terminal.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let out = self.out.as_deref().unwrap_or("(not written)");
        s.push_str(&format!(
            "imported {} ({}): {} rows read, {} written to {out}, {} skipped as bad, {} without ambient temperature\n",
            self.input,
            match self.format {
                Format::Enlight => "ENLIGHT peaks",
                Format::Csv => "logger CSV",
            },
            self.rows_read,
            self.rows_written,
            self.rows_skipped,
            self.dropped_no_ambient.count
        ));
        for f in &self.skipped {
            for (r, c) in &f.by_reason {
                let lines: Vec<String> = c.first_lines.iter().map(u64::to_string).collect();
                let more = if c.count > c.first_lines.len() { ", …" } else { "" };
                s.push_str(&format!(
                    "  skipped {} × {} in {} (lines {}{more})\n",
                    c.count,
                    r.as_str(),
                    f.file,
                    lines.join(", ")
                ));
            }
        }
        if self.dropped_no_ambient.count > 0 {
            let lines: Vec<String> = self.dropped_no_ambient.first_lines.iter().map(u64::to_string).collect();
            s.push_str(&format!(
                "  dropped {} rows with no ambient temperature (lines {}…)\n",
                self.dropped_no_ambient.count,
                lines.join(", ")
            ));
        }
        if let Some(e) = &self.enlight {
            s.push_str(&format!(
                "  {} channels, {}-separated, {} metadata lines",
                e.channels, e.delimiter, e.metadata_lines
            ));
            if e.unassigned_rows > 0 {
                s.push_str(&format!(", {} rows with an unusual peak count (gaps)", e.unassigned_rows));
            }
            if let Some(c) = &e.culture {
                s.push_str(&format!(", culture {c}"));
            }
            if let (Some(o), Some(from)) = (e.date_order, &e.date_order_from) {
                s.push_str(&format!(", dates {} ({from})", o.words()));
            }
            s.push('\n');
        }
        for g in &self.gratings {
            let r = match g.ref_nm {
                Some(r) => format!("λ_ref {r:.4} nm from {}", g.ref_source),
                None => g.ref_source.clone(),
            };
            let range = match (g.min_pm, g.max_pm) {
                (Some(a), Some(b)) => format!("{a:.1} … {b:.1} pm"),
                _ => "no values".into(),
            };
            s.push_str(&format!("  {}: {}; {r}; {range}; {} gaps\n", g.output, g.source, g.gaps));
        }
        let r = &self.references;
        let ambient = match &r.ambient {
            Some(a) => format!("T_amb_C ← `{}` ({} values)", a.column, a.values),
            None => "no ambient thermometer (no T_amb_C column)".to_string(),
        };
        let refs: Vec<String> =
            r.measurands.iter().map(|(m, x)| format!("{m} ← `{}` ({} values)", x.column, x.values)).collect();
        let refs = if refs.is_empty() { "no references".to_string() } else { refs.join("; ") };
        s.push_str(&format!("  references: {ambient}; {refs}\n"));
        if self.purpose == Purpose::Compensation {
            s.push_str(
                "  no reference columns: imported row for row (every row kept, gaps as gaps) — a field record for `fbg-trainer compensate`, not for training\n",
            );
        }
        if let Some(j) = &self.join {
            s.push_str(&format!(
                "  refs joined by linear interpolation, max gap {} s ({}); refs {} – {}, {} rows\n",
                j.max_gap_s, j.max_gap_source, j.refs_start, j.refs_end, j.refs_rows
            ));
        }
        let t = &self.time;
        let when = match (&t.start, &t.end) {
            (Some(a), Some(b)) => format!("{a} – {b}, "),
            _ => String::new(),
        };
        s.push_str(&format!("  time: {when}{:.3} s span, median step {:.3} s\n", t.span_s, t.median_dt_s));
        let sp = &self.split;
        s.push_str(&format!(
            "  split ({}): cal up to t_s = {:.3} s: {} cal rows, {} hold-out rows",
            sp.rule, sp.cal_until_s, sp.cal_rows, sp.holdout_rows
        ));
        s
    }
}

/// A file as text (invalid UTF-8 replaced, byte-order mark removed).
pub(crate) fn read_text(path: &Path) -> Result<String, TrainerError> {
    let bytes = std::fs::read(path).map_err(|e| TrainerError::io(path, e))?;
    let text = String::from_utf8_lossy(&bytes).into_owned();
    Ok(match text.strip_prefix('\u{feff}') {
        Some(t) => t.to_string(),
        None => text,
    })
}

/// A numeric cell: `Ok(None)` when empty or a missing marker (NaN, NA, N/A, null).
pub(crate) fn number(cell: &str) -> Result<Option<f64>, String> {
    let c = cell.trim();
    if c.is_empty() || ["nan", "na", "n/a", "null"].iter().any(|m| c.eq_ignore_ascii_case(m)) {
        return Ok(None);
    }
    match c.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        Ok(_) => Err(format!("`{c}` is not a finite number")),
        Err(_) if c.matches(',').count() == 1 && c.replace(',', ".").parse::<f64>().is_ok() => Err(format!(
            "`{c}` is not a number (a decimal comma? use a point, or a delimiter other than the decimal mark)"
        )),
        Err(_) => Err(format!("`{c}` is not a number")),
    }
}
