//! A time series of measured inputs and reference measurands, and its CSV form (DESIGN §3):
//! `t_s`, the reference columns (measurands, [`measurand`]), `T_amb_C`, `dl1_pm..dlN_pm`,
//! `split` — the paper's file is `t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split`.
//!
//! The header says everything: the gratings are the `dlN_pm` columns (1 to 8, numbered without
//! holes), the measurands the reference columns it names (`T_C`, `strain_ue`, `strain2_ue`,
//! `p_kPa`, `T2_C`, ...; at most 4), the ambient thermometer `T_amb_C` when the
//! installation has one. Columns are found by name in any order, other columns are ignored,
//! and the writer puts them in the canonical order (measurands by kind T, ε, p, then index).
//! An empty reference cell is a missing reference at that time, an empty `dlN_pm` cell is a
//! gap (a peak the interrogator did not report), and so is an empty `T_amb_C`. Text that is
//! not a number, or a non-finite number, is an error naming file, line and column.
//!
//! A model fitted on a dataset takes its dimensions from it ([`Dataset::dims`]): N gratings,
//! the ambient input when `T_amb_C` is there, and one output per reference column in
//! canonical order, so output `c` of such a model is reference `c` ([`Dataset::target`]).
//! A model run over another record finds its references by measurand
//! ([`Dataset::reference_of`]).

mod csv;
mod dataset;
pub mod files;
pub mod import;
pub mod measurand;
pub mod outliers;
pub mod record_meta;
pub mod timestamp;
pub(crate) mod units;

pub use crate::data::csv::{quote_cell, MAX_LINE_BYTES, QUOTE_CHARS};
pub(crate) use crate::data::csv::{Row, RowReader};
pub use crate::data::dataset::{check_next_time, Column, Dataset, Reference, Shape, Split};
pub use crate::data::measurand::{Kind, Measurand, MAX_GRATINGS, MAX_MEASURANDS};
pub use crate::data::record_meta::{GratingZero, RecordMeta};

/// The paper's CSV header, in column order.
pub const COLUMNS: [&str; 9] = ["t_s", "T_C", "strain_ue", "p_kPa", "T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm", "split"];

/// The ambient thermometer's column.
pub(crate) const T_AMB_COLUMN: &str = "T_amb_C";
