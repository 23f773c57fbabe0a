//! Micron Optics ENLIGHT / Hyperion "peaks" exports.
//!
//! Metadata lines may precede the table. Each data row is a timestamp, one peak count per
//! channel, then that many wavelengths [nm] flattened channel by channel, so rows differ in
//! length; cells are tab-, comma- or `;`-separated. Peaks are assigned to the gratings (1 to 8)
//! by the map's channel and wavelength window (a missing peak is a gap, never a shifted
//! column), or without a map, each channel's peaks become gratings in order.
//!
//! Locale: an export written on a German, French or British PC says so in a `Culture:` header
//! line (`Culture: de-DE`; `Culture<TAB>de-DE` as the other metadata lines also works), or the
//! map's `[enlight] culture` says it for a file that lacks one. The culture gives the decimal
//! mark (`1535,012` in de-DE and fr-FR) and the day/month order of numeric dates (`01.03.2024`
//! is the 1st of March in de-DE, `03/01/2024` the same day in en-US). Without a culture, a date
//! with a first field above 12 makes the file day-first and one with a second field above 12
//! month-first; a file whose dates never settle it is refused (reading day-first as
//! month-first would give wrong dates without any error), and so is a culture the dates
//! contradict.

use std::path::Path;

use super::culture::{find_culture, looks_like_data, number_in, Culture};
use super::dates::DateProbe;
use super::mapping::Map;
use super::problems::{OnError, Problems, Reason, RowError};
use super::time_axis::{dmy_fields, DateOrder, Dmy, TimeKind, TimeParser, TimeUnit};
use super::TextLines;
use crate::data::measurand::MAX_GRATINGS;
use crate::data::units::{check_wavelength, UnitSource, WlUnit};
use crate::error::TrainerError;

/// Largest peak count a channel cell may hold.
const MAX_PEAKS_PER_CHANNEL: usize = 1000;

/// The peaks of one file, assigned to the gratings.
pub(crate) struct PeaksFile {
    /// Physical line of each accepted row.
    pub lines: Vec<u64>,
    /// Time on the file's axis [s].
    pub t: Vec<f64>,
    /// Absolute wavelength [nm] per grating; NaN = gap.
    pub nm: Vec<Vec<f64>>,
    pub channels: usize,
    pub delimiter: char,
    /// Lines before the first data row (metadata, column header).
    pub metadata_lines: usize,
    pub time_kind: TimeKind,
    pub absolute: bool,
    /// The culture the file was read in (its `Culture:` line or the map's), if any.
    pub culture: Option<String>,
    /// Day/month order of the numeric dates, and what decided it (none for year-first dates
    /// or seconds).
    pub date_order: Option<(DateOrder, String)>,
    /// Where each grating comes from, in words.
    pub layout: Vec<String>,
    /// Without a map: rows whose peak count on some channel differs from the usual one; that
    /// channel's gratings are gaps on those rows.
    pub unassigned_rows: usize,
    pub problems: Problems,
}

/// One parsed row: time and the peaks [nm] of each channel with their cell index.
struct RawRow {
    t: f64,
    peaks: Vec<Vec<(f64, usize)>>,
}

/// Read and assign. `map` is `None` without `--map`.
pub(crate) fn read(path: &Path, map: Option<&Map>, origin: &str, policy: OnError) -> Result<PeaksFile, TrainerError> {
    let name = path.display().to_string();
    let default_map = Map::default();
    let m = map.unwrap_or(&default_map);
    let map_delim = m
        .enlight
        .delimiter
        .as_deref()
        .map(super::mapping::delimiter)
        .transpose()
        .map_err(|e| TrainerError::data(&name, 1, "-", e))?
        .map(char::from);
    let guess_delim = |l: &str| guess_delimiter(l, map_delim);
    // The metadata, read as far as the culture's search needs (the map's header lines, or up to
    // the first line that may be data); the rows are read as a stream further down.
    let mut head = Head::open(path)?;
    match m.enlight.header_lines {
        Some(n) => head.read_to(n)?,
        None => {
            head.read_until(|l| looks_like_data(l, &guess_delim))?;
        }
    }
    let culture =
        find_culture(&head.lines(), m.enlight.header_lines, m.enlight.culture.as_deref(), origin, &name, &guess_delim)?;
    let decimal_comma = culture.as_ref().is_some_and(|c| c.decimal_comma);
    let mut clock = TimeParser::new(TimeUnit::Auto, m.enlight.time_format.clone(), None)
        .with_locale(decimal_comma, if m.enlight.time_format.is_some() { Dmy::Off } else { Dmy::Probe });

    let first = first_data_row(&mut head, m, &clock, &guess_delim, &name)?;
    head.read_to(first)?;
    let Some(first_line) = head.line(first).map(str::to_string) else {
        return Err(TrainerError::data(&name, first as u64 + 1, "-", "no data rows after the metadata header"));
    };
    drop(head);
    let first_line = first_line.as_str();
    let delim = guess_delim(first_line);
    if let (Some(c), ',') = (&culture, delim) {
        if c.decimal_comma {
            return Err(TrainerError::data(
                &name,
                first as u64 + 1,
                "-",
                format!(
                    "the culture {} ({}) writes a decimal comma, but this table is comma-separated, so its numbers cannot be told apart; export with tabs or semicolons, or check the culture",
                    c.name, c.source
                ),
            ));
        }
    }
    // The day/month order of numeric dates: the culture's, checked against every date, or the
    // dates' own (a field above 12); never a guess.
    let first_time = split_cells(first_line, delim).into_iter().next().unwrap_or_default();
    let date_order = if clock.dmy == Dmy::Probe && dmy_fields(&first_time).is_some() {
        let (order, why) = date_order(path, first, delim, culture.as_ref(), &name)?;
        clock.dmy = Dmy::Order(order);
        Some((order, why))
    } else {
        clock.dmy = Dmy::Off;
        None
    };
    let channels = match m.enlight.channels {
        Some(n) => n,
        None => infer_channels(&split_cells(first_line, delim)).ok_or_else(|| {
            TrainerError::data(
                &name,
                first as u64 + 1,
                "2 (peak count ch1)",
                "cannot tell the number of channels: no split of this row into peak counts and wavelengths adds up; set the map key enlight.channels",
            )
        })?,
    };
    let windows = m.windows();
    for w in &windows {
        if w.channel >= channels {
            return Err(TrainerError::Config {
                origin: origin.to_string(),
                key: format!("{}.channel", w.key),
                message: format!("channel {} but the file has {channels} channels", w.channel + 1),
            });
        }
    }
    let spec = RowSpec {
        delim,
        channels,
        unit: m.enlight.unit.unwrap_or(WlUnit::Nm),
        check: m.check_units(),
        culture: culture.as_ref(),
        windows: &windows,
    };
    let rows = read_rows(path, first, &spec, &mut clock, Problems::new(&name, policy))?;
    if rows.t.is_empty() {
        let why = if rows.problems.rows_read == 0 { "no data rows" } else { "every data row was skipped" };
        return Err(TrainerError::data(&name, first as u64 + 1, "-", why));
    }
    let Assigned { nm, layout, unassigned_rows } = if windows.is_empty() {
        in_order(&rows.raw, channels, rows.lines.first().copied().unwrap_or(1), &name)?
    } else {
        let layout =
            windows.iter().map(|w| format!("channel {}, window {}–{} nm", w.channel + 1, w.lo, w.hi)).collect();
        Assigned { nm: rows.nm, layout, unassigned_rows: 0 }
    };
    Ok(PeaksFile {
        lines: rows.lines,
        t: rows.t,
        nm,
        channels,
        delimiter: delim,
        metadata_lines: first,
        time_kind: clock.kind.unwrap_or(TimeKind::Timestamp),
        absolute: clock.absolute(),
        culture: culture.map(|c| format!("{} ({})", c.name, c.source)),
        date_order,
        layout,
        unassigned_rows,
        problems: rows.problems,
    })
}

/// The cells of a line split at `d`, trimmed, trailing empty cells dropped.
fn split_cells(l: &str, d: char) -> Vec<String> {
    let mut cs: Vec<String> = l.split(d).map(|c| c.trim().to_string()).collect();
    while cs.last().is_some_and(|c| c.is_empty()) {
        cs.pop();
    }
    cs
}

/// The map's delimiter, else tab, `;` or `,`, whichever the line holds first in that order.
fn guess_delimiter(l: &str, map_delim: Option<char>) -> char {
    map_delim.unwrap_or(if l.contains('\t') {
        '\t'
    } else if l.contains(';') {
        ';'
    } else {
        ','
    })
}

/// The index of the first data row: the map's `header_lines`, else the first line that is a
/// time and then a peak count (read on as far as that line, within [`HEAD_LINES`]).
fn first_data_row(
    head: &mut Head,
    m: &Map,
    clock: &TimeParser,
    guess_delim: &dyn Fn(&str) -> char,
    name: &str,
) -> Result<usize, TrainerError> {
    if let Some(n) = m.enlight.header_lines {
        return Ok(n);
    }
    let is_data = |l: &str| {
        let cs = split_cells(l, guess_delim(l));
        cs.len() >= 2 && clock.probe(&cs[0]) && cs[1].parse::<usize>().is_ok()
    };
    head.read_until(is_data)?.ok_or_else(|| {
        let within = if head.capped { format!(" in the first {HEAD_LINES} lines") } else { String::new() };
        TrainerError::data(
            name,
            1,
            "1 (time)",
            format!(
                "no data row found{within}: a peaks row starts with a time and the peak count of the first channel"
            ),
        )
    })
}

/// Lines of metadata before the first data row that a file may have.
const HEAD_LINES: usize = 100_000;

/// The first lines of a file, read as far as asked (at most [`HEAD_LINES`] + 1).
struct Head {
    text: TextLines,
    lines: Vec<String>,
    /// The file has no line after the last of `lines`.
    ended: bool,
    /// The search stopped at [`HEAD_LINES`].
    capped: bool,
}

impl Head {
    fn open(path: &Path) -> Result<Head, TrainerError> {
        Ok(Head { text: TextLines::open(path)?, lines: Vec::new(), ended: false, capped: false })
    }

    /// Read one more line; `false` at the end of the file or the cap.
    fn more(&mut self) -> Result<bool, TrainerError> {
        if self.ended || self.lines.len() > HEAD_LINES {
            self.capped |= !self.ended;
            return Ok(false);
        }
        match self.text.next_line()? {
            Some((_, l, _)) => self.lines.push(l.to_string()),
            None => self.ended = true,
        }
        Ok(!self.ended)
    }

    /// Read through line `i` (0-based), if the file has it.
    fn read_to(&mut self, i: usize) -> Result<(), TrainerError> {
        while self.lines.len() <= i && self.more()? {}
        Ok(())
    }

    /// Read on until a line read so far satisfies `stop`, or to the end (or the cap); the index
    /// of the first line that does.
    fn read_until(&mut self, stop: impl Fn(&str) -> bool) -> Result<Option<usize>, TrainerError> {
        if let Some(i) = self.lines.iter().position(|l| stop(l)) {
            return Ok(Some(i));
        }
        while self.more()? {
            if self.lines.last().is_some_and(|l| stop(l)) {
                return Ok(Some(self.lines.len() - 1));
            }
        }
        Ok(None)
    }

    fn lines(&self) -> Vec<&str> {
        self.lines.iter().map(String::as_str).collect()
    }

    fn line(&self, i: usize) -> Option<&str> {
        self.lines.get(i).map(String::as_str)
    }
}

/// The data lines of `path` from line index `first` (0-based) on, each with its number (from
/// 1) and whether it ended with a line end, to `each`.
fn data_lines(
    path: &Path,
    first: usize,
    mut each: impl FnMut(u64, &str, bool) -> Result<bool, TrainerError>,
) -> Result<(), TrainerError> {
    let mut text = TextLines::open(path)?;
    while let Some((number, l, ended)) = text.next_line()? {
        if number as usize > first && !each(number, l, ended)? {
            break;
        }
    }
    Ok(())
}

/// The day/month order of the numeric dates of the data lines (every one of them, or until
/// they settle it both ways), a pass of its own over the file.
fn date_order(
    path: &Path,
    first: usize,
    delim: char,
    culture: Option<&Culture>,
    name: &str,
) -> Result<(DateOrder, String), TrainerError> {
    let mut probe = DateProbe::new(first, culture, name);
    data_lines(path, first, |number, l, _| Ok(!probe.see(number, l.split(delim).next().unwrap_or(""))?))?;
    probe.finish()
}

/// How the data rows are read.
struct RowSpec<'a> {
    delim: char,
    channels: usize,
    unit: WlUnit,
    check: bool,
    culture: Option<&'a Culture>,
    /// The map's gratings; empty without a map (the peaks are then kept per channel, `raw`).
    windows: &'a [super::mapping::Window],
}

/// The accepted rows: their lines and times, the peaks assigned to the map's gratings (`nm`),
/// or without a map each row's peaks per channel (`raw`).
struct Rows {
    lines: Vec<u64>,
    t: Vec<f64>,
    raw: RawPeaks,
    nm: Vec<Vec<f64>>,
    problems: Problems,
}

/// Every data row from line index `first` on, checked, parsed and assigned, read as a stream;
/// bad rows fail or are counted as `problems`' policy says.
fn read_rows(
    path: &Path,
    first: usize,
    spec: &RowSpec,
    clock: &mut TimeParser,
    mut problems: Problems,
) -> Result<Rows, TrainerError> {
    let windows = spec.windows;
    let mut out_lines: Vec<u64> = Vec::new();
    let mut out_t: Vec<f64> = Vec::new();
    let mut raw = RawPeaks::default();
    let mut nm: Vec<Vec<f64>> = vec![Vec::new(); windows.len()];
    data_lines(path, first, |line, l, ended| {
        if l.trim().is_empty() {
            return Ok(true);
        }
        problems.rows_read += 1;
        let cs = split_cells(l, spec.delim);
        // Only the file's last line may lack a line end.
        let truncated_tail = !ended;
        let row = parse_row(&cs, line, spec, clock, truncated_tail).and_then(|r| {
            if let (Some(&prev), Some(&prev_line)) = (out_t.last(), out_lines.last()) {
                if r.t < prev {
                    return Err(RowError::new(
                        Reason::TimeBackwards,
                        line,
                        "1 (time)",
                        format!("time goes backwards: `{}` is earlier than line {prev_line}", cs[0]),
                    ));
                }
                if r.t == prev {
                    return Err(RowError::new(
                        Reason::DuplicateTime,
                        line,
                        "1 (time)",
                        format!("duplicated timestamp `{}` (same as line {prev_line})", cs[0]),
                    ));
                }
            }
            let assigned = if windows.is_empty() { Vec::new() } else { assign(&r, windows, line)? };
            Ok((r, assigned))
        });
        match row {
            Ok((r, assigned)) => {
                out_lines.push(line);
                out_t.push(r.t);
                if windows.is_empty() {
                    raw.push(&r.peaks);
                } else {
                    for (g, v) in assigned.into_iter().enumerate() {
                        nm[g].push(v);
                    }
                }
            }
            Err(e) => problems.reject(e)?,
        }
        Ok(true)
    })?;
    problems.refuse_wrong_unit_columns()?;
    Ok(Rows { lines: out_lines, t: out_t, raw, nm, problems })
}

/// Without a map, every row's peaks per channel, flat: a row's count per channel, then its
/// wavelengths \[nm\] channel by channel (no allocation per row).
#[derive(Default)]
struct RawPeaks {
    channels: usize,
    counts: Vec<u32>,
    nm: Vec<f64>,
}

impl RawPeaks {
    fn push(&mut self, peaks: &[Vec<(f64, usize)>]) {
        self.channels = peaks.len();
        for p in peaks {
            self.counts.push(p.len() as u32);
            self.nm.extend(p.iter().map(|&(v, _)| v));
        }
    }

    /// Each row's peaks, per channel.
    fn rows(&self) -> impl Iterator<Item = Vec<&[f64]>> + '_ {
        let mut at = 0;
        self.counts.chunks(self.channels.max(1)).map(move |counts| {
            counts
                .iter()
                .map(|&n| {
                    let p = self.nm.get(at..at + n as usize).unwrap_or(&[]);
                    at += n as usize;
                    p
                })
                .collect()
        })
    }
}

/// Without a map: each channel's usual peak count decides its gratings, in order; a row with
/// another count on a channel has gaps for that channel's gratings.
fn in_order(raw: &RawPeaks, channels: usize, first_line: u64, name: &str) -> Result<Assigned, TrainerError> {
    let usual: Vec<usize> = (0..channels).map(|c| mode(raw.rows().map(|r| r[c].len()))).collect();
    let gratings: Vec<(usize, usize)> = (0..channels).flat_map(|c| (0..usual[c]).map(move |k| (c, k))).collect();
    if gratings.is_empty() || gratings.len() > MAX_GRATINGS {
        let counts: Vec<String> = usual.iter().map(|n| n.to_string()).collect();
        return Err(TrainerError::data(
            name,
            first_line,
            &format!("2-{} (peak counts)", channels + 1),
            format!(
                "without --map each channel's peaks become gratings in order, and 1 to {MAX_GRATINGS} are supported; the rows usually hold {} = {} peaks: give a map with one [[grating]] entry (channel, window_nm) per grating",
                counts.join("+"),
                gratings.len()
            ),
        ));
    }
    let mut unassigned_rows = 0;
    let rows = raw.counts.len() / channels.max(1);
    let mut nm = vec![Vec::with_capacity(rows); gratings.len()];
    for r in raw.rows() {
        let mut odd = false;
        for (g, &(c, k)) in gratings.iter().enumerate() {
            let v = if r[c].len() == usual[c] { r[c][k] } else { f64::NAN };
            odd |= r[c].len() != usual[c];
            nm[g].push(v);
        }
        unassigned_rows += usize::from(odd);
    }
    let layout = gratings
        .iter()
        .map(|&(c, k)| format!("channel {}, peak {} of {} (in order, no map)", c + 1, k + 1, usual[c]))
        .collect();
    Ok(Assigned { nm, layout, unassigned_rows })
}

/// The peaks assigned to gratings.
struct Assigned {
    /// Absolute wavelength \[nm\] per grating; NaN = gap.
    nm: Vec<Vec<f64>>,
    /// Where each grating comes from, in words.
    layout: Vec<String>,
    /// Rows with an unusual peak count on some channel (no map only).
    unassigned_rows: usize,
}

/// The smallest channel count for which the row's counts and wavelengths add up.
fn infer_channels(cs: &[String]) -> Option<usize> {
    let mut sum = 0usize;
    for n in 1..cs.len() {
        let c: usize = cs[n].parse().ok()?;
        if c > MAX_PEAKS_PER_CHANNEL {
            return None;
        }
        sum += c;
        if 1 + n + sum == cs.len() {
            return Some(n);
        }
        if 1 + n + sum > cs.len() {
            return None;
        }
    }
    None
}

fn mode(it: impl Iterator<Item = usize>) -> usize {
    let mut counts = std::collections::BTreeMap::new();
    for v in it {
        *counts.entry(v).or_insert(0usize) += 1;
    }
    // Most frequent; ties go to the larger count (a dropped peak is likelier than a spurious one).
    counts.into_iter().max_by_key(|&(v, n)| (n, v)).map_or(0, |(v, _)| v)
}

/// Column label of cell `idx` (0-based) for a row with `counts`.
fn label(idx: usize, counts: &[usize]) -> String {
    if idx == 0 {
        return "1 (time)".into();
    }
    if idx <= counts.len() {
        return format!("{} (peak count ch{idx})", idx + 1);
    }
    let mut k = idx - 1 - counts.len();
    for (c, &n) in counts.iter().enumerate() {
        if k < n {
            return format!("{} (ch{} peak {})", idx + 1, c + 1, k + 1);
        }
        k -= n;
    }
    format!("{} (beyond the peaks)", idx + 1)
}

fn parse_row(
    cs: &[String],
    line: u64,
    spec: &RowSpec,
    clock: &mut TimeParser,
    truncated_tail: bool,
) -> Result<RawRow, RowError> {
    let (channels, unit, check, culture) = (spec.channels, spec.unit, spec.check, spec.culture);
    if cs.len() < 1 + channels {
        return Err(RowError::new(
            Reason::RaggedRow,
            line,
            format!("{} (peak count ch{})", cs.len() + 1, cs.len().max(1)),
            format!(
                "truncated row: {} cells, but a row needs a time and {channels} peak counts before its wavelengths",
                cs.len()
            ),
        ));
    }
    let t = clock.parse(&cs[0]).map_err(|m| RowError::new(Reason::NonNumeric, line, "1 (time)", m))?;
    let mut counts = Vec::with_capacity(channels);
    for c in 0..channels {
        let n: usize = cs[1 + c].parse().ok().filter(|&n| n <= MAX_PEAKS_PER_CHANNEL).ok_or_else(|| {
            RowError::new(
                Reason::NonNumeric,
                line,
                format!("{} (peak count ch{})", 2 + c, 1 + c),
                format!("`{}` is not a peak count", crate::error::quote_cell(&cs[1 + c])),
            )
        })?;
        counts.push(n);
    }
    let total: usize = counts.iter().sum();
    let expected = 1 + channels + total;
    if cs.len() != expected {
        let listed: Vec<String> = counts.iter().map(|n| n.to_string()).collect();
        let found = cs.len() - 1 - channels;
        if truncated_tail && cs.len() < expected {
            return Err(RowError::new(
                Reason::RaggedRow,
                line,
                label(cs.len(), &counts),
                format!("truncated last row (no line end): the peak counts call for {total} wavelengths, the row has {found}"),
            ));
        }
        return Err(RowError::new(
            Reason::PeakCountMismatch,
            line,
            format!("2-{} (peak counts)", channels + 1),
            format!("peak counts {} = {total} disagree with the {found} wavelengths on the row", listed.join("+")),
        ));
    }
    if truncated_tail {
        // Complete in cells, but the file ends inside the row: its last number may be cut
        // short (`1555.0440` read as `1555.04`), which no magnitude check would catch.
        return Err(RowError::new(
            Reason::RaggedRow,
            line,
            label(cs.len() - 1, &counts),
            format!("truncated last row (no line end): the file ends inside this row, so its last value `{}` may be cut short", cs[cs.len() - 1]),
        ));
    }
    let mut peaks = Vec::with_capacity(channels);
    let mut idx = 1 + channels;
    for &n in &counts {
        let mut p = Vec::with_capacity(n);
        for _ in 0..n {
            let cell = &cs[idx];
            let v = number_in(cell, culture)
                .and_then(|v| {
                    v.ok_or_else(|| {
                        format!("`{}` where the peak count says a wavelength is", crate::error::quote_cell(cell))
                    })
                })
                .map_err(|m| RowError::new(Reason::NonNumeric, line, label(idx, &counts), m))?;
            if check {
                check_wavelength(unit, v, UnitSource::MapKey("enlight.unit"))
                    .map_err(|m| RowError::new(Reason::UnitMismatch, line, label(idx, &counts), m))?;
            }
            p.push((unit.convert(v), idx));
            idx += 1;
        }
        peaks.push(p);
    }
    Ok(RawRow { t, peaks })
}

/// One peak per window: none is a gap, two are an error.
fn assign(r: &RawRow, windows: &[super::mapping::Window], line: u64) -> Result<Vec<f64>, RowError> {
    let mut out = vec![f64::NAN; windows.len()];
    for (g, w) in windows.iter().enumerate() {
        let inside: Vec<&(f64, usize)> = r.peaks[w.channel].iter().filter(|(v, _)| *v >= w.lo && *v <= w.hi).collect();
        match inside.as_slice() {
            [] => {}
            [(v, _)] => out[g] = *v,
            [(a, _), (b, i), ..] => {
                let counts: Vec<usize> = r.peaks.iter().map(Vec::len).collect();
                return Err(RowError::new(
                    Reason::AmbiguousPeak,
                    line,
                    label(*i, &counts),
                    format!(
                        "{} peaks ({a} and {b} nm) in the window [{}, {}] nm of {} (channel {}); narrow the map key `{}.window_nm`",
                        inside.len(),
                        w.lo,
                        w.hi,
                        w.key,
                        w.channel + 1,
                        w.key
                    ),
                ));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn channel_count_from_a_row() {
        assert_eq!(infer_channels(&s(&["t", "1", "1", "1", "0", "1535.1", "1545.2", "1555.3"])), Some(4));
        assert_eq!(infer_channels(&s(&["t", "2", "1", "1535.1", "1545.2", "1555.3"])), Some(2));
        assert_eq!(infer_channels(&s(&["t", "1535.1"])), None);
        assert_eq!(label(6, &[2, 1, 0, 1]), "7 (ch1 peak 2)");
        assert_eq!(label(7, &[2, 1, 0, 1]), "8 (ch2 peak 1)");
        assert_eq!(mode([1, 1, 0, 1].into_iter()), 1);
    }
}
