//! `fbg-trainer inspect`: a blob's header, dimensions, hyper-parameters and provenance.

use std::path::Path;

use anyhow::{bail, Context, Result};

use fbg_shared::blob;
use fbg_trainer::export;
use fbg_trainer::fit::HostParams;
use fbg_trainer::sign;

/// `fbg-trainer inspect`.
pub fn run(path: &Path, pubkey: Option<&Path>, json: bool) -> Result<()> {
    let file = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    // The whole blob (CRC first) before the header, so corruption is named as such.
    let p: HostParams = export::read_blob(path)?;
    let bytes = fbg_shared::container::strip(&file);
    let header = blob::Header::parse(bytes)
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), export::blob_error_text(bytes, &e)))?;
    let crc = export::blob_crc(bytes).map(|(c, _)| format!("{c:08x}")).unwrap_or_default();
    let key = pubkey.map(sign::read_public_key).transpose()?;
    let check = sign::check(&file, key.as_ref());
    let (sens_model, sens_source) = sensitivity_source(path, &p);
    let mut sensitivity = export::sensitivity_json(&sens_model);
    if let Some(o) = sensitivity.as_object_mut() {
        o.insert("source".into(), serde_json::json!(sens_source));
    }
    let v = serde_json::json!({
        "file": path,
        "bytes": file.len(),
        "blob_bytes": bytes.len(),
        "crc32": crc,
        "header": {"magic": "FBGM", "format_version": header.version, "gratings": header.gratings,
                   "ambient": header.ambient == 1, "measurands": header.measurands, "poly_terms": header.poly_terms,
                   "memory_terms": header.memory_terms, "centres": header.centres},
        "signature": check,
        "model": export::model_json(&p, None),
        "sensitivity": sensitivity,
    });
    let refuse = |check: &sign::SignatureCheck| -> Result<()> {
        match (check.verifies, pubkey) {
            (Some(false), Some(k)) => bail!(
                "{}: the signature does not verify with {}: {}",
                path.display(),
                k.display(),
                check.problem.as_deref().unwrap_or("unknown reason")
            ),
            _ => Ok(()),
        }
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&v)?);
        return refuse(&check);
    }
    let h = &p.hyper;
    println!("{}: {} bytes, FBGM format v{}, CRC-32 {crc} (valid)", path.display(), bytes.len(), header.version);
    match (&check.record, check.verifies) {
        (None, _) if !check.signed => println!("signature: none (unsigned: valid on the host, refused by a device)"),
        (None, _) => println!("signature: malformed trailer ({})", check.problem.as_deref().unwrap_or("")),
        (Some(r), v) => println!(
            "signature: key id {}, serial {}{}; {}",
            r.key_id,
            r.serial,
            r.rollback_text(),
            match (v, pubkey) {
                (Some(true), Some(k)) =>
                    format!("verifies with {} (key id {})", k.display(), check.checked_key_id.as_deref().unwrap_or("")),
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
            fbg_trainer::data::import::time_axis::format_utc
        ),
        f.lead_max_s / 3600.0
    );
    let pr = &p.provenance;
    println!(
        "provenance: scenario {}, seed {}, trainer {}, date {}, {} calibration samples",
        pr.scenario, pr.seed, pr.trainer_version, pr.date_yyyymmdd, pr.n_cal
    );
    println!("{}", static_fidelity_line(path));
    println!("sensitivities from {sens_source}:");
    for (_, t) in fbg_trainer::report::coef::sensitivity_tables(&sens_model) {
        print!("{}", t.text());
    }
    refuse(&check)
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

/// Values stored as f32, printed at f32 precision: "0.1, 2.5, 1.6360161e-7".
fn f32s(v: &[f64]) -> String {
    let one = |x: f32| if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e7) { format!("{x:e}") } else { x.to_string() };
    v.iter().map(|&x| one(x as f32)).collect::<Vec<_>>().join(", ")
}
