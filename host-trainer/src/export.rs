//! What the trainer writes for others: the `.fbgm` blob (through `fbg_shared::blob`), the
//! audit file `coefficients.json`, a trained model's files together ([`ModelFiles`]), and
//! golden vectors for the firmware's QEMU test.

use std::path::{Path, PathBuf};

use fbg_link::golden;
use fbg_shared::layout::{head, MAX_OUTPUTS, MAX_POLY};
use fbg_shared::{blob, Compensator, ModelParams, Sample};

use crate::data::files::{write_bytes_atomically, OutputSet};
use crate::data::measurand::{input_columns, poly_term_names, stage1_columns};
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::fit::static_fidelity::StaticAudit;
use crate::fit::{HostParams, PolyCore, Selection, Trained, HOST_CAP};
use crate::sign::{maybe_sign, BlobSigner, SignatureRecord};
use crate::warning::Warning;

/// Encode a host model as a blob (f32). Every blob the trainer writes or signs comes from
/// here, and it is decoded again before it is returned: a model the decoder (so a device, and
/// `sign`) would refuse, e.g. a coefficient beyond its plausibility bound
/// (`fbg_shared::model::bounds`), is an error naming the field, never a file.
///
/// ```
/// use fbg_trainer::export::{blob_bytes, read_blob};
/// // The model the firmware ships with, read and validated into the host's f64 form ...
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/model/default.fbgm");
/// let model = read_blob(&path)?;
/// // ... and encoded again: the same blob, byte for byte (f32 -> f64 -> f32 is exact; a
/// // signature trailer, if the file has one, is not part of the blob).
/// let file = std::fs::read(&path)?;
/// assert_eq!(blob_bytes(&model)?, fbg_shared::container::strip(&file));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn blob_bytes(p: &HostParams) -> Result<Vec<u8>, TrainerError> {
    let refused =
        |e: fbg_shared::Error| TrainerError::fit(format!("the trained model would not decode as a blob: {e}"));
    let p32: ModelParams<f32, HOST_CAP> = p.convert().map_err(refused)?;
    let mut buf = vec![0u8; blob::max_len(p32.centres.len())];
    let n = blob::encode(&p32, &mut buf).map_err(refused)?;
    buf.truncate(n);
    blob::decode::<HOST_CAP>(&buf).map_err(refused)?;
    Ok(buf)
}

/// Write a model blob atomically.
pub fn write_blob(path: &Path, p: &HostParams) -> Result<usize, TrainerError> {
    let b = blob_bytes(p)?;
    write_bytes_atomically(path, &b)?;
    Ok(b.len())
}

/// Read and fully validate a model blob into a host model (f64).
pub fn read_blob(path: &Path) -> Result<HostParams, TrainerError> {
    let bytes = std::fs::read(path).map_err(|e| TrainerError::io(path, e))?;
    let p32 = blob::decode::<HOST_CAP>(&bytes)
        .map_err(|e| TrainerError::Model { path: path.display().to_string(), message: blob_error_text(&bytes, &e) })?;
    p32.convert().map_err(|e| TrainerError::Model { path: path.display().to_string(), message: e.to_string() })
}

/// The CRC-32/ISCSI over everything but the 4-byte trailer, and the trailer itself (`None`
/// for input too short to hold a header and a trailer).
pub fn blob_crc(bytes: &[u8]) -> Option<(u32, u32)> {
    Some((blob::computed_crc(bytes)?, blob::stored_crc(bytes)?))
}

/// A decode error as the user should read it: the decoder checks the format version first
/// (it decides how the rest is read), so a flipped bit in the header reads as "format version
/// 0"; when the CRC over the whole blob does not hold either, the blob is corrupt, and that is
/// what is reported.
///
/// Bytes left after a blob that end in a signature trailer this build cannot read (unknown
/// version, reserved byte set, ...) are named as that trailer's problem, not as extra bytes.
pub fn blob_error_text(bytes: &[u8], e: &fbg_shared::Error) -> String {
    if let (fbg_shared::Error::TrailingBytes { .. }, Err(trailer)) = (e, fbg_shared::container::open(bytes)) {
        return trailer.to_string();
    }
    match (e, blob_crc(bytes)) {
        (fbg_shared::Error::UnsupportedVersion { found, .. }, Some((computed, stored))) if computed != stored => format!(
            "model blob corrupted: CRC-32 mismatch over the whole blob (stored {stored:08x}, computed {computed:08x}); its header reads format version {found}, which the corruption may have changed"
        ),
        _ => e.to_string(),
    }
}

/// A JSON object with one entry per output of `p`, keyed by its column name (`T_C`, …).
fn per_output<T: serde::Serialize>(p: &HostParams, v: impl Fn(usize) -> T) -> serde_json::Value {
    let m: serde_json::Map<String, serde_json::Value> =
        output_keys(p).into_iter().enumerate().map(|(o, k)| (k, serde_json::json!(v(o)))).collect();
    serde_json::Value::Object(m)
}

/// JSON keys of a model's outputs: their column names, in output order.
pub fn output_keys(p: &HostParams) -> Vec<String> {
    p.dims.outputs().iter().map(|o| o.column().as_str().to_string()).collect()
}

/// The audit view of one model.
pub fn model_json(p: &HostParams, core: Option<&PolyCore>) -> serde_json::Value {
    let fs = p.hyper.feature_set;
    let dims = &p.dims;
    let (m, n_z, ns) = (dims.n_outputs(), dims.z_len(), dims.stage1_len());
    let active: Vec<bool> = head(&dims.z_active(fs), n_z).to_vec();
    let centres: Vec<serde_json::Value> = p
        .centres
        .iter()
        .enumerate()
        .map(|(j, c)| {
            let physical: Vec<Option<f64>> =
                (0..n_z).map(|d| if active[d] { Some(p.z_mean[d] + c.mu[d] * p.z_std[d]) } else { None }).collect();
            serde_json::json!({
                "index": j,
                "mu_standardised": head(&c.mu, n_z),
                "mu_physical": physical,
                "w": per_output(p, |o| c.w[o]),
                "variance_eigvec_components": c.v,
            })
        })
        .collect();
    let names = poly_term_names(dims);
    let poly_rows = |b: &[[f64; MAX_POLY]; MAX_OUTPUTS]| -> serde_json::Value {
        per_output(p, |o| {
            let row: serde_json::Map<String, serde_json::Value> =
                names.iter().zip(b[o].iter()).map(|(n, v)| (n.clone(), serde_json::json!(v))).collect();
            serde_json::Value::Object(row)
        })
    };
    let physical = core.map(|c| poly_rows(&c.physical_coefficients()));
    let memory = memory_json(p);
    let z_names: Vec<String> = (0..n_z).map(|i| dims.z_name(i).as_str().to_string()).collect();
    let mut stage1 = serde_json::json!({ "columns": stage1_columns(dims) });
    if let (Some(obj), serde_json::Value::Object(rows)) =
        (stage1.as_object_mut(), per_output(p, |o| head(&p.stage1[o], ns)))
    {
        obj.extend(rows);
    }
    serde_json::json!({
        "hyper_parameters": {
            "feature_set": fs.name(),
            "centres": p.centres.len(),
            "sigma_multiplier": p.hyper.sigma_mult,
            "sigma_standardised": p.hyper.sigma,
            "alpha_eq7": p.hyper.alpha,
            "dead_band_pm": p.hyper.dead_band_pm,
            "weak_support_threshold": p.hyper.weak_support,
            "envelope_margin": p.hyper.envelope_margin,
            "flagged_band_factor": p.hyper.flagged_band_factor,
        },
        "stage1_linear_inverse": stage1,
        "model_dims": {"gratings": dims.gratings(), "ambient": dims.ambient(), "measurands": output_keys(p)},
        "first_guess_scalers": {"mean": head(&p.guess_mean, m), "std": head(&p.guess_std, m), "order": output_keys(p)},
        "poly_B_standardised_guesses": poly_rows(&p.poly),
        "poly_B_physical_units": physical,
        "memory_terms": memory,
        "rbf_input_scalers": {"inputs": z_names, "active": active, "mean": head(&p.z_mean, n_z), "std": head(&p.z_std, n_z)},
        "rbf_centres": centres,
        "band": {
            "resid_var_at_cal_end": head(&p.resid_var, m),
            "resid_var_growth_per_s": head(&p.resid_var_growth, m),
            "t_cal_end_s": p.t_cal_end_s,
            "k95": head(&p.band_k, m),
            "var_inv_g": p.var_inv_g,
            "var_inv_g_tail": p.var_inv_g_tail,
        },
        "envelope": {"inputs": input_columns(dims), "lo": head(&p.envelope_lo, dims.envelope_len()), "hi": head(&p.envelope_hi, dims.envelope_len())},
        "field": field_json(p),
        "trust": {
            "meaning": "DESIGN §4, the second rule: the gate lets a sample into the memory state only within the envelope widened by half its span and within ten times the largest calibration rate; beyond a grating's largest calibration quiet time (time since its narrowest play last reversed) what Model-H adds to the core fades to nothing at twice that, and the band to Model-P's",
            "rate_max_per_s": {"inputs": input_columns(dims), "values": head(&p.trust.rate_max, dims.envelope_len())},
            "quiet_max_s": head(&p.trust.quiet_max_s, dims.gratings()),
            "fallback_band_var_at_cal_end": head(&p.trust.fallback_var, dims.n_outputs()),
            "fallback_band_var_growth_per_s": head(&p.trust.fallback_var_growth, dims.n_outputs()),
            "pace": {
                "meaning": "beyond the calibration's pace (rho = the largest ratio over the inputs of the RMS swing, a band-pass of the input from fast_tau_s to slow_tau_s averaged in square over window_s, or of the RMS speed, the rate of the fast low-pass averaged in square over window_s, to its largest calibration value) what Model-H adds fades to nothing at rho = 2 and the band's variance is multiplied by rho squared",
                "fast_tau_s": fbg_shared::compensator::SWING_FAST_TAU_S,
                "slow_tau_s": fbg_shared::compensator::SWING_SLOW_TAU_S,
                "window_s": fbg_shared::compensator::PACE_WINDOW_S,
                "inputs": input_columns(dims),
                "swing_rms_max": head(&p.trust.swing_rms_max, dims.envelope_len()),
                "speed_rms_max_per_s": head(&p.trust.speed_rms_max, dims.envelope_len()),
            },
        },
        "provenance": {
            "seed": p.provenance.seed,
            "scenario": p.provenance.scenario.as_str(),
            "trainer_version": p.provenance.trainer_version.as_str(),
            "date_yyyymmdd": p.provenance.date_yyyymmdd,
            "n_cal": p.provenance.n_cal,
        },
    })
}

/// The model's field context: each grating's zero, the tolerance on a record's zero, the
/// calibration's absolute clock, the output envelope and the largest band.
pub fn field_json(p: &HostParams) -> serde_json::Value {
    let f = &p.field;
    let n = p.dims.gratings();
    let m = p.dims.n_outputs();
    serde_json::json!({
        "gratings": (1..=n).map(crate::data::measurand::grating_column).collect::<Vec<_>>(),
        "lambda_ref_nm": (0..n).map(|g| f.lambda_ref(g)).collect::<Vec<_>>(),
        "lambda_ref_source": head(&f.lambda_ref_source, n).iter().map(|s| s.name()).collect::<Vec<_>>(),
        "lambda_ref_tolerance_pm": f.lambda_ref_tol_pm,
        "cal_end_utc": f.cal_end_unix_s.map(crate::data::timestamp::format_utc),
        "cal_end_unix_s": f.cal_end_unix_s,
        "lead_max_s": f.lead_max_s,
        "outputs": output_keys(p),
        "output_lo": head(&f.output_lo, m),
        "output_hi": head(&f.output_hi, m),
        "band_max": head(&f.band_max, m),
    })
}

/// What a memory term is, in words a metrologist checks: e.g. "FBG2 minus its 20-min average".
pub fn memory_term_meaning(info: &fbg_shared::memory::TermInfo<f64>) -> String {
    use fbg_shared::MemoryGroup as G;
    let dur = |s: f64| {
        if s >= 3600.0 && (s / 3600.0).fract() == 0.0 {
            format!("{}-h", s / 3600.0)
        } else {
            format!("{}-min", s / 60.0)
        }
    };
    match info.group {
        G::GratingHighPass => format!("FBG{} shift minus its {} average", info.grating + 1, dur(info.parameter)),
        G::AmbientHighPass => format!("T_amb minus its {} average", dur(info.parameter)),
        G::Stop => format!("FBG{} shift minus its play operator of half-width {} pm", info.grating + 1, info.parameter),
        G::DriftObserver => format!(
            "drift observer: {} average of (grating temperature lagged like the thermometer − T_amb)",
            dur(info.parameter)
        ),
    }
}

/// Γ with a unit and a meaning per used term (the audit view of the memory terms).
pub fn memory_json(p: &HostParams) -> serde_json::Value {
    let spec = &p.memory;
    let terms: Vec<serde_json::Value> = (0..p.dims.memory_len())
        .filter_map(|k| spec.term(&p.dims, k).filter(|t| t.parameter > 0.0).map(|t| (k, t)))
        .map(|(k, t)| {
            let unit = t.group.unit();
            let coef = per_output(p, |o| {
                serde_json::json!({
                    "value": p.gamma[o][k],
                    "unit": format!("{} per {}", p.dims.outputs()[o].unit(), unit),
                })
            });
            serde_json::json!({
                "index": k,
                "group": t.group.name(),
                "meaning": memory_term_meaning(&t),
                "term_unit": unit,
                "gamma": coef,
            })
        })
        .collect();
    serde_json::json!({
        "spec": {
            "grating_tau_s": spec.grating_tau_s,
            "ambient_tau_s": spec.ambient_tau_s,
            "play_half_width_pm": spec.play_half_width_pm,
            "observer_lag_s": spec.observer_lag_s,
            "observer_smooth_s": spec.observer_smooth_s,
            "observer_row": {"columns": stage1_columns(&p.dims), "values": head(&spec.observer_row, p.dims.stage1_len())},
        },
        "terms": terms,
    })
}

/// The audit sidecar of the model blob `model`: `<stem>.coefficients.json` beside it, so models
/// trained into one directory never overwrite each other's coefficients (as `fleet` names them).
pub fn coefficients_path(model: &Path) -> PathBuf {
    sidecar(model, "coefficients.json")
}

/// Where Model-P goes beside the Model-H blob `model`: `<stem>-p.fbgm`.
pub fn baseline_path(model: &Path) -> PathBuf {
    model.with_file_name(format!("{}-p.fbgm", stem(model)))
}

/// Where `evaluate` writes the metrics of the model blob `model`: `<stem>.metrics.json` beside it.
pub fn metrics_path(model: &Path) -> PathBuf {
    sidecar(model, "metrics.json")
}

/// `<stem>.<suffix>` beside the model blob `model`.
pub fn sidecar(model: &Path, suffix: &str) -> PathBuf {
    model.with_file_name(format!("{}.{suffix}", stem(model)))
}

fn stem(model: &Path) -> String {
    model.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "model".into())
}

/// The text of `<stem>.coefficients.json`: both models with every number a metrologist audits,
/// the fit's warnings (`warnings`: code, channel, message, numbers; `fit::Trained::warnings`)
/// and, for signed blobs, their signatures (`signatures`: key id, serial and flags per model),
/// so that the audit file names the release each blob is.
pub fn coefficients_text(
    model_p: &HostParams,
    model_h: &HostParams,
    core: &PolyCore,
    selection: Option<&Selection>,
    audit: Option<&StaticAudit>,
    signatures: Option<serde_json::Value>,
    warnings: &[Warning],
) -> Result<String, TrainerError> {
    let mut v = serde_json::json!({
        "format": "fbg-trainer coefficients v1",
        "units": units_json(model_h),
        "model_p": model_json(model_p, Some(core)),
        "model_h": model_json(model_h, Some(&PolyCore::of(model_h))),
        "selection": selection.map(|s| serde_json::json!({
            "chosen": s.chosen, "cv_rmse_p": s.cv_rmse_p, "cv_rmse_h": s.cv_rmse_h, "folds": s.folds,
            "drift_rate_pm2_per_s": s.drift_rate_pm2_per_s,
            "memory": output_keys(model_h).iter().enumerate().map(|(o, k)| serde_json::json!({
                "output": k, "groups": s.memory.names(o), "lambda": s.memory.lambda[o],
            })).collect::<Vec<_>>(),
            "memory_cv": s.memory_rows,
        })),
        "static_fidelity": audit.map(|a| static_fidelity_json(model_h, a)),
        "sensitivity": sensitivity_json(model_p),
        "warnings": warnings,
    });
    // The interrogator's statement, only when given (other models' files stay as they were).
    if let Some(sel) = selection.zip(v.get_mut("selection").and_then(|s| s.as_object_mut())) {
        if let Some(spec) = sel.0.stated_drift_pm_per_sqrt_day {
            sel.1.insert("stated_drift_pm_per_sqrt_day".into(), spec.into());
        }
        if let Some(g) = &sel.0.stated_drift_gains {
            sel.1.insert("stated_drift_gains".into(), g.clone().into());
        }
    }
    if let (Some(sig), Some(obj)) = (signatures, v.as_object_mut()) {
        obj.insert("signatures".into(), sig);
    }
    serde_json::to_string_pretty(&v).map_err(|e| TrainerError::fit(e.to_string()))
}

/// A trained model as its files hold it: the Model-H and Model-P blobs, signed when a signer
/// is given, and `coefficients.json` naming their signatures. Every command that writes a
/// fit (`train`, `demo`, a `fleet` group) and Python's `fit` make them here.
pub struct ModelFiles {
    /// The Model-H file.
    pub model_h: Vec<u8>,
    /// The Model-P file.
    pub model_p: Vec<u8>,
    /// The text of `coefficients.json`.
    pub coefficients: String,
    /// Model-H's and Model-P's signatures, when signed.
    pub signatures: Option<(SignatureRecord, SignatureRecord)>,
}

impl ModelFiles {
    /// The files of `tr`, each blob signed by `signer` when given (Model-H first, then
    /// Model-P).
    pub fn of(tr: &Trained, signer: Option<&BlobSigner>) -> Result<ModelFiles, TrainerError> {
        let (model_h, sig_h) = maybe_sign(blob_bytes(&tr.model_h)?, signer)?;
        let (model_p, sig_p) = maybe_sign(blob_bytes(&tr.model_p)?, signer)?;
        let mut files = ModelFiles { model_h, model_p, coefficients: String::new(), signatures: sig_h.zip(sig_p) };
        files.coefficients = coefficients_text(
            &tr.model_p,
            &tr.model_h,
            &tr.core,
            Some(&tr.selection),
            Some(&tr.static_audit),
            files.signatures_json(),
            &tr.warnings,
        )?;
        Ok(files)
    }

    /// The signatures as `coefficients.json` and the summaries write them.
    pub fn signatures_json(&self) -> Option<serde_json::Value> {
        self.signatures.as_ref().map(|(h, p)| serde_json::json!({"model_h": h, "model_p": p}))
    }

    /// Stage the files in `set`: Model-H at `out`, Model-P at [`baseline_path`], the
    /// coefficients at [`coefficients_path`].
    pub fn stage(&self, set: &OutputSet, out: &Path) -> Result<(), TrainerError> {
        set.stage_bytes(out, &self.model_h)?;
        set.stage_bytes(&baseline_path(out), &self.model_p)?;
        set.stage_bytes(&coefficients_path(out), self.coefficients.as_bytes())
    }

    /// Write the files beside `out` as one output set: replaced together or not at all.
    pub fn write(&self, out: &Path) -> Result<(), TrainerError> {
        let set = OutputSet::beside(out)?;
        self.stage(&set, out)?;
        set.commit()
    }
}

/// The static-fidelity audit (DESIGN §4) as written in `coefficients.json`: per output both
/// models' static gains (the truth regressed on the settled reading over the calibration batch) and the
/// RMS of what each dynamic part of Model-H adds.
pub fn static_fidelity_json(model_h: &HostParams, a: &StaticAudit) -> serde_json::Value {
    let mut parts = serde_json::Map::new();
    for (g, v) in &a.contributions.memory {
        parts.insert((*g).to_string(), serde_json::json!(v));
    }
    parts.insert("rbf".into(), serde_json::json!(a.contributions.rbf));
    serde_json::json!({
        "what": "per output, the slope of the truth regressed on each model's settled reading (high-pass memory terms at 0) over the calibration batch: the gain the settled reading would need; 1 is right",
        "outputs": output_keys(model_h),
        "model_p_gain": a.model_p.gain,
        "model_h_gain": a.model_h.gain,
        "model_p_offset": a.model_p.offset,
        "model_h_offset": a.model_h.offset,
        "tolerance": crate::fit::static_fidelity::STATIC_GAIN_TOLERANCE,
        "disagreements": a.disagreements().iter().map(|&(c, h, p)| serde_json::json!({"output": c, "model_h": h, "model_p": p})).collect::<Vec<_>>(),
        "contributions_rms": parts,
    })
}

/// The calibration sheet of Model-P `p` ([`crate::fit::sensitivity`]) as written in
/// `coefficients.json` and `inspect --json`: each grating's sensitivity to each measurand
/// (`forward`, grating → output → pm per output unit), the model's inverse (`inverse`, output →
/// grating → output unit per pm) and, with the ambient input, T_amb's slope with the gratings
/// held, with their units; `{"error": …}` when the model has none.
pub fn sensitivity_json(p: &HostParams) -> serde_json::Value {
    let s = match crate::fit::sensitivity::of(p) {
        Ok(s) => s,
        Err(e) => return serde_json::json!({ "error": e.to_string() }),
    };
    let gratings: Vec<String> = (1..=s.gratings).map(crate::data::measurand::grating_column).collect();
    let keyed = |keys: &[String], v: &[f64]| -> serde_json::Value {
        serde_json::Value::Object(keys.iter().cloned().zip(v.iter().map(|x| serde_json::json!(x))).collect())
    };
    let by_name = |keys: &[String], units: Vec<String>| -> serde_json::Value {
        serde_json::Value::Object(keys.iter().cloned().zip(units.into_iter().map(serde_json::Value::from)).collect())
    };
    let mut v = serde_json::json!({
        "what": format!("∂Δλ/∂y (forward) and ∂ŷ/∂Δλ (inverse) {}", s.how()),
        "method": s.method,
        "rank": s.rank,
        "ambient_follows_temperature": s.ambient_follows,
        "gratings": gratings,
        "outputs": s.outputs,
        "forward_units": by_name(&s.outputs, s.forward_units()),
        "forward": serde_json::Value::Object(
            gratings.iter().cloned().zip(s.forward.iter().map(|row| keyed(&s.outputs, row))).collect()
        ),
        "inverse_units": by_name(&s.outputs, s.inverse_units()),
        "inverse": serde_json::Value::Object(
            s.outputs.iter().cloned().zip(s.inverse.iter().map(|row| keyed(&gratings, row))).collect()
        ),
    });
    if let (Some(a), Some(obj)) = (&s.ambient, v.as_object_mut()) {
        obj.insert(
            "ambient_slope_units".into(),
            by_name(&s.outputs, s.units.iter().map(|u| format!("{u}/°C")).collect()),
        );
        obj.insert("ambient_slope".into(), keyed(&s.outputs, a));
    }
    v
}

/// The units of a model's outputs and inputs, by short channel name.
fn units_json(p: &HostParams) -> serde_json::Value {
    let mut m = serde_json::Map::new();
    for o in p.dims.outputs() {
        m.insert(o.channel().as_str().to_string(), serde_json::json!(o.unit()));
    }
    m.insert("dl".into(), serde_json::json!("pm"));
    m.insert("t".into(), serde_json::json!("s"));
    serde_json::Value::Object(m)
}

/// The files [`write_golden`] writes into `dir`.
pub fn golden_files(dir: &Path) -> [PathBuf; 3] {
    ["golden_inputs.bin", "golden_expected.csv", "golden_meta.json"].map(|f| dir.join(f))
}

/// Golden vectors for the firmware (`fbg_link::golden`): `golden_inputs.bin` (the samples as
/// the device receives them: the N shifts, T_amb and t, in f32), `golden_expected.csv` (the
/// f64 reference on those same inputs) and
/// `golden_meta.json` (tolerance scale: Model-H's hold-out RMSE). The reference is a fresh
/// compensator fed the samples `idx` in order, exactly what a freshly booted device sees.
/// The three files are one output set: replaced together or not at all.
pub fn write_golden(
    dir: &Path,
    model_h: &HostParams,
    d: &Dataset,
    idx: &[usize],
    holdout_rmse: &[f64],
) -> Result<(), TrainerError> {
    let set = crate::data::files::OutputSet::in_dir(dir)?;
    let mut reference = Compensator::<f64, HOST_CAP>::new(model_h).map_err(|e| TrainerError::fit(e.to_string()))?;
    let inputs: Vec<Sample<f32>> = idx.iter().map(|&i| d.sample(i).cast()).collect();
    let rows: Vec<_> = inputs.iter().map(|x| reference.step(&x.cast())).collect();
    let [bin, csv, meta_file] = golden_files(dir);
    set.stage_bytes(&bin, &golden::inputs_bytes(&inputs))?;
    set.stage_bytes(&csv, golden::expected_csv(&rows).as_bytes())?;
    let meta = serde_json::json!({
        "samples": idx.len(),
        "holdout_rmse_h": holdout_rmse,
        "tolerance_fraction": fbg_link::parity::REL_TOL,
        "feature_set": model_h.hyper.feature_set.name(),
        "centres": model_h.centres.len(),
        "note": "expected = fbg_shared::Compensator<f64> with the trainer's f64 model on these f32 inputs, streamed from the first sample",
    });
    set.stage_bytes(&meta_file, meta.to_string().as_bytes())?;
    set.commit()
}

/// A Model-P-only host model is Model-H without centres; true when `p` has none.
pub fn is_model_p(p: &HostParams) -> bool {
    p.centres.is_empty()
}
