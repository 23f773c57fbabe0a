//! The page's provenance: where the data, the models and the metrics come from, and the
//! scenario that generated the data when data.meta.json is there.

use super::{date, Page, Section};
use crate::export;
use crate::report::figures::{count, num};
use crate::report::html::{self, esc};
use crate::sim::scenario::ScenarioConfig;

/// The provenance facts, then the scenario (its main parameters and all of it as TOML).
pub(super) fn section(p: &Page) -> Section {
    let mut body = html::facts(&record_facts(p));
    if let Some(meta) = &p.inp.meta {
        let s = &meta.scenario;
        body.push_str("<h3>Scenario</h3>\n");
        body.push_str(&html::facts(&scenario_facts(s)));
        let toml = toml::to_string(s).unwrap_or_else(|e| format!("(cannot serialise the scenario: {e})"));
        body.push_str(&format!("<details><summary>Every scenario parameter (TOML, usable with <code>--config</code>)</summary><pre>{}</pre></details>\n", esc(&toml)));
    }
    Section { id: "provenance".into(), title: "Provenance and scenario".into(), body }
}

/// Scenario, seed, sample counts, versions, dates, blob sizes, the sidecar's state and the
/// recorded wall times.
fn record_facts(p: &Page) -> Vec<(String, String)> {
    let (inp, m, d, resimulated, today) = (p.inp, &p.inp.metrics, &p.inp.data, p.resimulated, p.today);
    let pr = &inp.model_h.provenance;
    let dt = d.t_s[1] - d.t_s[0];
    let mut rows: Vec<(String, String)> = vec![
        ("scenario (preset or TOML name)".into(), m.scenario.clone()),
        ("seed".into(), m.seed.to_string()),
        (
            "samples (calibration / hold-out)".into(),
            format!("{} ({} / {})", count(d.len()), count(d.cal_indices().len()), count(d.holdout_indices().len())),
        ),
        (
            "record".into(),
            format!("{} s sampling, {} days", num(dt, 3), num((d.t_s[d.len() - 1] - d.t_s[0]) / 86_400.0, 2)),
        ),
        (
            "trainer version (metrics.json / model.fbgm / this report)".into(),
            format!("{} / {} / {}", m.trainer_version, pr.trainer_version, env!("CARGO_PKG_VERSION")),
        ),
        ("models trained on".into(), date(pr.date_yyyymmdd)),
        ("calibration samples recorded in the model".into(), count(pr.n_cal as usize)),
        (
            "model blobs".into(),
            format!(
                "model.fbgm {} B ({} centres), model-p.fbgm {} B",
                export::blob_bytes(&inp.model_h).map(|b| b.len()).unwrap_or(0),
                inp.model_h.centres.len(),
                export::blob_bytes(&inp.model_p).map(|b| b.len()).unwrap_or(0)
            ),
        ),
        ("report generated".into(), date(today)),
        (
            "data.meta.json".into(),
            match (&inp.meta, resimulated) {
                (None, _) => "absent".into(),
                (Some(_), true) => "present; data.csv matches its re-simulation".into(),
                (Some(_), false) => "present; data.csv does NOT match its re-simulation".into(),
            },
        ),
    ];
    for (k, v) in &m.timings_s {
        rows.push((format!("wall time of `{k}` [s]"), num(*v, 1)));
    }
    rows
}

/// The scenario's clock, trajectories and artefacts, one row each.
fn scenario_facts(s: &ScenarioConfig) -> Vec<(String, String)> {
    let on = |b: bool| if b { "on" } else { "off" };
    let mut srows: Vec<(String, String)> = vec![
        (
            "clock".into(),
            format!(
                "{} days at {} s, calibration fraction {}",
                num(s.clock.days, 2),
                num(s.clock.dt_s, 1),
                num(s.clock.cal_fraction, 2)
            ),
        ),
        (
            "temperature".into(),
            format!(
                "mean {} °C, diurnal ±{} °C, weekly ±{} °C, seasonal ±{} °C, AR σ {} °C",
                num(s.temperature.mean_c, 1),
                num(s.temperature.diurnal_amp_c, 1),
                num(s.temperature.weekly_amp_c, 1),
                num(s.temperature.seasonal_amp_c, 1),
                num(s.temperature.ar_sigma_c, 2)
            ),
        ),
    ];
    // Only the measurands the scenario has (a one-output record names no strain or pressure).
    let has = |k: crate::data::Kind| s.measurands.iter().any(|m| m.kind == k);
    if has(crate::data::Kind::Strain) {
        srows.push((
            "strain".into(),
            format!(
                "levels {} … {} µε held {} s, sines ±{} / ±{} µε, AR σ {} µε",
                num(s.strain.level_lo_ue, 0),
                num(s.strain.level_hi_ue, 0),
                num(s.strain.hold_s, 0),
                num(s.strain.sine1_amp_ue, 0),
                num(s.strain.sine2_amp_ue, 0),
                num(s.strain.ar_sigma_ue, 1)
            ),
        ));
    }
    if has(crate::data::Kind::Pressure) {
        srows.push((
            "pressure".into(),
            format!(
                "mean {} kPa, sines ±{} / ±{} kPa, AR σ {} kPa",
                num(s.pressure.mean_kpa, 0),
                num(s.pressure.sine1_amp_kpa, 1),
                num(s.pressure.sine2_amp_kpa, 1),
                num(s.pressure.ar_sigma_kpa, 2)
            ),
        ));
    }
    srows.extend([
        (
            "hysteresis (Eq. 9 + play)".into(),
            format!(
                "{}: β {}, γ {}, ρ {}, play ±{} pm",
                on(s.hysteresis.enabled),
                s.hysteresis.beta,
                s.hysteresis.gamma,
                s.hysteresis.rho,
                s.hysteresis.play_half_width_pm
            ),
        ),
        (
            "scan nonlinearity".into(),
            format!(
                "{}: ripple {} pm per {} nm, bow {} pm",
                on(s.scan.enabled),
                s.scan.ripple_amp_pm,
                s.scan.ripple_period_nm,
                s.scan.bow_pm
            ),
        ),
        (
            "drift (Eq. 8)".into(),
            format!(
                "{}: σ_d {} pm per step, channel gains {:?}",
                on(s.drift.enabled),
                s.drift.sigma_pm,
                s.drift.channel_gain
            ),
        ),
        (
            "electronics drift".into(),
            format!(
                "{}: {} pm/°C, {} pm/°C²",
                on(s.electronics.enabled),
                s.electronics.lin_pm_per_c,
                s.electronics.quad_pm_per_c2
            ),
        ),
        (
            "noise".into(),
            format!(
                "{}: pink σ {} pm, white σ {} pm",
                on(s.noise.enabled),
                s.noise.pink_sigma_pm,
                s.noise.white_sigma_pm
            ),
        ),
    ]);
    srows
}
