//! The compensator's stream state, explicit: a long record fed in chunks gives, chunk after
//! chunk, exactly what one pass gives (the memory terms, direction latches and drift observer
//! carry over between calls).

use fbg_shared::{Estimate, Sample, StreamClock};
use fbg_trainer::data::MAX_GRATINGS;
use fbg_trainer::fit::{Engine, HostParams, Precision};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::error::msg;
use crate::interrupt;
use crate::model::Model;

/// Rows made into samples and compensated at a time (the engine spreads them over the cores).
const BLOCK: usize = 16384;

/// One compensator's running state over a stream of rows (`Stream(model, precision="f64",
/// t0_unix_s=None)`): feed it chunks in time order with `step`.
///
/// `t0_unix_s` is the absolute time (Unix s, UTC) of the stream's `t_s = 0`; without it the
/// band takes the model's largest validated lead and every row is flagged `lead-unknown`, as
/// `compensate` does for a record that does not state its start.
#[pyclass(module = "fbg_compensation._core")]
pub struct Stream {
    engine: Engine,
    gratings: usize,
    ambient: bool,
    outputs: usize,
    rows: usize,
    /// Set when Ctrl-C stopped a `step` partway: the state has then taken rows whose results
    /// were never returned, so the stream cannot go on.
    interrupted: bool,
}

impl Stream {
    /// A fresh stream of `params` in `precision` on `clock`.
    pub fn of(params: &HostParams, precision: Precision, clock: StreamClock) -> PyResult<Stream> {
        let engine = Engine::load(params, precision, clock)
            .map_err(|(what, e)| msg(format!("the model cannot be loaded for {what} arithmetic: {e}")))?;
        let dims = params.dims;
        Ok(Stream {
            engine,
            gratings: dims.gratings(),
            ambient: dims.ambient(),
            outputs: dims.n_outputs(),
            rows: 0,
            interrupted: false,
        })
    }
}

/// `"f64"` or `"f32"`.
pub fn precision(name: &str) -> PyResult<Precision> {
    match name {
        "f64" => Ok(Precision::F64),
        "f32" => Ok(Precision::F32),
        other => Err(msg(format!("precision: `{other}` is neither \"f64\" (the host's) nor \"f32\" (the device's)"))),
    }
}

/// The shifts `Stream.step` takes: rows × gratings in C order, or one array per grating (the
/// columns of a frame, with no copy into a matrix).
#[derive(FromPyObject)]
pub enum ShiftsArg<'py> {
    /// rows × gratings.
    Rows(PyReadonlyArray2<'py, f64>),
    /// One 1-D array per grating.
    Columns(Vec<PyReadonlyArray1<'py, f64>>),
}

/// [`ShiftsArg`] as slices.
enum Shifts<'a> {
    /// rows × gratings in C order, and the gratings.
    Rows(&'a [f64], usize),
    /// One slice per grating.
    Columns(Vec<&'a [f64]>),
}

impl<'a> Shifts<'a> {
    /// The slices of `arg`, each checked to hold `n` rows.
    fn of(arg: &'a ShiftsArg<'_>, n: usize) -> PyResult<Shifts<'a>> {
        let shifts = match arg {
            ShiftsArg::Rows(a) => {
                let (rows, g) = a.as_array().dim();
                let d = a.as_slice().map_err(|_| msg("dl_pm: not a C-contiguous float64 array"))?;
                (rows == n).then_some(Shifts::Rows(d, g))
            }
            ShiftsArg::Columns(cs) => {
                let cs = cs
                    .iter()
                    .map(|c| {
                        c.as_slice().map_err(|_| msg("dl_pm: a grating's column is not a contiguous float64 array"))
                    })
                    .collect::<PyResult<Vec<&[f64]>>>()?;
                cs.iter().all(|c| c.len() == n).then_some(Shifts::Columns(cs))
            }
        };
        shifts.ok_or_else(|| msg(format!("dl_pm needs one row per value of t_s ({n})")))
    }

    fn gratings(&self) -> usize {
        match self {
            Shifts::Rows(_, g) => *g,
            Shifts::Columns(cs) => cs.len(),
        }
    }

    /// Row `i`'s shifts into `out` (one per grating).
    fn row_into(&self, i: usize, out: &mut [f64]) {
        match self {
            Shifts::Rows(d, g) => {
                let row = d.get(i * g..(i + 1) * g).unwrap_or(&[]);
                out.iter_mut().zip(row).for_each(|(o, &x)| *o = x);
            }
            Shifts::Columns(cs) => out.iter_mut().zip(cs).for_each(|(o, c)| *o = c.get(i).copied().unwrap_or(f64::NAN)),
        }
    }
}

/// The band's clock of a stream starting at `t0_unix_s` (unknown without it).
pub fn clock(t0_unix_s: Option<f64>) -> StreamClock {
    t0_unix_s.map_or(StreamClock::Unknown, StreamClock::StartUnix)
}

/// What `Stream.step` returns: the estimates (rows × outputs, units of the outputs), their
/// 95 % half-bands (same units) and the flags (one `u8` bit set per row).
type Chunk<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<u8>>);

#[pymethods]
impl Stream {
    #[new]
    #[pyo3(signature = (model, precision="f64", t0_unix_s=None))]
    fn new(model: &Model, precision: &str, t0_unix_s: Option<f64>) -> PyResult<Stream> {
        Stream::of(model.params(), self::precision(precision)?, clock(t0_unix_s))
    }

    /// Compensate the next rows: `dl_pm` (pm shifts: rows × gratings in C order, or one 1-D
    /// array per grating), `t_amb_c` (°C per row; None for a model without an ambient input)
    /// and `t_s` (s per row). NaN inputs are gaps (the row's values are NaN and flagged
    /// non-finite). Runs without the GIL, in chunks of rows with Ctrl-C looked for between them
    /// (a stream stopped partway refuses further rows: its state has taken rows whose results
    /// were lost).
    #[pyo3(signature = (dl_pm, t_amb_c, t_s))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        dl_pm: ShiftsArg<'py>,
        t_amb_c: Option<PyReadonlyArray1<'py, f64>>,
        t_s: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Chunk<'py>> {
        let t = t_s.as_slice().map_err(|_| msg("t_s: not a contiguous float64 array"))?;
        let n = t.len();
        let dl = Shifts::of(&dl_pm, n)?;
        let g = dl.gratings();
        if g != self.gratings || g > MAX_GRATINGS {
            return Err(msg(format!("dl_pm: {g} grating columns; the model reads {}", self.gratings)));
        }
        if self.ambient && t_amb_c.is_none() {
            return Err(msg("T_amb_C: the model reads the ambient thermometer and none was given"));
        }
        let amb = t_amb_c
            .as_ref()
            .map(|a| a.as_slice())
            .transpose()
            .map_err(|_| msg("T_amb_C: not a contiguous float64 array"))?;
        if amb.is_some_and(|a| a.len() != n) {
            return Err(msg(format!("t_s and T_amb_C need one value per row of dl_pm ({n})")));
        }
        if self.interrupted {
            return Err(msg(format!(
                "this stream was interrupted (Ctrl-C) partway through a chunk after {} rows: its state has taken rows whose results were lost; start a new stream",
                self.rows
            )));
        }
        let m = self.outputs;
        let (mut values, mut band, mut flags) = (vec![0.0; n * m], vec![0.0; n * m], vec![0u8; n]);
        // The engine's batch path (bit for bit its step, sample after sample) over blocks of
        // rows made into samples here.
        let mut samples = vec![Sample::<f64>::default(); BLOCK];
        let mut estimates = vec![Estimate::<f64>::default(); BLOCK];
        // In chunks, with the GIL released for each and Ctrl-C looked for between them.
        let chunks = t
            .chunks(interrupt::ROWS_PER_CHUNK)
            .zip(values.chunks_mut(interrupt::ROWS_PER_CHUNK * m).zip(band.chunks_mut(interrupt::ROWS_PER_CHUNK * m)))
            .zip(flags.chunks_mut(interrupt::ROWS_PER_CHUNK));
        for (k, ((t, (values, band)), flags)) in chunks.enumerate() {
            if k > 0 {
                if let Err(e) = py.check_signals() {
                    self.interrupted = true;
                    self.rows += k * interrupt::ROWS_PER_CHUNK;
                    return Err(e);
                }
            }
            let first = k * interrupt::ROWS_PER_CHUNK;
            let engine = &mut self.engine;
            let (samples, estimates, dl) = (&mut samples, &mut estimates, &dl);
            py.detach(|| {
                let blocks = t
                    .chunks(BLOCK)
                    .zip(values.chunks_mut(BLOCK * m).zip(band.chunks_mut(BLOCK * m)))
                    .zip(flags.chunks_mut(BLOCK));
                for (b, ((t, (values, band)), flags)) in blocks.enumerate() {
                    let at = first + b * BLOCK;
                    for (i, (&t_s, s)) in t.iter().zip(samples.iter_mut()).enumerate() {
                        *s = Sample {
                            dl_pm: [0.0; MAX_GRATINGS],
                            gratings: g as u8,
                            t_amb_c: amb.and_then(|a| a.get(at + i).copied()).unwrap_or(f64::NAN),
                            t_s,
                        };
                        dl.row_into(at + i, s.dl_pm.get_mut(..g).unwrap_or(&mut []));
                    }
                    let done = engine.step_batch(samples.get(..t.len()).unwrap_or(&[]), estimates);
                    let out = values.chunks_exact_mut(m).zip(band.chunks_exact_mut(m)).zip(flags.iter_mut());
                    for (((v, b), f), e) in out.zip(estimates.iter()).take(done) {
                        v.iter_mut().zip(&e.values).for_each(|(o, &x)| *o = x);
                        b.iter_mut().zip(&e.band95).for_each(|(o, &x)| *o = x);
                        *f = e.flags.0;
                    }
                }
            });
        }
        self.rows += n;
        let shape = |v: Vec<f64>| Array2::from_shape_vec((n, m), v).map_err(|e| msg(e.to_string()));
        Ok((shape(values)?.into_pyarray(py), shape(band)?.into_pyarray(py), flags.into_pyarray(py)))
    }

    /// Rows compensated so far.
    #[getter]
    fn rows(&self) -> usize {
        self.rows
    }

    /// Number of outputs (columns of the estimates).
    #[getter]
    fn outputs(&self) -> usize {
        self.outputs
    }
}
