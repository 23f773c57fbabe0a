//! The page's reference material: the calibration sheet (sensitivities), every coefficient
//! of both models, and the device arithmetic against the f64 reference.

use super::{Page, Section};
use crate::report::figures::{count, num};
use crate::report::html;

/// The sensitivities (the calibration sheet), then the coefficients.
pub(super) fn coefficients(p: &Page, sections: &mut Vec<Section>) {
    let coefs = p.coefs;
    let is_sens = |n: &str| n.starts_with("sensitivity");
    let mut body = String::from(
        "<p>Each grating's sensitivity to each measurand and the model's inverse, as a calibration sheet gives them (fbg_trainer::fit::sensitivity; also in model.coefficients.json and <code>fbg-trainer inspect</code>).</p>\n",
    );
    for (name, t) in coefs.iter().filter(|(n, _)| is_sens(n)) {
        body.push_str(&html::table(t, Some(name)));
    }
    sections.push(Section { id: "sensitivity".into(), title: "Sensitivities at the calibration point".into(), body });
    let mut body = String::from(
        "<p>Every number the device uses, read back from the model blobs (f32 on disk, shown in f64). The polynomial core is also given in physical units, the form a metrologist can check against gauge factors or replace after service.</p>\n",
    );
    for (name, t) in coefs.iter().filter(|(n, _)| !is_sens(n)) {
        body.push_str(&html::table(t, Some(name)));
    }
    sections.push(Section { id: "coefficients".into(), title: "Coefficients".into(), body });
}

/// The f32 device path against the f64 reference, when metrics.json has the comparison.
pub(super) fn device(p: &Page, sections: &mut Vec<Section>) {
    let m = &p.inp.metrics;
    if let Some(p) = &m.parity {
        let rows: Vec<(String, String)> = vec![
            ("hold-out samples compared".into(), count(p.samples)),
            (
                format!(
                    "max |f32 − f64| ({})",
                    m.channels.iter().map(|c| c.replacen("strain", "ε", 1)).collect::<Vec<_>>().join(", ")
                ),
                p.max_abs_diff.iter().zip(&m.units).map(|(v, u)| format!("{v:.3e} {u}")).collect::<Vec<_>>().join(", "),
            ),
            (
                "as a share of Model-H's RMSE".into(),
                p.max_diff_over_rmse.iter().map(|v| format!("{} %", num(100.0 * v, 4))).collect::<Vec<_>>().join(", "),
            ),
            (
                "max relative band difference".into(),
                p.max_band_rel_diff.iter().map(|v| format!("{v:.2e}")).collect::<Vec<_>>().join(", "),
            ),
            ("flag mismatches".into(), p.flag_mismatches.to_string()),
            (
                "leverage band gap (kept eigen-directions vs exact)".into(),
                format!("{:.3e} (largest exact leverage {:.3e})", p.leverage_band_gap, p.leverage_max),
            ),
        ];
        sections.push(Section {
            id: "device".into(),
            title: "Device arithmetic (f32) against the f64 reference".into(),
            body: html::facts(&rows),
        });
    }
}
