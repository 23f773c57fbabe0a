//! Micron Optics ENLIGHT / Hyperion "peaks" exports.
//!
//! Metadata lines may precede the table. Each data row is a timestamp, one peak count per
//! channel, then that many wavelengths [nm] flattened channel by channel, so rows differ in
//! length; cells are tab- or comma-separated. Peaks are assigned to the gratings (1 to 8) by
//! the map's channel and wavelength window (a missing peak is a gap, never a shifted column),
//! or without a map, each channel's peaks become gratings in order.

use std::path::Path;

use super::mapping::Map;
use super::problems::{OnError, Problems, Reason, RowError};
use super::read_text;
use super::time_axis::{TimeKind, TimeParser, TimeUnit};
use crate::data::measurand::MAX_GRATINGS;
use crate::data::units::{check_wavelength, WlUnit};
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
    let text = read_text(path)?;
    let ends_with_newline = text.ends_with('\n');
    let lines: Vec<&str> = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l)).collect();
    let default_map = Map::default();
    let m = map.unwrap_or(&default_map);
    let unit = m.enlight.unit.unwrap_or(WlUnit::Nm);
    let check = m.check_units();
    let map_delim = m
        .enlight
        .delimiter
        .as_deref()
        .map(super::mapping::delimiter)
        .transpose()
        .map_err(|e| TrainerError::data(&name, 1, "-", e))?
        .map(char::from);
    let mut clock = TimeParser::new(TimeUnit::Auto, m.enlight.time_format.clone(), None);
    let split_with = |l: &str, d: char| -> Vec<String> {
        let mut cs: Vec<String> = l.split(d).map(|c| c.trim().to_string()).collect();
        while cs.last().is_some_and(|c| c.is_empty()) {
            cs.pop();
        }
        cs
    };
    let guess_delim = |l: &str| map_delim.unwrap_or(if l.contains('\t') { '\t' } else { ',' });

    // The first data row: a time, then a peak count.
    let first = match m.enlight.header_lines {
        Some(n) => n,
        None => lines
            .iter()
            .position(|l| {
                let cs = split_with(l, guess_delim(l));
                cs.len() >= 2 && clock.probe(&cs[0]) && cs[1].parse::<usize>().is_ok()
            })
            .ok_or_else(|| {
                TrainerError::data(
                    &name,
                    1,
                    "1 (time)",
                    "no data row found: a peaks row starts with a time and the peak count of the first channel",
                )
            })?,
    };
    let Some(first_line) = lines.get(first) else {
        return Err(TrainerError::data(&name, first as u64 + 1, "-", "no data rows after the metadata header"));
    };
    let delim = guess_delim(first_line);
    let channels = match m.enlight.channels {
        Some(n) => n,
        None => infer_channels(&split_with(first_line, delim)).ok_or_else(|| {
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

    let mut problems = Problems::new(&name, policy);
    let mut out_lines: Vec<u64> = Vec::new();
    let mut out_t: Vec<f64> = Vec::new();
    let mut raw: Vec<Vec<Vec<f64>>> = Vec::new();
    let mut nm: Vec<Vec<f64>> = vec![Vec::new(); windows.len()];
    let last_nonblank = lines.iter().rposition(|l| !l.trim().is_empty()).unwrap_or(0);
    for (i, l) in lines.iter().enumerate().skip(first) {
        if l.trim().is_empty() {
            continue;
        }
        let line = i as u64 + 1;
        problems.rows_read += 1;
        let cs = split_with(l, delim);
        let truncated_tail = i == last_nonblank && !ends_with_newline;
        let row = parse_row(&cs, line, channels, &mut clock, unit, check, truncated_tail).and_then(|r| {
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
            let assigned = if windows.is_empty() { Vec::new() } else { assign(&r, &windows, line)? };
            Ok((r, assigned))
        });
        match row {
            Ok((r, assigned)) => {
                out_lines.push(line);
                out_t.push(r.t);
                if windows.is_empty() {
                    raw.push(r.peaks.into_iter().map(|p| p.into_iter().map(|(v, _)| v).collect()).collect());
                } else {
                    for (g, v) in assigned.into_iter().enumerate() {
                        nm[g].push(v);
                    }
                }
            }
            Err(e) => problems.reject(e)?,
        }
    }
    problems.refuse_wrong_unit_columns()?;
    if out_t.is_empty() {
        let why = if problems.rows_read == 0 { "no data rows" } else { "every data row was skipped" };
        return Err(TrainerError::data(&name, first as u64 + 1, "-", why));
    }

    let mut unassigned_rows = 0;
    let layout: Vec<String> = if windows.is_empty() {
        // Each channel's usual peak count decides its gratings, in order.
        let usual: Vec<usize> = (0..channels).map(|c| mode(raw.iter().map(|r| r[c].len()))).collect();
        let gratings: Vec<(usize, usize)> = (0..channels).flat_map(|c| (0..usual[c]).map(move |k| (c, k))).collect();
        if gratings.is_empty() || gratings.len() > MAX_GRATINGS {
            let counts: Vec<String> = usual.iter().map(|n| n.to_string()).collect();
            return Err(TrainerError::data(
                &name,
                out_lines[0],
                &format!("2-{} (peak counts)", channels + 1),
                format!(
                    "without --map each channel's peaks become gratings in order, and 1 to {MAX_GRATINGS} are supported; the rows usually hold {} = {} peaks: give a map with one [[grating]] entry (channel, window_nm) per grating",
                    counts.join("+"),
                    gratings.len()
                ),
            ));
        }
        nm = vec![Vec::with_capacity(raw.len()); gratings.len()];
        for r in &raw {
            let mut odd = false;
            for (g, &(c, k)) in gratings.iter().enumerate() {
                let v = if r[c].len() == usual[c] { r[c][k] } else { f64::NAN };
                odd |= r[c].len() != usual[c];
                nm[g].push(v);
            }
            unassigned_rows += usize::from(odd);
        }
        gratings
            .iter()
            .map(|&(c, k)| format!("channel {}, peak {} of {} (in order, no map)", c + 1, k + 1, usual[c]))
            .collect()
    } else {
        windows.iter().map(|w| format!("channel {}, window {}–{} nm", w.channel + 1, w.lo, w.hi)).collect()
    };

    Ok(PeaksFile {
        lines: out_lines,
        t: out_t,
        nm,
        channels,
        delimiter: delim,
        metadata_lines: first,
        time_kind: clock.kind.unwrap_or(TimeKind::Timestamp),
        absolute: clock.absolute(),
        layout,
        unassigned_rows,
        problems,
    })
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
    channels: usize,
    clock: &mut TimeParser,
    unit: WlUnit,
    check: bool,
    truncated_tail: bool,
) -> Result<RawRow, RowError> {
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
                format!("`{}` is not a peak count", cs[1 + c]),
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
            let v = super::number(cell)
                .and_then(|v| v.ok_or_else(|| format!("`{cell}` where the peak count says a wavelength is")))
                .map_err(|m| RowError::new(Reason::NonNumeric, line, label(idx, &counts), m))?;
            if check {
                check_wavelength(unit, v, "enlight.unit")
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
