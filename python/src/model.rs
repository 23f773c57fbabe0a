//! A model blob (`.fbgm`, Model-H or Model-P) held as the host's f64 model and the bytes it
//! came from: load and save (signed or not), inspect as JSON, the coefficient tables.

use std::path::PathBuf;

use fbg_shared::blob;
use fbg_trainer::data::files::write_bytes_atomically;
use fbg_trainer::export;
use fbg_trainer::fit::{HostParams, HOST_CAP};
use fbg_trainer::sign::{self, BlobSigner, SignOptions};
use fbg_trainer::TrainerError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::error::to_py;

/// A model, as `fbg-trainer` writes it and a device loads it. Its file is the blob the
/// trainer encodes (f32 coefficients); the host runs it in f64 or in the device's f32.
#[pyclass(module = "fbg_compensation._core", frozen)]
pub struct Model {
    params: HostParams,
    /// The file's bytes (with a signature trailer when signed).
    file: Vec<u8>,
}

impl Model {
    /// The host model.
    pub fn params(&self) -> &HostParams {
        &self.params
    }

    /// A freshly fitted model from its file (`export::ModelFiles`): the blob (f32
    /// coefficients) decoded again, so an estimator predicts exactly what its exported file
    /// does on the device's host path and in `compensate`.
    pub fn fitted(file: Vec<u8>) -> Result<Model, TrainerError> {
        Model::decode(file, "the fitted model")
    }

    /// Decode and validate `file` as `read_blob` does; `source` names it in errors.
    fn decode(file: Vec<u8>, source: &str) -> Result<Model, TrainerError> {
        let p32 = blob::decode::<HOST_CAP>(&file).map_err(|e| TrainerError::Model {
            path: source.to_string(),
            message: export::blob_error_text(&file, &e),
        })?;
        let params =
            p32.convert().map_err(|e| TrainerError::Model { path: source.to_string(), message: e.to_string() })?;
        Ok(Model { params, file })
    }
}

#[pymethods]
impl Model {
    /// A model from a file's bytes (as [`Model::from_bytes`]); what a pickle restores.
    #[new]
    #[pyo3(signature = (data, source="<bytes>"))]
    fn new(data: Vec<u8>, source: &str) -> PyResult<Model> {
        Model::decode(data, source).map_err(to_py)
    }

    /// Pickle and copy as the file's bytes: the restored model decodes the same bytes, so it
    /// predicts bit for bit what this one does.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, pyo3::types::PyType>, (Bound<'py, PyBytes>,)) {
        (slf.get_type(), (PyBytes::new(slf.py(), &slf.get().file),))
    }

    /// Read and fully validate a model file (signed or not), as `fbg-trainer` does.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Model> {
        let file = std::fs::read(&path).map_err(|e| to_py(TrainerError::io(&path, e)))?;
        Model::decode(file, &path.display().to_string()).map_err(to_py)
    }

    /// A model from a file's bytes; `source` names them in errors.
    #[staticmethod]
    #[pyo3(signature = (data, source="<bytes>"))]
    fn from_bytes(data: Vec<u8>, source: &str) -> PyResult<Model> {
        Model::decode(data, source).map_err(to_py)
    }

    /// The file's bytes (the signature trailer included when it has one).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.file)
    }

    /// The blob without any signature trailer, as the trainer encodes the model.
    fn blob_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, fbg_shared::container::strip(&self.file)))
    }

    /// Write the model to `path` atomically; with `key` (an Ed25519 PKCS#8 PEM file as
    /// `fbg-trainer keygen` writes), signed as `fbg-trainer sign` signs: the serial is the
    /// next of the key's ledger in `state_dir` unless given. Returns the signature record as
    /// JSON text (None unsigned).
    #[pyo3(signature = (path, key=None, serial=None, state_dir=None))]
    fn save(
        &self,
        path: PathBuf,
        key: Option<PathBuf>,
        serial: Option<u64>,
        state_dir: Option<PathBuf>,
    ) -> PyResult<Option<String>> {
        let blob = fbg_shared::container::strip(&self.file).to_vec();
        let signer = key
            .map(|key| BlobSigner::load(&SignOptions { key, serial, state_dir, ..SignOptions::default() }))
            .transpose()
            .map_err(to_py)?;
        let (bytes, record) = sign::maybe_sign(blob, signer.as_ref()).map_err(to_py)?;
        write_bytes_atomically(&path, &bytes).map_err(to_py)?;
        record.map(|r| serde_json::to_string(&r).map_err(|e| crate::error::msg(e.to_string()))).transpose()
    }

    /// The audit view as JSON text: the `model` object of `fbg-trainer inspect --json` (the
    /// coefficients, centres, field terms), with `signature` (checked against the public key
    /// file `pubkey` when given) and `bytes`.
    #[pyo3(signature = (pubkey=None))]
    fn inspect_json(&self, pubkey: Option<PathBuf>) -> PyResult<String> {
        let key = pubkey.as_deref().map(sign::read_public_key).transpose().map_err(to_py)?;
        let v = serde_json::json!({
            "bytes": self.file.len(),
            "blob_bytes": fbg_shared::container::strip(&self.file).len(),
            "kind": if export::is_model_p(&self.params) { "model-p" } else { "model-h" },
            "outputs": export::output_keys(&self.params),
            "signature": sign::check(&self.file, key.as_ref()),
            "model": export::model_json(&self.params, None),
        });
        serde_json::to_string(&v).map_err(|e| crate::error::msg(e.to_string()))
    }

    /// The output columns in order (`T_C`, `strain_ue`, `p_kPa`, …).
    #[getter]
    fn outputs(&self) -> Vec<String> {
        export::output_keys(&self.params)
    }

    /// Number of gratings the model reads (`dl1_pm..dlN_pm`).
    #[getter]
    fn gratings(&self) -> usize {
        self.params.dims.gratings()
    }

    /// Whether the model reads the ambient thermometer `T_amb_C`.
    #[getter]
    fn ambient(&self) -> bool {
        self.params.dims.ambient()
    }

    /// Whether this is Model-P (the polynomial core alone, no RBF centres).
    #[getter]
    fn is_model_p(&self) -> bool {
        export::is_model_p(&self.params)
    }
}
