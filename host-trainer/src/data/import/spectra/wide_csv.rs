//! The table both CSV spectrum formats share: a header `t_s,channel,` and one column per
//! sample of the spectrum, then one row per frame and channel. What the sample columns are
//! (wavelengths, pixels) and so the grid is the caller's: [`super::spectra_csv`],
//! [`super::pixels`].
//!
//! Cells are comma-, tab- or `;`-separated (whichever the header holds first: tab, `;`, `,`),
//! numbers with a decimal point; an empty or `NaN` sample is missing (a window holding one has
//! no peak in that frame). The time column is seconds or timestamps, as in a logger CSV;
//! channels are numbered from 1. Errors name the line and the column by its header cell (the
//! wavelength or the pixel).

use std::path::Path;

use fbg_shared::spectrum::{from_db_in_place, Grid, Spectrum};

use super::super::problems::{OnError, Problems, Reason, RowError};
use super::super::scale::Scale;
use super::super::time_axis::{TimeKind, TimeParser, TimeUnit};
use super::super::{number, TextLines};
use super::frames::{FileFacts, SpectrumRow, SpectrumSink, MAX_CHANNELS};
use crate::error::TrainerError;

/// Header names accepted for the time column (any case).
const TIME_NAMES: [&str; 4] = ["t_s", "time", "timestamp", "datetime"];

/// The grid of the sample columns' header cells, or (index among the sample columns, message).
pub(crate) type GridOf<'a> = dyn Fn(&[&str]) -> Result<Grid<f64>, (usize, String)> + 'a;

/// Read the table at `path`, handing each row's spectrum (linear) to `sink`.
pub(crate) fn read(
    path: &Path,
    scale: Scale,
    policy: OnError,
    grid_of: &GridOf<'_>,
    sink: &mut dyn SpectrumSink,
) -> Result<(FileFacts, usize), TrainerError> {
    let name = path.display().to_string();
    // Line by line: memory does not grow with the file's length.
    let mut lines = TextLines::open(path)?;
    let (header_line, header) = loop {
        match lines.next_line()? {
            Some((n, l, _)) if !l.trim().is_empty() => break (n, l.to_string()),
            Some(_) => continue,
            None => {
                return Err(TrainerError::data(
                    &name,
                    1,
                    "1",
                    "empty file: no header `t_s,channel,<wavelengths or pixels>`",
                ))
            }
        }
    };
    let header = header.as_str();
    let delim = if header.contains('\t') {
        '\t'
    } else if header.contains(';') {
        ';'
    } else {
        ','
    };
    let head: Vec<&str> = header.split(delim).map(str::trim).collect();
    let head: Vec<&str> = match head.iter().rposition(|c| !c.is_empty()) {
        Some(k) => head.get(..=k).unwrap_or_default().to_vec(),
        None => Vec::new(),
    };
    let time_name = head.first().copied().unwrap_or_default();
    if !TIME_NAMES.iter().any(|n| n.eq_ignore_ascii_case(time_name)) {
        return Err(TrainerError::data(
            &name,
            header_line,
            &format!("1 ({})", crate::error::quote_cell(time_name)),
            format!("the header starts `{}`, not the time column (`t_s`): a spectrum table's header is `t_s,channel,` and then one column per wavelength or pixel", crate::error::quote_cell(time_name)),
        ));
    }
    let channel_name = head.get(1).copied().unwrap_or_default();
    if !channel_name.eq_ignore_ascii_case("channel") {
        return Err(TrainerError::data(
            &name,
            header_line,
            &format!("2 ({})", crate::error::quote_cell(channel_name)),
            format!("the second header cell is `{}`, not `channel`: a spectrum table's header is `t_s,channel,` and then one column per wavelength or pixel", crate::error::quote_cell(channel_name)),
        ));
    }
    let columns = head.get(2..).unwrap_or_default();
    if columns.len() < 3 {
        return Err(TrainerError::data(
            &name,
            header_line,
            &format!("{}", head.len() + 1),
            format!("{} sample columns after `t_s,channel`; a spectrum needs at least 3", columns.len()),
        ));
    }
    let label = |k: usize| match columns.get(k) {
        Some(c) => format!("{} ({c})", k + 3),
        None => format!("{}", k + 3),
    };
    let grid = grid_of(columns).map_err(|(k, m)| TrainerError::data(&name, header_line, &label(k), m))?;
    let points = columns.len();
    let mut clock = TimeParser::new(TimeUnit::Auto, None, None);
    let mut problems = Problems::new(&name, policy);
    let mut samples = vec![0.0f64; points];
    let mut channels = 0usize;
    while let Some((line, l, ended)) = lines.next_line()? {
        if l.trim().is_empty() {
            continue;
        }
        problems.rows_read += 1;
        // Only the file's last line can lack its line end.
        let truncated = !ended;
        let row = parse_row(l, delim, line, points, scale, truncated, &mut clock, &mut samples, &label).and_then(
            |(t, channel)| {
                sink.spectrum(SpectrumRow { t, line, channel, spectrum: Spectrum::new(&samples, grid) })?;
                Ok(channel)
            },
        );
        match row {
            Ok(c) => channels = channels.max(c + 1),
            Err(e) => problems.reject(e)?,
        }
    }
    problems.refuse_wrong_unit_columns()?;
    let facts = FileFacts {
        grid,
        points,
        metadata_lines: header_line as usize,
        time_kind: clock.kind.unwrap_or(TimeKind::Seconds),
        absolute: clock.absolute(),
        time_column: format!("1 ({time_name})"),
        culture: None,
        problems,
    };
    Ok((facts, channels))
}

/// One row into `samples` (linear): its time and channel (0-based). The cells are parsed as
/// they are split, with no per-row allocation.
#[allow(clippy::too_many_arguments)]
fn parse_row(
    l: &str,
    delim: char,
    line: u64,
    points: usize,
    scale: Scale,
    truncated: bool,
    clock: &mut TimeParser,
    samples: &mut [f64],
    label: &dyn Fn(usize) -> String,
) -> Result<(f64, usize), RowError> {
    // Trailing empty cells (a trailing delimiter) are not cells.
    let l = l.trim_end_matches(|c: char| c == delim || c.is_whitespace());
    let mut cells = l.split(delim).map(str::trim);
    let time_cell = cells.next().unwrap_or_default();
    let channel_cell = cells.next();
    let mut n = 0usize;
    let mut bad: Option<RowError> = None;
    for cell in cells.by_ref() {
        if let Some(s) = samples.get_mut(n) {
            if bad.is_none() {
                match number(cell) {
                    Ok(v) => *s = v.unwrap_or(f64::NAN),
                    Err(m) => bad = Some(RowError::new(Reason::NonNumeric, line, label(n), m)),
                }
            }
        }
        n += 1;
    }
    let found = n + 1 + usize::from(channel_cell.is_some());
    if n != points {
        let (column, what) = if n < points {
            (label(n), "missing from here on")
        } else {
            (format!("{}", 2 + points + 1), "beyond the header's last column")
        };
        let why = if truncated && n < points { "truncated last row (no line end): " } else { "" };
        return Err(RowError::new(
            Reason::RaggedRow,
            line,
            column,
            format!("{why}{found} cells where the header has {} ({what})", 2 + points),
        ));
    }
    if truncated {
        return Err(RowError::new(
            Reason::RaggedRow,
            line,
            label(points - 1),
            "truncated last row (no line end): the file ends inside this row, so its last value may be cut short",
        ));
    }
    let t = clock.parse(time_cell).map_err(|m| RowError::new(Reason::NonNumeric, line, "1 (t_s)", m))?;
    let channel_cell = channel_cell.unwrap_or_default();
    let channel = channel_cell.parse::<usize>().ok().filter(|c| (1..=MAX_CHANNELS).contains(c)).ok_or_else(|| {
        RowError::new(
            Reason::NonNumeric,
            line,
            "2 (channel)",
            format!("`{}` is not a channel number (1 to {MAX_CHANNELS})", crate::error::quote_cell(channel_cell)),
        )
    })?;
    if let Some(e) = bad {
        return Err(e);
    }
    check_scale(samples, scale, line, &label(0))?;
    if scale == Scale::Db {
        from_db_in_place(samples);
    }
    Ok((t, channel - 1))
}

/// A linear spectrum whose every value is negative is a dB trace read as linear.
pub(crate) fn check_scale(samples: &[f64], scale: Scale, line: u64, column: &str) -> Result<(), RowError> {
    let mut finite = samples.iter().filter(|v| v.is_finite()).peekable();
    if scale == Scale::Linear && finite.peek().is_some() && finite.all(|&v| v < 0.0) {
        return Err(RowError::new(
            Reason::UnitMismatch,
            line,
            column,
            "every intensity of this spectrum is negative, which linear intensities are not: a dB trace? pass --scale db (or set [spectra] scale = \"db\" in the map)",
        ));
    }
    Ok(())
}
