//! `fbg-trainer inspect`: a blob's header, dimensions, hyper-parameters and provenance.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use fbg_shared::blob;
use fbg_trainer::export;
use fbg_trainer::fit::HostParams;
use fbg_trainer::sign;

/// Print a blob's header, dimensions, hyper-parameters, provenance and signature (key id,
/// serial, and whether it verifies against --pubkey).
#[derive(clap::Args)]
pub struct InspectArgs {
    /// The `.fbgm` blob.
    model: PathBuf,
    /// Check the signature against this public key (`lab.pub`, raw 32 bytes, or
    /// `lab.pub.hex`) with the device's verifier; exits non-zero when it does not verify.
    #[arg(long, value_name = "FILE")]
    pubkey: Option<PathBuf>,
    /// Print the header and the whole model as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// What `inspect` read of a blob.
struct Inspected<'a> {
    path: &'a Path,
    pubkey: Option<&'a Path>,
    /// The file's bytes, with any signature trailer.
    file: Vec<u8>,
    params: HostParams,
    header: blob::Header,
    /// The blob's CRC-32 (hex).
    crc: String,
    check: sign::SignatureCheck,
    sens_model: HostParams,
    sens_source: String,
}

impl InspectArgs {
    pub fn run(self) -> Result<()> {
        let path = self.model.as_path();
        let file = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        // The whole blob (CRC first) before the header, so corruption is named as such.
        let params: HostParams = export::read_blob(path)?;
        let bytes = fbg_shared::container::strip(&file);
        let header = blob::Header::parse(bytes)
            .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), export::blob_error_text(bytes, &e)))?;
        let crc = export::blob_crc(bytes).map(|(c, _)| format!("{c:08x}")).unwrap_or_default();
        let key = self.pubkey.as_deref().map(sign::read_public_key).transpose()?;
        let check = sign::check(&file, key.as_ref());
        let (sens_model, sens_source) = sensitivity_source(path, &params);
        let i = Inspected {
            path,
            pubkey: self.pubkey.as_deref(),
            file,
            params,
            header,
            crc,
            check,
            sens_model,
            sens_source,
        };
        if self.json {
            println!("{}", serde_json::to_string_pretty(&i.json())?);
        } else {
            i.print();
        }
        i.refuse()
    }
}

impl Inspected<'_> {
    /// An error when `--pubkey` was given and the signature does not verify with it.
    fn refuse(&self) -> Result<()> {
        match (self.check.verifies, self.pubkey) {
            (Some(false), Some(k)) => bail!(
                "{}: the signature does not verify with {}: {}",
                self.path.display(),
                k.display(),
                self.check.problem.as_deref().unwrap_or("unknown reason")
            ),
            _ => Ok(()),
        }
    }

    fn json(&self) -> serde_json::Value {
        let header = &self.header;
        let mut sensitivity = export::sensitivity_json(&self.sens_model);
        if let Some(o) = sensitivity.as_object_mut() {
            o.insert("source".into(), serde_json::json!(self.sens_source));
        }
        serde_json::json!({
            "file": self.path,
            "bytes": self.file.len(),
            "blob_bytes": fbg_shared::container::strip(&self.file).len(),
            "crc32": self.crc,
            "header": {"magic": "FBGM", "format_version": header.version, "gratings": header.gratings,
                       "ambient": header.ambient == 1, "measurands": header.measurands, "poly_terms": header.poly_terms,
                       "memory_terms": header.memory_terms, "centres": header.centres},
            "signature": self.check,
            "model": export::model_json(&self.params, None),
            "sensitivity": sensitivity,
        })
    }

    fn print(&self) {
        let (path, p, header) = (self.path, &self.params, &self.header);
        println!(
            "{}: {} bytes, FBGM format v{}, CRC-32 {} (valid)",
            path.display(),
            fbg_shared::container::strip(&self.file).len(),
            header.version,
            self.crc
        );
        println!("{}", self.signature_line());
        let names: Vec<String> = p.dims.outputs().iter().map(|o| o.column().as_str().to_string()).collect();
        println!(
            "dims: gratings {}, ambient {}, measurands {} ({}), poly terms {}, memory terms {}, centres {}",
            header.gratings,
            if header.ambient == 1 { "yes" } else { "no" },
            header.measurands,
            names.join(", "),
            header.poly_terms,
            header.memory_terms,
            header.centres
        );
        print_model(p);
        println!("{}", static_fidelity_line(path));
        println!("sensitivities from {}:", self.sens_source);
        for (_, t) in fbg_trainer::report::coef::sensitivity_tables(&self.sens_model) {
            print!("{}", t.text());
        }
    }

    /// "signature: key id …, serial …; verifies with …" (or none, or malformed).
    fn signature_line(&self) -> String {
        let check = &self.check;
        match (&check.record, check.verifies) {
            (None, _) if !check.signed => "signature: none (unsigned: valid on the host, refused by a device)".into(),
            (None, _) => format!("signature: malformed trailer ({})", check.problem.as_deref().unwrap_or("")),
            (Some(r), v) => format!(
                "signature: key id {}, serial {}{}; {}",
                r.key_id,
                r.serial,
                r.rollback_text(),
                match (v, self.pubkey) {
                    (Some(true), Some(k)) => format!(
                        "verifies with {} (key id {})",
                        k.display(),
                        check.checked_key_id.as_deref().unwrap_or("")
                    ),
                    (Some(false), Some(k)) => format!(
                        "does NOT verify with {} (key id {}): {}",
                        k.display(),
                        check.checked_key_id.as_deref().unwrap_or(""),
                        check.problem.as_deref().unwrap_or("")
                    ),
                    _ => "not checked (pass --pubkey lab.pub)".to_string(),
                }
            ),
        }
    }
}

/// The hyper-parameters, band, envelope, zero, clock and provenance lines of `p`.
fn print_model(p: &HostParams) {
    let h = &p.hyper;
    println!(
        "hyper-parameters: features {}, σ {:.4} (= {}×NN), α {:.4e}, dead band {} pm, weak support < {:.2e}, envelope margin {}, flagged band ×{}",
        h.feature_set.name(), h.sigma, f32s(&[h.sigma_mult]), h.alpha, f32s(&[h.dead_band_pm]), h.weak_support, f32s(&[h.envelope_margin]), f32s(&[h.flagged_band_factor])
    );
    // The blob stores f32: print what it holds (`0.1`, not `0.10000000149011612`).
    println!(
        "band: k95 [{}], s² at cal end [{}], growth [{}] per s after t = {} s",
        f32s(fbg_shared::layout::head(&p.band_k, p.dims.n_outputs())),
        f32s(fbg_shared::layout::head(&p.resid_var, p.dims.n_outputs())),
        f32s(fbg_shared::layout::head(&p.resid_var_growth, p.dims.n_outputs())),
        f32s(&[p.t_cal_end_s])
    );
    let ne = p.dims.envelope_len();
    println!(
        "envelope: lo [{}] hi [{}] (dl1..{} pm{})",
        f32s(fbg_shared::layout::head(&p.envelope_lo, ne)),
        f32s(fbg_shared::layout::head(&p.envelope_hi, ne)),
        p.dims.gratings(),
        if p.dims.ambient() { ", T_amb °C" } else { "" }
    );
    let t = &p.trust;
    if t.rate_max.iter().any(|&r| r > 0.0) {
        println!(
            "trust: gate rate limits [{}] per s (×{} of these), fade beyond quiet times [{}] s, fallback band var [{}]",
            f32s(fbg_shared::layout::head(&t.rate_max, ne)),
            fbg_shared::trust::GATE_RATE_FACTOR,
            f32s(fbg_shared::layout::head(&t.quiet_max_s, p.dims.gratings())),
            f32s(fbg_shared::layout::head(&t.fallback_var, p.dims.n_outputs())),
        );
        println!(
            "trust: the calibration's pace, largest RMS swings [{}] (per input, its unit) and speeds [{}] (its unit per second): beyond either Model-H fades and the band widens",
            f32s(fbg_shared::layout::head(&t.swing_rms_max, ne)),
            f32s(fbg_shared::layout::head(&t.speed_rms_max, ne)),
        );
    }
    let f = &p.field;
    let zeros: Vec<String> = (0..p.dims.gratings())
        .map(|g| match f.lambda_ref(g) {
            Some(nm) => format!("dl{} {nm:.6} nm ({})", g + 1, f.lambda_ref_source[g].name()),
            None => format!("dl{} unknown", g + 1),
        })
        .collect();
    println!(
        "zero: λ_ref {}; a record's zero may differ by at most {} pm",
        zeros.join(", "),
        f32s(&[f.lambda_ref_tol_pm.into()])
    );
    println!(
        "clock: calibration ended {}; largest validated lead {:.1} h (the band's lead when a record's clock is unknown)",
        f.cal_end_unix_s.map_or(
            "at an unknown absolute time (calibrated on a record without absolute time)".to_string(),
            fbg_trainer::data::timestamp::format_utc
        ),
        f.lead_max_s / 3600.0
    );
    let pr = &p.provenance;
    println!(
        "provenance: scenario {}, seed {}, trainer {}, date {}, {} calibration samples",
        pr.scenario, pr.seed, pr.trainer_version, pr.date_yyyymmdd, pr.n_cal
    );
}

/// The model the calibration sheet comes from: Model-P (`fbg_trainer::fit::sensitivity`):
/// this blob when it is one, else `<stem>-p.fbgm` beside it, else this blob's own polynomial
/// core (Model-P's whenever the two share it, as `train` writes them); with where it came from.
fn sensitivity_source(path: &Path, p: &HostParams) -> (HostParams, String) {
    if export::is_model_p(p) {
        return (p.clone(), format!("{} (Model-P)", path.display()));
    }
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let sibling = path.with_file_name(format!("{stem}-p.fbgm"));
    match export::read_blob(&sibling) {
        Ok(mp) => (mp, format!("{} (Model-P beside this blob)", sibling.display())),
        Err(e) => (
            p.clone(),
            format!(
                "the polynomial core of {} ({}: {}; the core is Model-P's when train wrote both)",
                path.display(),
                sibling.display(),
                if sibling.exists() { e.to_string() } else { "not found".into() }
            ),
        ),
    }
}

/// The static gains `train` recorded in the blob's audit sidecar (`<stem>.coefficients.json`,
/// or for a Model-P blob `<stem>-p.fbgm` its Model-H's), which the blob itself does not carry.
fn static_fidelity_line(path: &Path) -> String {
    let mut candidates = vec![export::coefficients_path(path)];
    if let Some(stem) = path.file_stem().and_then(|s| s.to_str()).and_then(|s| s.strip_suffix("-p")) {
        candidates.push(export::coefficients_path(&path.with_file_name(format!("{stem}.fbgm"))));
    }
    for c in candidates {
        let Ok(text) = std::fs::read_to_string(&c) else { continue };
        let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else { continue };
        let sf = &v["static_fidelity"];
        let (Some(outs), Some(gp), Some(gh)) =
            (sf["outputs"].as_array(), sf["model_p_gain"].as_array(), sf["model_h_gain"].as_array())
        else {
            return format!("static gain: not recorded in {} (written before static fidelity)", c.display());
        };
        let fmt = |g: &[serde_json::Value]| -> String {
            outs.iter()
                .zip(g)
                .map(|(o, x)| {
                    format!(
                        "{} {}",
                        o.as_str().unwrap_or("?"),
                        x.as_f64().map(|x| format!("{x:.4}")).unwrap_or("–".into())
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        return format!(
            "static gain (truth on the settled reading over the calibration batch, 1 is right; from {}): Model-P {}; Model-H {}",
            c.display(),
            fmt(gp),
            fmt(gh)
        );
    }
    "static gain: no coefficients.json beside the blob (`train` writes it)".into()
}

/// Values stored as f32, printed at f32 precision: "0.1, 2.5, 7.757233e-3, 1.6360161e-7" (small
/// ones with an exponent, so no value runs to more digits than it holds).
fn f32s(v: &[f64]) -> String {
    let one = |x: f32| if x != 0.0 && (x.abs() < 1e-1 || x.abs() >= 1e7) { format!("{x:e}") } else { x.to_string() };
    v.iter().map(|&x| one(x as f32)).collect::<Vec<_>>().join(", ")
}
