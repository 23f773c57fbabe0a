//! The dataset: column-oriented samples of a record (time, references, ambient reading,
//! wavelength shifts, split) and what the fit and the evaluation ask of it.

use fbg_shared::layout::Dims;
use fbg_shared::Sample;

use crate::data::measurand::grating_column;
use crate::data::units::{check_ambient, check_wavelength, AbsNmCheck, UnitSource, WlUnit};
use crate::data::{Measurand, RecordMeta, MAX_GRATINGS, T_AMB_COLUMN};
use crate::error::TrainerError;

/// The rule of a record's time axis, for every front end (the CSV reader, Python's frames):
/// each `t_s` finite and later than the one before (`prev`). The message says what breaks it.
pub fn check_next_time(prev: Option<f64>, t: f64) -> Result<(), String> {
    use crate::error::ShortNumber;
    if !t.is_finite() {
        return Err(format!("{} is not a finite time", ShortNumber(t)));
    }
    match prev {
        Some(p) if t <= p => Err(format!("time does not increase ({} after {})", ShortNumber(t), ShortNumber(p))),
        _ => Ok(()),
    }
}

/// The rule of a record's input magnitudes, for every front end (the dataset CSV reader,
/// Python's frames), one row at a time: a finite ambient reading within −80…200 °C, a finite
/// shift within ±10 nm (`data::units`; a NaN is a gap). An implausible cell
/// would not only be answered wrongly: its square overflows the fit's normal equations.
/// `source(Some(g))` says where grating g's (0-based) unit is set, `source(None)` the
/// ambient's. The error is (column, message).
pub(crate) fn check_input_row<'a>(
    t_amb_c: f64,
    dl_pm: &[f64],
    source: impl Fn(Option<usize>) -> UnitSource<'a>,
) -> Result<(), (String, String)> {
    if t_amb_c.is_finite() {
        check_ambient(t_amb_c, source(None)).map_err(|m| (T_AMB_COLUMN.to_string(), m))?;
    }
    for (g, &v) in dl_pm.iter().enumerate() {
        if v.is_finite() {
            check_wavelength(WlUnit::ShiftPm, v, source(Some(g))).map_err(|m| (grating_column(g + 1), m))?;
        }
    }
    Ok(())
}

/// Which part of the record a sample belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Split {
    Cal,
    Holdout,
}

impl Split {
    pub fn as_str(self) -> &'static str {
        match self {
            Split::Cal => "cal",
            Split::Holdout => "holdout",
        }
    }
}

/// One reference column: what it measures and its values (NaN where missing).
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    pub measurand: Measurand,
    pub values: Vec<f64>,
}

/// What a dataset carries: gratings, measurands, ambient thermometer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Number of gratings (`dl1_pm..dlN_pm`).
    pub gratings: usize,
    /// Reference columns, in canonical order (empty for a field record).
    pub measurands: Vec<Measurand>,
    /// Whether the ambient thermometer `T_amb_C` is there.
    pub ambient: bool,
}

impl std::fmt::Display for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let g = match self.gratings {
            1 => "1 grating (dl1_pm)".to_string(),
            2 => "2 gratings (dl1_pm, dl2_pm)".to_string(),
            n => format!("{n} gratings (dl1_pm..dl{n}_pm)"),
        };
        let m = if self.measurands.is_empty() {
            "no reference columns".to_string()
        } else {
            let names: Vec<String> = self.measurands.iter().map(|m| m.column()).collect();
            format!("measurands {}", names.join(", "))
        };
        let a = if self.ambient { "ambient T_amb_C" } else { "no ambient thermometer (T_amb_C)" };
        write!(f, "{g}, {m}, {a}")
    }
}

/// A reference column ([`Dataset::target`], [`Dataset::reference_of`]): the values, or NaN at
/// every row for a reference the dataset does not have.
#[derive(Clone, Copy, Debug)]
pub struct Column<'a>(Option<&'a [f64]>);

impl<'a> Column<'a> {
    /// The values; empty for an absent reference.
    pub fn as_slice(&self) -> &'a [f64] {
        self.0.unwrap_or(&[])
    }
    /// Whether the dataset has the reference.
    pub(crate) fn is_present(&self) -> bool {
        self.0.is_some()
    }
}

impl std::ops::Index<usize> for Column<'_> {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        match self.0 {
            Some(v) => &v[i],
            None => &f64::NAN,
        }
    }
}

/// Column-oriented samples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dataset {
    /// Time since the start \[s\].
    pub t_s: Vec<f64>,
    /// Reference measurands, in canonical order (sorted by [`Measurand`]), at most
    /// [`MAX_MEASURANDS`](crate::data::MAX_MEASURANDS); empty for a field record without references.
    pub refs: Vec<Reference>,
    /// Ambient thermometer reading [°C]; `None` for an installation without one.
    pub t_amb_c: Option<Vec<f64>>,
    /// Measured wavelength shifts \[pm\] per grating (1 to [`MAX_GRATINGS`]).
    pub dl_pm: Vec<Vec<f64>>,
    pub split: Vec<Split>,
    /// Each grating's zero (λ_ref) and the absolute time of `t_s = 0`, when known (written as
    /// comment lines before the CSV header, [`record_meta`](crate::data::record_meta)).
    pub meta: RecordMeta,
}

impl Dataset {
    /// [`check_next_time`] over the whole time axis: the first row (0-based) that breaks it,
    /// with the message.
    pub fn check_times(&self) -> Result<(), (usize, String)> {
        let mut prev = None;
        for (i, &t) in self.t_s.iter().enumerate() {
            check_next_time(prev, t).map_err(|m| (i, m))?;
            prev = Some(t);
        }
        Ok(())
    }

    /// The rule of a record's input magnitudes (`check_input_row`) over every row, then the whole-column check of the dataset reader
    /// (a shift column whose values all lie within 1 % of an absolute wavelength in nm holds
    /// wavelengths), for a record handed over in memory: the messages name the columns. The
    /// first row (0-based) that breaks it, its column and the message.
    pub fn check_inputs(&self) -> Result<(), (usize, String, String)> {
        let mut row = [f64::NAN; MAX_GRATINGS];
        let names: Vec<String> = (1..=self.n_gratings()).map(grating_column).collect();
        let source =
            |g: Option<usize>| UnitSource::Column(g.and_then(|g| names.get(g)).map_or(T_AMB_COLUMN, String::as_str));
        for i in 0..self.len() {
            for (o, c) in row.iter_mut().zip(&self.dl_pm) {
                *o = c.get(i).copied().unwrap_or(f64::NAN);
            }
            let amb = self.t_amb_c.as_ref().and_then(|a| a.get(i)).copied().unwrap_or(f64::NAN);
            check_input_row(amb, row.get(..self.n_gratings()).unwrap_or(&[]), source).map_err(|(c, m)| (i, c, m))?;
        }
        for (g, c) in self.dl_pm.iter().enumerate() {
            let mut a = AbsNmCheck::default();
            c.iter().for_each(|&v| a.push(v));
            if a.looks_absolute_nm() {
                return Err((0, grating_column(g + 1), a.message(source(Some(g)))));
            }
        }
        Ok(())
    }

    pub fn len(&self) -> usize {
        self.t_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
    /// Number of gratings.
    pub fn n_gratings(&self) -> usize {
        self.dl_pm.len()
    }
    /// The measurands, in canonical order.
    pub fn measurands(&self) -> Vec<Measurand> {
        self.refs.iter().map(|r| r.measurand).collect()
    }
    /// The values of measurand `m`, if the dataset has that reference.
    pub fn reference(&self, m: Measurand) -> Option<&[f64]> {
        self.refs.iter().find(|r| r.measurand == m).map(|r| r.values.as_slice())
    }
    /// The values of measurand `m` to change, if the dataset has that reference.
    pub fn reference_mut(&mut self, m: Measurand) -> Option<&mut Vec<f64>> {
        self.refs.iter_mut().find(|r| r.measurand == m).map(|r| &mut r.values)
    }
    /// Remove the reference `m` (it becomes absent, not fitted); true if it was there.
    pub fn remove_reference(&mut self, m: Measurand) -> bool {
        let before = self.refs.len();
        self.refs.retain(|r| r.measurand != m);
        self.refs.len() != before
    }
    /// Gratings, measurands and ambient thermometer.
    pub fn shape(&self) -> Shape {
        Shape { gratings: self.n_gratings(), measurands: self.measurands(), ambient: self.t_amb_c.is_some() }
    }
    /// Put the references in canonical order (what the writer and the accessors expect).
    pub(crate) fn sort_refs(&mut self) {
        self.refs.sort_by_key(|r| r.measurand);
    }

    /// The dimensions of a model fitted on this dataset: its gratings, the ambient input when
    /// the dataset has `T_amb_C`, and its measurands in canonical order. A dataset without a
    /// reference column is an error naming `origin` (nothing to fit).
    pub fn dims(&self, origin: &str) -> Result<Dims, TrainerError> {
        if self.refs.is_empty() {
            return Err(TrainerError::data(
                origin,
                1,
                "T_C",
                "no reference column (T_C, strain_ue, p_kPa, T2_C, strain2_ue, ...): nothing to calibrate against (a record without references is for `compensate`)",
            ));
        }
        let outputs: Vec<_> = self.refs.iter().map(|r| r.measurand.output()).collect();
        Dims::new(self.n_gratings(), self.t_amb_c.is_some(), &outputs)
            .map_err(|e| TrainerError::data(origin, 1, "-", format!("the data have {}: {e}", self.shape())))
    }

    /// `Ok` when the dataset carries the inputs of a model of `dims` (its N gratings, and the
    /// ambient thermometer when the model reads it; references do not matter); otherwise an
    /// error naming `origin`, the first missing column, what the data have and what the model
    /// needs.
    pub fn inputs_for(&self, dims: &Dims, origin: &str, command: &str) -> Result<(), TrainerError> {
        let n = dims.gratings();
        let column = if self.n_gratings() != n {
            grating_column(self.n_gratings().min(n) + 1)
        } else if dims.ambient() && self.t_amb_c.is_none() {
            T_AMB_COLUMN.to_string()
        } else {
            return Ok(());
        };
        let needs = match (n, dims.ambient()) {
            (1, a) => format!("1 grating (dl1_pm){}", if a { " and the ambient thermometer T_amb_C" } else { "" }),
            (n, a) => format!(
                "{n} gratings (dl1_pm..dl{n}_pm){}",
                if a { " and the ambient thermometer T_amb_C" } else { "" }
            ),
        };
        Err(TrainerError::data(
            origin,
            1,
            &column,
            format!("the data have {}; `{command}` runs a model whose inputs are {needs}", self.shape()),
        ))
    }

    /// The ambient readings; empty when the installation has no thermometer.
    pub fn ambient(&self) -> &[f64] {
        self.t_amb_c.as_deref().unwrap_or(&[])
    }

    /// The model inputs of sample `i`: every grating's shift and the ambient reading (NaN
    /// without one).
    pub fn sample(&self, i: usize) -> Sample<f64> {
        // Built in place (every compensator pass reads each row through here).
        let mut s = Sample {
            dl_pm: [0.0; MAX_GRATINGS],
            gratings: self.n_gratings().min(MAX_GRATINGS) as u8,
            t_amb_c: self.t_amb_c.as_ref().map_or(f64::NAN, |a| a[i]),
            t_s: self.t_s[i],
        };
        for (o, c) in s.dl_pm.iter_mut().zip(&self.dl_pm) {
            *o = c[i];
        }
        s
    }
    /// The reference measurands of sample `i`, in canonical order.
    pub fn truth(&self, i: usize) -> Vec<f64> {
        self.refs.iter().map(|r| r.values[i]).collect()
    }
    /// Reference `c` in canonical order: output `c` of a model fitted on this dataset
    /// ([`Dataset::dims`]); indexing it gives NaN at every row beyond the references.
    pub fn target(&self, c: usize) -> Column<'_> {
        Column(self.refs.get(c).map(|r| r.values.as_slice()))
    }
    /// The reference of output `c` of a model of `dims`, found by measurand (NaN at every row
    /// when the dataset does not have it).
    pub fn reference_of(&self, dims: &Dims, c: usize) -> Column<'_> {
        Column(dims.outputs().get(c).and_then(|&o| self.reference(Measurand::of_output(o))))
    }
    /// The references of every output of a model of `dims`, found by measurand ([`Column`]s
    /// that read NaN where the dataset lacks one).
    pub fn references_of(&self, dims: &Dims) -> Vec<Column<'_>> {
        (0..dims.n_outputs()).map(|c| self.reference_of(dims, c)).collect()
    }
    /// Indices of the calibration samples.
    pub fn cal_indices(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.split[i] == Split::Cal).collect()
    }
    /// True when sample `i` can be used for fitting: finite inputs and every available
    /// reference present.
    pub fn usable(&self, i: usize) -> bool {
        self.dl_pm.iter().all(|c| c[i].is_finite())
            && self.t_amb_c.as_ref().is_none_or(|a| a[i].is_finite())
            && self.t_s[i].is_finite()
            && self.refs.iter().all(|r| r.values[i].is_finite())
    }
    /// Assign the split by time: samples with `t_s <= cal_until_s` calibrate, later ones are
    /// the hold-out.
    pub(crate) fn split_at_time(&mut self, cal_until_s: f64) {
        for (s, &t) in self.split.iter_mut().zip(&self.t_s) {
            *s = if t <= cal_until_s { Split::Cal } else { Split::Holdout };
        }
    }
    /// Assign the split by fraction of the record's duration.
    pub fn split_at_fraction(&mut self, fraction: f64) {
        let (t0, t1) = (self.t_s.first().copied().unwrap_or(0.0), self.t_s.last().copied().unwrap_or(0.0));
        self.split_at_time(t0 + fraction * (t1 - t0));
    }
    /// The band's clock for a model run over this record as over its own calibration record
    /// (`evaluate`, `stream`, the studies): absolute when the record and the model both know
    /// absolute time, else the calibration clock (this record's `t_s` is the model's).
    pub fn calibration_clock<F: fbg_shared::Real, const K: usize>(
        &self,
        model: &fbg_shared::ModelParams<F, K>,
    ) -> fbg_shared::StreamClock {
        match (self.meta.t0_unix_s, model.field.cal_end_unix_s) {
            (Some(t0), Some(_)) => fbg_shared::StreamClock::StartUnix(t0),
            _ => fbg_shared::StreamClock::Calibration,
        }
    }

    /// The band's clock for a field record (`compensate`): absolute when the record knows its
    /// start, else unknown (the band then takes the model's largest validated lead and every
    /// estimate says the lead is unknown).
    pub fn field_clock(&self) -> fbg_shared::StreamClock {
        self.meta.t0_unix_s.map_or(fbg_shared::StreamClock::Unknown, fbg_shared::StreamClock::StartUnix)
    }

    /// Indices of the hold-out samples.
    pub fn holdout_indices(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.split[i] == Split::Holdout).collect()
    }
    /// A new dataset with the rows `idx`, in that order.
    pub fn select(&self, idx: &[usize]) -> Dataset {
        let pick = |v: &Vec<f64>| idx.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        Dataset {
            t_s: pick(&self.t_s),
            refs: self.refs.iter().map(|r| Reference { measurand: r.measurand, values: pick(&r.values) }).collect(),
            t_amb_c: self.t_amb_c.as_ref().map(pick),
            dl_pm: self.dl_pm.iter().map(pick).collect(),
            split: idx.iter().map(|&i| self.split[i]).collect(),
            meta: self.meta.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_axis_is_finite_and_increasing() {
        let at = |t: Vec<f64>| Dataset { t_s: t, ..Dataset::default() }.check_times();
        assert_eq!(at(vec![0.0, 60.0, 120.0]), Ok(()));
        assert_eq!(at(vec![]), Ok(()));
        assert_eq!(at(vec![0.0, 60.0, 60.0]), Err((2, "time does not increase (60 after 60)".into())));
        assert_eq!(at(vec![120.0, 60.0]), Err((1, "time does not increase (60 after 120)".into())));
        assert_eq!(at(vec![0.0, f64::NAN]), Err((1, "NaN is not a finite time".into())));
        assert_eq!(at(vec![0.0, 1e308, -1e308]), Err((2, "time does not increase (-1e308 after 1e308)".into())));
    }

    #[test]
    fn the_csv_reader_applies_the_same_rule() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("r.csv");
        std::fs::write(&p, "t_s,T_C,dl1_pm,split\n0,20,1,cal\n60,20,1,cal\n30,20,1,cal\n").unwrap();
        let e = Dataset::read_csv(&p).unwrap_err().to_string();
        assert!(e.ends_with("line 4, column t_s: time does not increase (30 after 60)"), "{e}");
    }
}
