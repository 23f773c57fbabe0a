//! A record as columns: the dataset's CSV columns (`t_s` \[s\], the references `T_C`,
//! `strain_ue`, `p_kPa`, …, `T_amb_C` \[°C\], `dl1_pm..dlN_pm` \[pm\]) as NumPy arrays, to and from
//! the library's [`Dataset`].

use fbg_trainer::data::{Dataset, Measurand, RecordMeta, Reference, Split, MAX_GRATINGS};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::msg;

/// The ambient thermometer's column \[°C\].
const T_AMB: &str = "T_amb_C";

/// The column of grating `g` (1-based): its shift \[pm\].
pub fn grating_column(g: usize) -> String {
    format!("dl{g}_pm")
}

/// The dataset of `columns` (name -> 1-D float64 array, one value per row), the rows with
/// `cal` true calibrating (all of them when `None`), `t0_unix_s` the absolute time of
/// `t_s = 0`. `origin` names the frame in errors. Columns that are neither time, reference,
/// thermometer nor grating are ignored, as the CSV reader does.
pub fn dataset(
    columns: &Bound<'_, PyDict>,
    cal: Option<Vec<bool>>,
    t0_unix_s: Option<f64>,
    origin: &str,
) -> PyResult<Dataset> {
    let mut n: Option<usize> = None;
    let mut take = |name: &str, v: &Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
        let v: PyReadonlyArray1<'_, f64> =
            v.extract().map_err(|_| msg(format!("{origin}: column {name}: not a 1-D float64 array")))?;
        let v = v.as_array().to_vec();
        match n {
            Some(k) if k != v.len() => {
                Err(msg(format!("{origin}: column {name}: {} values where the other columns have {k}", v.len())))
            }
            _ => {
                n = Some(v.len());
                Ok(v)
            }
        }
    };
    let mut d = Dataset { meta: RecordMeta { t0_unix_s, ..RecordMeta::default() }, ..Dataset::default() };
    let mut t_s = None;
    let mut dl: Vec<Option<Vec<f64>>> = vec![None; MAX_GRATINGS];
    for (key, value) in columns.iter() {
        let name: String = key.extract()?;
        if name == "t_s" {
            t_s = Some(take(&name, &value)?);
        } else if name == T_AMB {
            d.t_amb_c = Some(take(&name, &value)?);
        } else if let Some(g) = (1..=MAX_GRATINGS).find(|&g| grating_column(g) == name) {
            if let Some(slot) = dl.get_mut(g - 1) {
                *slot = Some(take(&name, &value)?);
            }
        } else {
            match Measurand::parse(&name) {
                Ok(Some(m)) => d.refs.push(Reference { measurand: m, values: take(&name, &value)? }),
                Ok(None) => {}
                Err(e) => return Err(msg(format!("{origin}: column {name}: {e}"))),
            }
        }
    }
    d.refs.sort_by_key(|r| r.measurand);
    let gratings = dl.iter().take_while(|c| c.is_some()).count();
    if let Some(g) = dl.iter().skip(gratings).position(Option::is_some) {
        return Err(msg(format!(
            "{origin}: column {}: the gratings are numbered from dl1_pm without holes, and {} is missing",
            grating_column(gratings + g + 1),
            grating_column(gratings + 1)
        )));
    }
    if gratings == 0 {
        return Err(msg(format!("{origin}: no grating column (dl1_pm, dl2_pm, …)")));
    }
    d.dl_pm = dl.into_iter().flatten().collect();
    let rows = n.unwrap_or(0);
    d.t_s = t_s.ok_or_else(|| msg(format!("{origin}: no column t_s (time since the start, s)")))?;
    // The rule the CSV reader applies to a record's time (finite, increasing): a frame is a
    // record too, and a model fitted on shuffled rows would disagree with its own stream.
    d.check_times().map_err(|(row, m)| msg(format!("{origin}: t (t_s) at row {row}: {m}")))?;
    // And to its inputs' magnitudes: an implausible cell would be answered wrongly, and its
    // square overflows the fit.
    d.check_inputs().map_err(|(row, column, m)| msg(format!("{origin}: row {row}, column {column}: {m}")))?;
    d.split = match cal {
        None => vec![Split::Cal; rows],
        Some(c) if c.len() == rows => c.into_iter().map(|b| if b { Split::Cal } else { Split::Holdout }).collect(),
        Some(c) => return Err(msg(format!("{origin}: split: {} values for {rows} rows", c.len()))),
    };
    Ok(d)
}

/// A record's zero as Python sees it: per grating, λ_ref \[nm\] (None when unknown) and its
/// source (`map`, `first reading`, `model`, `simulated`, `unknown`); empty when it states none.
pub type Zero = Vec<(Option<f64>, String)>;

/// The zero of `meta` as [`Zero`].
pub fn zero_of(meta: &RecordMeta) -> Zero {
    meta.zero.iter().map(|z| (z.known(), z.source.name().to_string())).collect()
}

/// The columns of `d` as a dict (name -> float64 array) in the CSV's canonical order, with
/// `split` (`cal`/`holdout` strings), the record's `t0_unix_s` (None when unknown) and its
/// zero ([`Zero`]).
#[allow(clippy::type_complexity)]
pub fn to_dict<'py>(
    py: Python<'py>,
    d: Dataset,
) -> PyResult<(Bound<'py, PyDict>, Vec<&'static str>, Option<f64>, Zero)> {
    let zero = zero_of(&d.meta);
    let out = PyDict::new(py);
    out.set_item("t_s", d.t_s.into_pyarray(py))?;
    for r in d.refs {
        out.set_item(r.measurand.column(), r.values.into_pyarray(py))?;
    }
    if let Some(a) = d.t_amb_c {
        out.set_item(T_AMB, a.into_pyarray(py))?;
    }
    for (g, c) in d.dl_pm.into_iter().enumerate() {
        out.set_item(grating_column(g + 1), c.into_pyarray(py))?;
    }
    let split = d.split.iter().map(|s| s.as_str()).collect();
    Ok((out, split, d.meta.t0_unix_s, zero))
}
