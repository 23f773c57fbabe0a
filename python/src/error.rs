//! The one Python exception of the package, carrying the library's (so the CLI's) message.

use fbg_trainer::TrainerError;
use pyo3::PyErr;

pyo3::create_exception!(
    _core,
    FbgError,
    pyo3::exceptions::PyValueError,
    "An error of the FBG compensator: the message is the command line's (it names the file, line and column, or the field)."
);

/// A library error as the Python exception, with the same text the CLI prints.
pub fn to_py(e: TrainerError) -> PyErr {
    FbgError::new_err(e.to_string())
}

/// An error of this layer (an argument), worded like the library's.
pub fn msg(text: impl Into<String>) -> PyErr {
    FbgError::new_err(text.into())
}
