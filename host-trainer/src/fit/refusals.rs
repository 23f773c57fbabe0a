//! What refuses a calibration batch before any fitting: columns that carry nothing to fit, and
//! outlying reference cells.

use crate::data::outliers::{self, Outlier};
use crate::data::Dataset;
use crate::error::TrainerError;

/// Largest span of a column over the calibration batch still taken as constant: the dataset
/// CSV's resolution (6 decimals).
pub(crate) const CONSTANT_SPAN: f64 = 1e-6;

/// A reference that never changes, or a grating that never moves, over the calibration batch
/// leaves the fit without the information it needs (a rank-deficient design whose failure would
/// only name a condition number): refuse it by column name, before any work.
pub(crate) fn refuse_constant_columns(d: &Dataset, cal: &[usize]) -> Result<(), TrainerError> {
    let span = |v: &[f64]| {
        let (lo, hi) =
            cal.iter().map(|&i| v[i]).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        (hi - lo, lo)
    };
    for r in &d.refs {
        let (name, unit) = (r.measurand.column(), r.measurand.unit());
        let (s, v) = span(&r.values);
        if s <= CONSTANT_SPAN {
            return Err(TrainerError::Dataset {
                message: format!(
                    "column `{name}` is constant ({v} {unit}) over the {} calibration rows: nothing to calibrate that measurand against; \
                     leave the column out (references are optional) or calibrate on a batch where it varies",
                    cal.len()
                ),
            });
        }
    }
    for (g, v) in d.dl_pm.iter().enumerate() {
        let (s, x) = span(v);
        if s <= CONSTANT_SPAN {
            return Err(TrainerError::Dataset {
                message: format!(
                    "column `dl{}_pm` never moves ({x} pm on all {} calibration rows): the grating is dead, unplugged or not in the \
                     map; fix the export or the map",
                    g + 1,
                    cal.len()
                ),
            });
        }
    }
    Ok(())
}

/// The refusal of a calibration batch with outlying reference cells (`found`, by row) from
/// `source`: its first cell's line and column, value and running median, and how many more;
/// `skip` names the option that leaves those rows out.
pub(crate) fn refuse_outliers(source: &str, found: &[Outlier], skip: &str) -> TrainerError {
    let Some(first) = found.first() else {
        return TrainerError::Dataset { message: "no reference outliers".into() };
    };
    let rows = outliers::rows_of(found).len();
    TrainerError::data(
        source,
        first.line,
        &first.column,
        format!(
            "reference outlier: {}; {} calibration row{} with outlying reference cells (line{} {}): correct them or empty the cells (an empty reference cell is a missing reference), or {skip} to leave those rows out",
            first.describe(),
            rows,
            if rows == 1 { "" } else { "s" },
            if rows == 1 { "" } else { "s" },
            outliers::first_lines(found)
        ),
    )
}
