//! `--format enlight-responses`: a Micron Optics / Luna ENLIGHT or Hyperion "Responses"
//! (full-spectrum) export.
//!
//! The layout read here (no public specification was found; this is the layout the issue
//! describes, with the details below as assumptions):
//!
//! - line 1 holds the header's line count N, this line included: the header is lines 1–N and
//!   the data start on line N + 1;
//! - header lines are `Key<TAB>value` (or `Key: value`, `Key = value`); the keys read are
//!   `Wavelength Start` \[nm\], `Wavelength Delta` \[nm\] and `Number of Points` (all three
//!   required) and `Culture` (optional: the decimal mark and the date order, as in a peaks
//!   export; the map's `[enlight] culture` for a file without one); other lines are ignored;
//! - then blocks: a timestamp line (one cell: a timestamp, or seconds), followed by one line
//!   per channel (channel 1 first) of `Number of Points` tab-separated levels in dB; a block may
//!   hold fewer channels than the first one (the missing ones are gaps in that frame), not more
//!   (its extra lines are refused: a lost timestamp line would otherwise turn the next frame
//!   into more channels of this one); a first block longer than every later one is refused
//!   for the same reason (its own next timestamp lost), unless the map's `[enlight] channels`
//!   gives the count.
//!
//! Numbers follow the culture (`-42,137` in de-DE). Errors name the line and the column, a
//! level's column by its wavelength.

use std::path::Path;

use fbg_shared::spectrum::{from_db_in_place, Grid, Spectrum};

use super::super::culture::{find_culture, number_in, Culture};
use super::super::dates::DateProbe;
use super::super::mapping::Map;
use super::super::problems::{OnError, Problems, Reason, RowError};
use super::super::scale::Scale;
use super::super::time_axis::{dmy_fields, Dmy, TimeKind, TimeParser, TimeUnit};
use super::super::TextLines;
use super::frames::{FileFacts, SpectrumRow, SpectrumSink, MAX_CHANNELS};
use super::wide_csv::check_scale;
use crate::data::units::NM_RANGE;
use crate::error::{ShortNumber, TrainerError};

/// Smallest wavelength step \[nm\] taken for a real one (a tenth of a pm, finer than any
/// interrogator samples).
const MIN_DELTA_NM: f64 = 1e-4;

/// The header keys read.
const START: &str = "Wavelength Start";
const DELTA: &str = "Wavelength Delta";
const POINTS: &str = "Number of Points";

/// Read the export at `path`, handing each channel's spectrum (linear) to `sink`; also the
/// number of channels seen.
pub(crate) fn read(
    path: &Path,
    m: &Map,
    origin: &str,
    scale: Scale,
    policy: OnError,
    sink: &mut dyn SpectrumSink,
) -> Result<(FileFacts, usize), TrainerError> {
    let name = path.display().to_string();
    // Line by line: memory does not grow with the file's length. The header is kept (its line
    // count is line 1's); a date order to probe takes a first pass over the data.
    let mut lines = TextLines::open(path)?;
    let (head, file_lines) = header_lines(&mut lines)?;
    let head_refs: Vec<&str> = head.iter().map(String::as_str).collect();
    let Header { n_header, culture, points, grid } = header(&head_refs, file_lines, m, origin, &name)?;
    let decimal_comma = culture.as_ref().is_some_and(|c| c.decimal_comma);
    let mut clock = TimeParser::new(TimeUnit::Auto, m.enlight.time_format.clone(), None)
        .with_locale(decimal_comma, if m.enlight.time_format.is_some() { Dmy::Off } else { Dmy::Probe });
    clock.dmy = if clock.dmy == Dmy::Probe { probe_dates(path, n_header, culture.as_ref(), &name)? } else { Dmy::Off };
    let label = |k: usize| format!("{} ({:.3} nm)", k + 1, grid.wavelength(k as f64));
    let spec = Blocks { points, scale, culture: culture.as_ref(), label: &label };
    let mut problems = Problems::new(&name, policy);
    let mut samples = vec![0.0f64; points];
    // The current block: its time and the next channel, or `None` after a bad timestamp.
    let mut block: Option<Option<(f64, usize)>> = None;
    let mut channels = 0usize;
    // The channel count: the map's `[enlight] channels`, else the first block's. A later
    // block with more lines has lost a timestamp.
    let mut first_block: Option<usize> = m.enlight.channels;
    // The first block's channel lines, and the most channel lines of any later block: a first
    // block longer than every later one has taken in the next block (its timestamp lost).
    let mut first_lines: Vec<u64> = Vec::new();
    let mut most_later = 0usize;
    let mut blocks = 0usize;
    while let Some((line, l, ended)) = lines.next_line()? {
        if l.trim().is_empty() {
            continue;
        }
        if is_time_line(l) {
            if blocks >= 2 {
                most_later = most_later.max(block.flatten().map_or(0, |(_, c)| c));
            }
            blocks += 1;
            if blocks == 2 {
                first_block = first_block.or(Some(channels));
            }
            match clock.parse(l.trim()) {
                Ok(t) => block = Some(Some((t, 0))),
                Err(e) => {
                    block = Some(None);
                    problems.rows_read += 1;
                    problems.reject(RowError::new(
                        Reason::NonNumeric,
                        line,
                        "1 (time)",
                        format!("{e} (a line of one cell starts a block: its timestamp)"),
                    ))?;
                }
            }
            continue;
        }
        problems.rows_read += 1;
        let Some(current) = block.as_mut() else {
            return Err(TrainerError::data(
                &name,
                line,
                "1",
                "spectrum values before any timestamp line: a block is a timestamp line, then one line of levels per channel",
            ));
        };
        let Some((t, channel)) = current.as_mut() else { continue };
        let c = *channel;
        *channel += 1;
        if blocks == 1 && first_lines.len() < MAX_CHANNELS {
            first_lines.push(line);
        }
        if let Some(n) = first_block.filter(|&n| c >= n) {
            problems.reject(RowError::new(
                Reason::RaggedRow,
                line,
                "1 (channel line)",
                format!("channel line {} of a block, but the first block has {n} channels: is a timestamp line missing above?", c + 1),
            ))?;
            continue;
        }
        // Only the file's last line can lack its line end.
        let truncated = !ended;
        let row = spec.parse(l, line, c, truncated, &mut samples).and_then(|()| {
            sink.spectrum(SpectrumRow { t: *t, line, channel: c, spectrum: Spectrum::new(&samples, grid) })
        });
        match row {
            Ok(()) => channels = channels.max(c + 1),
            Err(e) => problems.reject(e)?,
        }
    }
    if blocks >= 2 {
        most_later = most_later.max(block.flatten().map_or(0, |(_, c)| c));
    }
    if m.enlight.channels.is_none() && blocks >= 2 {
        refuse_a_long_first_block(&name, &first_lines, most_later)?;
    }
    problems.refuse_wrong_unit_columns()?;
    let facts = FileFacts {
        grid,
        points,
        metadata_lines: n_header,
        time_kind: clock.kind.unwrap_or(TimeKind::Timestamp),
        absolute: clock.absolute(),
        time_column: "1 (time)".into(),
        culture: culture.map(|c| format!("{} ({})", c.name, c.source)),
        problems,
    };
    Ok((facts, channels))
}

/// A first block with more channel lines (`first_lines`) than any later block (`most_later`)
/// has taken in the next block, whose timestamp line was lost: refused at the first line it
/// took.
fn refuse_a_long_first_block(name: &str, first_lines: &[u64], most_later: usize) -> Result<(), TrainerError> {
    let n = most_later.max(1);
    if first_lines.len() <= n {
        return Ok(());
    }
    Err(TrainerError::data(
        name,
        first_lines.get(n).copied().unwrap_or(0),
        "1 (channel line)",
        format!(
            "the first block has {} channel lines but no later block more than {n}: is the timestamp line of the next block missing above this line? (give `[enlight] channels = {}` in the map if the first block really is the only complete one)",
            first_lines.len(),
            first_lines.len()
        ),
    ))
}

/// What the header says: its line count, the culture, the points and their grid.
struct Header {
    n_header: usize,
    culture: Option<Culture>,
    points: usize,
    grid: Grid<f64>,
}

/// The header's lines of the file `lines` reads from its start: as many as its first line's
/// count says (all of them when that is not a count, or more than the file holds), and the
/// file's line count when the whole file was read for them (counted as its text split on
/// `\n`: a file ending with a line end has an empty last line).
fn header_lines(lines: &mut TextLines) -> Result<(Vec<String>, Option<usize>), TrainerError> {
    let mut head: Vec<String> = Vec::new();
    let mut want: Option<usize> = None;
    let mut last_ended = false;
    loop {
        if want.is_some_and(|n| head.len() >= n) {
            return Ok((head, None));
        }
        let Some((_, l, ended)) = lines.next_line()? else { break };
        if head.is_empty() {
            want = l.split('\t').next().unwrap_or_default().trim().parse::<usize>().ok();
            if want.is_none() {
                // Not a count: an error naming the file's line count; the rest is counted, not kept.
                let first = l.to_string();
                let mut n = 1;
                last_ended = ended;
                while let Some((_, _, e)) = lines.next_line()? {
                    n += 1;
                    last_ended = e;
                }
                return Ok((vec![first], Some(n + usize::from(last_ended))));
            }
        }
        head.push(l.to_string());
        last_ended = ended;
    }
    let n = head.len() + usize::from(last_ended || head.is_empty());
    Ok((head, Some(n)))
}

/// The day/month order of the data's dates when the first timestamp after the header's
/// `n_header` lines has numeric day and month fields: every data line's first cell probed, in a
/// pass over the file of its own.
fn probe_dates(path: &Path, n_header: usize, culture: Option<&Culture>, name: &str) -> Result<Dmy, TrainerError> {
    let mut lines = TextLines::open(path)?;
    let mut numeric = false;
    while let Some((line, l, _)) = lines.next_line()? {
        if line as usize > n_header && is_time_line(l) {
            numeric = dmy_fields(l.trim()).is_some();
            break;
        }
    }
    if !numeric {
        return Ok(Dmy::Off);
    }
    let mut lines = TextLines::open(path)?;
    let mut probe = DateProbe::new(n_header, culture, name);
    while let Some((line, l, _)) = lines.next_line()? {
        if line as usize > n_header && probe.see(line, l.split('\t').next().unwrap_or(""))? {
            break;
        }
    }
    Ok(Dmy::Order(probe.finish()?.0))
}

/// Read and check the header `lines` (its first lines, as many as line 1 says when it can;
/// `file_lines` the file's line count when the file ended first) of the file `name`.
fn header(
    lines: &[&str],
    file_lines: Option<usize>,
    m: &Map,
    origin: &str,
    name: &str,
) -> Result<Header, TrainerError> {
    let name = name.to_string();
    let available = file_lines.unwrap_or(usize::MAX);
    let first = lines.first().map(|l| l.split('\t').next().unwrap_or_default().trim()).unwrap_or_default();
    let n_header = first.parse::<usize>().ok().filter(|&n| (1..=available).contains(&n)).ok_or_else(|| {
        TrainerError::data(
            &name,
            1,
            "1 (header line count)",
            format!("`{}` is not the header's line count: a Responses export's first line is the number of header lines (this one included), at most the file's {} lines", crate::error::quote_cell(first), available),
        )
    })?;
    let culture = find_culture(lines, Some(n_header), m.enlight.culture.as_deref(), origin, &name, &|_| '\t')?;
    let header = lines.get(..n_header.min(lines.len())).unwrap_or_default();
    let key_number = |key: &str| -> Result<f64, TrainerError> {
        let Some((i, v)) = header.iter().enumerate().skip(1).find_map(|(i, l)| value_of(l, key).map(|v| (i, v))) else {
            return Err(TrainerError::data(
                &name,
                1,
                key,
                format!("the header (lines 1–{n_header}, as line 1 says) has no `{key}` line; a Responses header gives `{START}`, `{DELTA}` and `{POINTS}`"),
            ));
        };
        number_in(v, culture.as_ref())
            .and_then(|x| x.ok_or_else(|| "empty".to_string()))
            .map_err(|e| TrainerError::data(&name, i as u64 + 1, key, e))
    };
    let start = key_number(START)?;
    let delta = key_number(DELTA)?;
    let points = key_number(POINTS)?;
    let bad_key = |key: &str, msg: String| {
        let line = header.iter().position(|l| value_of(l, key).is_some()).map_or(1, |i| i as u64 + 1);
        TrainerError::data(&name, line, key, msg)
    };
    if !(NM_RANGE.0..=NM_RANGE.1).contains(&start) {
        return Err(bad_key(START, format!("{start} is not a wavelength in nm ({}–{} nm)", NM_RANGE.0, NM_RANGE.1)));
    }
    if !(MIN_DELTA_NM..1.0).contains(&delta) {
        return Err(bad_key(
            DELTA,
            format!("{} is not a wavelength step in nm ({MIN_DELTA_NM} ≤ step < 1 nm)", ShortNumber(delta)),
        ));
    }
    if !(points >= 3.0 && points.fract() == 0.0 && points <= 1e7) {
        return Err(bad_key(POINTS, format!("{} is not a number of points (3 or more, whole)", ShortNumber(points))));
    }
    let end = start + delta * (points - 1.0);
    if end > NM_RANGE.1 {
        return Err(bad_key(
            POINTS,
            format!(
                "{} points of {} nm from {start} nm end at {} nm, beyond {} nm: check `{DELTA}` and `{POINTS}`",
                ShortNumber(points),
                ShortNumber(delta),
                ShortNumber(end),
                NM_RANGE.1
            ),
        ));
    }
    let points = points as usize;
    let grid = Grid::uniform(start, delta);
    Ok(Header { n_header, culture, points, grid })
}

/// A line of one cell: a block's timestamp.
fn is_time_line(l: &str) -> bool {
    let cells = l.split('\t').filter(|c| !c.trim().is_empty()).count();
    cells == 1
}

/// `Key<TAB>value`, `Key: value`, `Key = value` (key in any case): the value.
fn value_of<'a>(l: &'a str, key: &str) -> Option<&'a str> {
    let t = l.trim();
    let head = t.get(..key.len())?;
    if !head.eq_ignore_ascii_case(key) {
        return None;
    }
    let rest = t.get(key.len()..)?;
    let trimmed = rest.trim_start_matches([' ']);
    let v = trimmed.strip_prefix([':', '=', '\t', ';']).or_else(|| (trimmed.len() < rest.len()).then_some(trimmed))?;
    Some(v.trim())
}

/// How the levels lines are read.
struct Blocks<'a> {
    points: usize,
    scale: Scale,
    culture: Option<&'a Culture>,
    label: &'a dyn Fn(usize) -> String,
}

impl Blocks<'_> {
    /// One channel's levels into `samples` (linear).
    fn parse(&self, l: &str, line: u64, channel: usize, truncated: bool, samples: &mut [f64]) -> Result<(), RowError> {
        if channel >= MAX_CHANNELS {
            return Err(RowError::new(
                Reason::RaggedRow,
                line,
                "1",
                format!("more than {MAX_CHANNELS} channel lines in one block: is a timestamp line missing?"),
            ));
        }
        // Parsed as split, with no per-row allocation; a trailing tab is not a cell.
        let l = l.trim_end_matches(|c: char| c == '\t' || c.is_whitespace());
        let mut n = 0usize;
        let mut bad: Option<RowError> = None;
        for cell in l.split('\t').map(str::trim) {
            match samples.get_mut(n) {
                Some(s) if bad.is_none() => match number_in(cell, self.culture) {
                    Ok(v) => *s = v.unwrap_or(f64::NAN),
                    Err(m) => bad = Some(RowError::new(Reason::NonNumeric, line, (self.label)(n), m)),
                },
                _ => {}
            }
            n += 1;
        }
        if n != self.points {
            let column = if n < self.points { (self.label)(n) } else { format!("{}", self.points + 1) };
            let why = if truncated && n < self.points { "truncated last line (no line end): " } else { "" };
            return Err(RowError::new(
                Reason::RaggedRow,
                line,
                column,
                format!("{why}{n} levels where the header's {POINTS} is {} (channel {})", self.points, channel + 1),
            ));
        }
        if truncated {
            return Err(RowError::new(
                Reason::RaggedRow,
                line,
                (self.label)(self.points - 1),
                "truncated last line (no line end): the file ends inside this line, so its last value may be cut short",
            ));
        }
        if let Some(e) = bad {
            return Err(e);
        }
        check_scale(samples, self.scale, line, &(self.label)(0))?;
        if self.scale == Scale::Db {
            from_db_in_place(samples);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_values_after_a_tab_colon_or_equals() {
        assert_eq!(value_of("Wavelength Start\t1530,000", START), Some("1530,000"));
        assert_eq!(value_of("wavelength start: 1530.0", START), Some("1530.0"));
        assert_eq!(value_of("Wavelength Start = 1530", START), Some("1530"));
        assert_eq!(value_of("Wavelength Starts\t1530", START), None);
        assert_eq!(value_of("Number of Points\t20001", POINTS), Some("20001"));
        assert!(is_time_line("03.01.2024 10:00:00") && !is_time_line("-40,1\t-40,2"));
    }
}
