//! `fbg_compensation._core`: the Rust core of the Python package. Every loop over rows runs
//! here, through `fbg-trainer`'s library and `fbg-shared`'s compensator (the code the device
//! runs); the Python layer (`python/python/fbg_compensation/`) only shapes inputs and outputs.
//! Long work (a fit, a pass over a record, a simulation) runs with the GIL released and stops
//! on Ctrl-C (`interrupt.rs`).

use pyo3::prelude::*;

mod columns;
mod error;
mod fitting;
mod interrupt;
mod model;
mod records;
mod stream;

/// The module `fbg_compensation._core`.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("FbgError", m.py().get_type::<error::FbgError>())?;
    m.add_class::<model::Model>()?;
    m.add_class::<stream::Stream>()?;
    m.add_function(wrap_pyfunction!(fitting::fit, m)?)?;
    m.add_function(wrap_pyfunction!(records::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(records::read_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(records::compensate_file, m)?)?;
    m.add_function(wrap_pyfunction!(records::presets, m)?)?;
    m.add_function(wrap_pyfunction!(records::write_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(records::record_zero, m)?)?;
    m.add_function(wrap_pyfunction!(records::import_file, m)?)?;
    m.add_function(wrap_pyfunction!(flag_bits, m)?)?;
    Ok(())
}

/// Every flag bit of an estimate with its name (`fbg_shared::Flags`, the one definition).
#[pyfunction]
fn flag_bits() -> Vec<(u8, String)> {
    (0..8u8)
        .filter_map(|k| fbg_shared::Flags::from_bits(1 << k).filter(|f| !f.is_ok()).map(|f| (1u8 << k, f.to_string())))
        .collect()
}
