//! The common steps after either importer ([`finish`]): drop rows without an ambient reading
//! (from a record with references), times from the first kept row, wavelengths to shifts on
//! each grating's zero, the dataset, its split and the summary.

use fbg_shared::ZeroSource;

use super::merge::Merged;
use super::problems;
use super::summary::{
    Dropped, GratingSummary, ImportSummary, Purpose, RefSummary, References, SplitSummary, TimeSummary,
};
use super::{join, ImportOptions, SplitChoice};
use crate::data::measurand::{grating_column, Measurand};
use crate::data::timestamp::{format_timestamp, parse_timestamp};
use crate::data::{Dataset, GratingZero, RecordMeta, Reference, Split};
use crate::error::TrainerError;

/// Drop rows without ambient temperature (from a record with references), take shifts, build
/// the dataset and its split.
pub(super) fn finish(
    m: Merged,
    opts: &ImportOptions,
    map_origin: Option<String>,
) -> Result<(Dataset, ImportSummary), TrainerError> {
    let (purpose, keep, dropped) = kept_rows(&m);
    if keep.is_empty() {
        return Err(TrainerError::Dataset { message: m.empty_hint });
    }
    let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let (t0, t_s) = relative_times(&m, &keep)?;
    let shifts = Shifts::of(&m, opts, &keep)?;
    let n = keep.len();
    let mut d = Dataset {
        t_s,
        refs: m.refs.iter().map(|(measurand, _, v)| Reference { measurand: *measurand, values: pick(v) }).collect(),
        t_amb_c: m.ambient.as_ref().map(|(_, a)| pick(a)),
        dl_pm: shifts.dl,
        split: vec![Split::Cal; n],
        meta: RecordMeta { zero: shifts.zero, ..RecordMeta::default() },
    };
    d.sort_refs();
    d.meta.t0_unix_s = start_unix_s(&m, opts, t0)?;
    let (rule, cal_until_s) = split_rule(&opts.split, &d, m.absolute, t0)?;
    d.split_at_time(cal_until_s);
    let cal_rows = d.split.iter().filter(|&&s| s == Split::Cal).count();
    let time = TimeSummary {
        kind: m.kind,
        start: m.absolute.then(|| format_timestamp(t0)),
        end: m.absolute.then(|| format_timestamp(t0 + d.t_s[n - 1])),
        span_s: d.t_s[n - 1],
        median_dt_s: join::median_spacing(&d.t_s),
    };
    let references = references_found(&m, &d);
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
        gaps: shifts.gratings.iter().map(|g| g.gaps).collect(),
        gratings: shifts.gratings,
        references,
        time,
        split: SplitSummary { rule, cal_until_s, cal_rows, holdout_rows: n - cal_rows },
        enlight: m.enlight,
        join: m.join,
        spectra: m.spectra,
    };
    Ok((d, summary))
}

/// What the record is for, the rows kept and those dropped for want of an ambient reading.
fn kept_rows(m: &Merged) -> (Purpose, Vec<usize>, Dropped) {
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
    (purpose, keep, dropped)
}

/// The first kept row's time and the kept rows' times from it \[s\], refused where two rows
/// are less than the dataset's resolution apart.
fn relative_times(m: &Merged, keep: &[usize]) -> Result<(f64, Vec<f64>), TrainerError> {
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
    Ok((t0, t_s))
}

/// The gratings' shifts \[pm\] on their zeros, with what the summary and the record's
/// metadata say of each.
struct Shifts {
    dl: Vec<Vec<f64>>,
    gratings: Vec<GratingSummary>,
    zero: Vec<GratingZero>,
}

impl Shifts {
    fn of(m: &Merged, opts: &ImportOptions, keep: &[usize]) -> Result<Shifts, TrainerError> {
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
        let mut s =
            Shifts { dl: Vec::with_capacity(n_g), gratings: Vec::with_capacity(n_g), zero: Vec::with_capacity(n_g) };
        for g in 0..n_g {
            let v: Vec<f64> = keep.iter().map(|&i| m.wl[g][i]).collect();
            let (ref_nm, ref_source, source) = zero_of(m, opts, keep, g, &v)?;
            s.zero.push(match ref_nm {
                Some(nm) => GratingZero { nm, source },
                None => GratingZero::UNKNOWN,
            });
            let shifts: Vec<f64> = match ref_nm {
                Some(r) => v.iter().map(|&x| (x - r) * 1e3).collect(),
                None => v,
            };
            let finite = shifts.iter().copied().filter(|x| x.is_finite());
            let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
            s.gratings.push(GratingSummary {
                output: grating_column(g + 1),
                source: m.sources[g].clone(),
                ref_nm,
                ref_source,
                gaps: shifts.iter().filter(|x| !x.is_finite()).count(),
                min_pm: lo.is_finite().then_some(lo),
                max_pm: hi.is_finite().then_some(hi),
            });
            s.dl.push(shifts);
        }
        Ok(s)
    }
}

/// Grating `g`'s zero \[nm\] (none for shifts in the file), in words and as a source: the
/// model's (`--model`), the map's, else the first reading among the kept rows `v`.
fn zero_of(
    m: &Merged,
    opts: &ImportOptions,
    keep: &[usize],
    g: usize,
    v: &[f64],
) -> Result<(Option<f64>, String, ZeroSource), TrainerError> {
    let model_ref = opts.zero_from.as_ref().map(|z| (z.model.as_str(), z.lambda_ref_nm[g]));
    Ok(if m.is_shift[g] {
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
    })
}

/// The absolute time of `t_s = 0` (Unix s): the first kept row's timestamp, or `--start` for
/// plain seconds.
fn start_unix_s(m: &Merged, opts: &ImportOptions, t0: f64) -> Result<Option<f64>, TrainerError> {
    match (m.absolute, opts.start_unix_s) {
        (true, None) => Ok(Some(t0)),
        (false, start) => Ok(start),
        (true, Some(_)) => Err(TrainerError::Config {
            origin: "--start".into(),
            key: String::new(),
            message: format!("{} has calendar timestamps: its start is known, drop --start", m.input),
        }),
    }
}

/// The split's rule in words and the last calibration time (`t_s` \[s\]).
fn split_rule(split: &SplitChoice, d: &Dataset, absolute: bool, t0: f64) -> Result<(String, f64), TrainerError> {
    let n = d.len();
    match split {
        SplitChoice::Fraction(f) => {
            split.check()?;
            Ok((format!("fraction {f}"), f * d.t_s[n - 1]))
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
                if !absolute {
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
            Ok((format!("until {s}"), until))
        }
    }
}

/// The ambient thermometer and the references written, with their source columns and counts.
fn references_found(m: &Merged, d: &Dataset) -> References {
    let count = |v: &[f64]| v.iter().filter(|x| x.is_finite()).count();
    let mut found: Vec<(Measurand, RefSummary)> = m
        .refs
        .iter()
        .map(|(mm, name, _)| (*mm, RefSummary { column: name.clone(), values: d.reference(*mm).map_or(0, count) }))
        .collect();
    found.sort_by_key(|(mm, _)| *mm);
    References {
        ambient: m.ambient.as_ref().map(|(name, _)| RefSummary { column: name.clone(), values: count(d.ambient()) }),
        measurands: found,
    }
}
