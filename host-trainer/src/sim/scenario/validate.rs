//! The ranges and shapes a scenario must keep: the first problem found, named by its key.

use super::{Pace, ScenarioConfig, Strain, MAX_NAME_LEN, SIMULATED};
use crate::data::measurand::{MAX_GRATINGS, MAX_MEASURANDS};

impl ScenarioConfig {
    /// Check ranges and shapes; the error is (key path, message) of the first problem, in the
    /// order of the sections below.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let mut v = Checker::default();
        self.check_clock(&mut v);
        self.check_trajectories(&mut v);
        self.check_shape(&mut v);
        self.check_gratings(&mut v);
        self.check_instrument(&mut v);
        self.check_pace_and_name(&mut v);
        v.result()
    }

    /// The clock, the recording gaps and the steps part.
    fn check_clock(&self, v: &mut Checker) {
        let c = &self.clock;
        v.range("clock.days", c.days, 1.0 / 24.0, 3650.0);
        v.range("clock.dt_s", c.dt_s, 1e-3, 86_400.0);
        v.range("clock.cal_fraction", c.cal_fraction, 0.05, 0.95);
        v.nonneg("clock.jitter_s", c.jitter_s, 1e4);
        v.nonneg("clock.gaps_per_day", c.gaps_per_day, 1e3);
        v.nonneg("clock.gap_mean_s", c.gap_mean_s, 10.0 * 86_400.0);
        // Expected fraction of the record inside gaps (a renewal process of gaps and runs).
        let gap_days = c.gaps_per_day * c.gap_mean_s / 86_400.0;
        if v.ok() && gap_days / (1.0 + gap_days) > 0.5 {
            v.fail("clock.gap_mean_s", "the gaps would drop more than half of the record on average");
        }
        let st = &self.steps;
        if !(5..=1000).contains(&st.levels) {
            v.fail("steps.levels", &format!("{} is out of range [5, 1000]", st.levels));
        }
        // A hold needs samples only when the steps part is simulated.
        v.range("steps.hold_s", st.hold_s, if st.enabled { 4.0 * c.dt_s } else { 1e-3 }, 1e8);
        v.range("steps.ramp_s", st.ramp_s, 0.0, 0.25 * st.hold_s);
        let pl = &self.plateaus;
        v.range("plateaus.hold_min_s", pl.hold_min_s, if pl.enabled { 4.0 * c.dt_s } else { 1e-3 }, 1e8);
        v.range("plateaus.hold_max_s", pl.hold_max_s, pl.hold_min_s, 1e8);
        v.range("plateaus.ramp_s", pl.ramp_s, 0.0, 0.25 * pl.hold_min_s);
        if pl.enabled && st.enabled {
            v.fail("plateaus.enabled", "a record has either the steps or the plateau hold-out, not both");
        }
        if v.ok() && self.n_native_samples() < 100 {
            v.fail("clock.days", "fewer than 100 samples: increase days or decrease dt_s");
        }
        if v.ok() && self.n_native_samples() > 50_000_000 {
            v.fail("clock.days", "more than 5e7 samples");
        }
        if v.ok() && self.n_samples() > 50_000_000 {
            v.fail("steps.hold_s", "the steps part makes the record more than 5e7 samples");
        }
    }

    /// The measurands' trajectories.
    fn check_trajectories(&self, v: &mut Checker) {
        let t = &self.temperature;
        v.range("temperature.mean_c", t.mean_c, -100.0, 300.0);
        v.nonneg("temperature.diurnal_amp_c", t.diurnal_amp_c, 100.0);
        v.finite("temperature.diurnal_phase_rad", t.diurnal_phase_rad);
        v.nonneg("temperature.weekly_amp_c", t.weekly_amp_c, 100.0);
        v.finite("temperature.weekly_phase_rad", t.weekly_phase_rad);
        v.nonneg("temperature.seasonal_amp_c", t.seasonal_amp_c, 100.0);
        v.range("temperature.seasonal_period_days", t.seasonal_period_days, 0.1, 10_000.0);
        v.finite("temperature.seasonal_phase_rad", t.seasonal_phase_rad);
        v.nonneg("temperature.ar_sigma_c", t.ar_sigma_c, 50.0);
        v.range("temperature.ar_tau_s", t.ar_tau_s, 1e-3, 1e8);
        validate_strain(v, "strain", &self.strain);
        let p = &self.pressure;
        v.range("pressure.mean_kpa", p.mean_kpa, 0.0, 1e5);
        v.nonneg("pressure.sine1_amp_kpa", p.sine1_amp_kpa, 1e5);
        v.range("pressure.sine1_period_s", p.sine1_period_s, 1e-3, 1e9);
        v.nonneg("pressure.sine2_amp_kpa", p.sine2_amp_kpa, 1e5);
        v.range("pressure.sine2_period_s", p.sine2_period_s, 1e-3, 1e9);
        v.nonneg("pressure.ar_sigma_kpa", p.ar_sigma_kpa, 1e5);
        v.range("pressure.ar_tau_s", p.ar_tau_s, 1e-3, 1e8);
        if let Some(s) = &self.strain2 {
            validate_strain(v, "strain2", s);
        }
    }

    /// The measurands, the number of gratings and the length of every per-grating list.
    fn check_shape(&self, v: &mut Checker) {
        let m = &self.measurands;
        if m.is_empty() || m.len() > MAX_MEASURANDS {
            v.fail("measurands", &format!("{} measurands; 1 to {MAX_MEASURANDS} are simulated", m.len()));
        }
        for (i, x) in m.iter().enumerate() {
            if m[..i].contains(x) {
                v.fail("measurands", &format!("`{x}` is listed twice"));
            }
            if !SIMULATED.contains(x) {
                let names: Vec<String> = SIMULATED.iter().map(|m| m.column()).collect();
                v.fail("measurands", &format!("`{x}` is not simulated; the simulator has {}", names.join(", ")));
            }
        }
        let n_g = self.n_gratings();
        if n_g == 0 || n_g > MAX_GRATINGS {
            v.fail("gratings.nominal_nm", &format!("{n_g} gratings; 1 to {MAX_GRATINGS} are simulated"));
        }
        if v.ok() && n_g < m.len() {
            v.fail("gratings.nominal_nm", &format!("{n_g} gratings cannot resolve {} measurands", m.len()));
        }
        let per_grating = |v: &mut Checker, key: &str, len: usize, empty_ok: bool| {
            if len != n_g && !(empty_ok && len == 0) {
                let also = if empty_ok { " (or none)" } else { "" };
                v.fail(
                    key,
                    &format!("{len} entries; one per grating ({n_g}, the length of gratings.nominal_nm){also}"),
                );
            }
        };
        let g = &self.gratings;
        per_grating(v, "gratings.gauge", g.gauge.len(), false);
        for (i, row) in g.gauge.iter().enumerate() {
            if row.len() != m.len() {
                v.fail(
                    &format!("gratings.gauge[{i}]"),
                    &format!("{} entries; one per measurand ({}: {})", row.len(), m.len(), {
                        let names: Vec<String> = m.iter().map(|x| x.column()).collect();
                        names.join(", ")
                    }),
                );
            }
        }
        for (name, arr, needs) in g.cross_terms() {
            per_grating(v, &format!("gratings.{name}"), arr.len(), true);
            if arr.iter().any(|&c| c != 0.0) {
                if let Some(x) = needs.iter().find(|x| !m.contains(x)) {
                    v.fail(
                        &format!("gratings.{name}"),
                        &format!("a cross-term on `{x}`, which is not among the measurands"),
                    );
                }
            }
        }
        per_grating(v, "scan.ripple_phase_rad", self.scan.ripple_phase_rad.len(), false);
        per_grating(v, "gratings.thermal_lag_s", g.thermal_lag_s.len(), true);
        per_grating(v, "ageing.creep_fraction", self.ageing.creep_fraction.len(), true);
        per_grating(v, "ageing.drift_pm_per_day", self.ageing.drift_pm_per_day.len(), true);
        per_grating(v, "drift.channel_gain", self.drift.channel_gain.len(), false);
    }

    /// The ambient thermometer, the gratings' values and ageing, and the gauge matrix's
    /// conditioning.
    fn check_gratings(&self, v: &mut Checker) {
        let (m, n_g, g) = (&self.measurands, self.n_gratings(), &self.gratings);
        let a = &self.ambient;
        v.range("ambient.lag_tau_s", a.lag_tau_s, 0.0, 1e8);
        v.range("ambient.offset_c", a.offset_c, -50.0, 50.0);
        v.nonneg("ambient.noise_sigma_c", a.noise_sigma_c, 50.0);
        v.nonneg("ambient.resolution_c", a.resolution_c, 10.0);
        for (i, nm) in g.nominal_nm.iter().enumerate() {
            v.range(&format!("gratings.nominal_nm[{i}]"), *nm, 400.0, 2500.0);
        }
        for (i, row) in g.gauge.iter().enumerate() {
            for (j, k) in row.iter().enumerate() {
                v.range(&format!("gratings.gauge[{i}][{j}]"), *k, -1e3, 1e3);
            }
        }
        v.nonneg("gratings.dispersion", g.dispersion, 0.5);
        for (name, arr, _) in g.cross_terms() {
            for (i, c) in arr.iter().enumerate() {
                v.range(&format!("gratings.{name}[{i}]"), *c, -10.0, 10.0);
            }
        }
        v.range("gratings.ref_t_c", g.ref_t_c, -100.0, 300.0);
        v.range("gratings.ref_strain_ue", g.ref_strain_ue, -1e4, 1e4);
        v.range("gratings.ref_p_kpa", g.ref_p_kpa, 0.0, 1e5);
        for (i, tau) in g.thermal_lag_s.iter().enumerate() {
            v.range(&format!("gratings.thermal_lag_s[{i}]"), *tau, 0.0, 1e8);
        }
        let ag = &self.ageing;
        for (i, f) in ag.creep_fraction.iter().enumerate() {
            v.range(&format!("ageing.creep_fraction[{i}]"), *f, 0.0, 0.5);
        }
        v.range("ageing.creep_tau_s", ag.creep_tau_s, 1e-3, 1e10);
        for (i, r) in ag.drift_pm_per_day.iter().enumerate() {
            v.range(&format!("ageing.drift_pm_per_day[{i}]"), *r, -100.0, 100.0);
        }
        v.range("ageing.ageing_tau_days", ag.ageing_tau_days, 1e-3, 1e6);
        if v.ok() {
            let k = nalgebra::DMatrix::from_fn(n_g, m.len(), |i, j| g.gauge[i][j]);
            let svd = k.svd(false, false);
            let (mx, mn) = (svd.singular_values.max(), svd.singular_values.min());
            if !(mn > 0.0 && mx / mn < 1e6) {
                v.fail("gratings.gauge", "gauge matrix is singular or too ill-conditioned to invert");
            }
        }
    }

    /// The interrogator: hysteresis, scan, drift, electronics and noise.
    fn check_instrument(&self, v: &mut Checker) {
        let h = &self.hysteresis;
        v.range("hysteresis.beta", h.beta, 0.0, 2.0);
        v.range("hysteresis.gamma", h.gamma, -1.0, 1.0);
        v.range("hysteresis.rho", h.rho, -1.0, 1.0);
        v.nonneg("hysteresis.play_half_width_pm", h.play_half_width_pm, 1e3);
        let bw = &h.bouc_wen;
        v.range("hysteresis.bouc_wen.a", bw.a, 1e-6, 10.0);
        v.range("hysteresis.bouc_wen.beta", bw.beta, 1e-9, 1e3);
        v.range("hysteresis.bouc_wen.gamma", bw.gamma, -bw.beta.abs(), bw.beta.abs());
        v.range("hysteresis.bouc_wen.n", bw.n, 1.0, 10.0);
        let pr = &h.preisach;
        v.nonneg("hysteresis.preisach.loop_width_pm", pr.loop_width_pm, 1e3);
        v.range("hysteresis.preisach.lo_pm", pr.lo_pm, -1e5, 1e5);
        v.range("hysteresis.preisach.hi_pm", pr.hi_pm, -1e5, 1e5);
        if v.ok() && pr.hi_pm <= pr.lo_pm {
            v.fail("hysteresis.preisach.hi_pm", "must be above hysteresis.preisach.lo_pm");
        }
        if !(2..=200).contains(&pr.cells) {
            v.fail("hysteresis.preisach.cells", &format!("{} is out of range [2, 200]", pr.cells));
        }
        v.range("hysteresis.preisach.sigma_pm", pr.sigma_pm, 1e-6, 1e5);
        let sc = &self.scan;
        v.nonneg("scan.ripple_amp_pm", sc.ripple_amp_pm, 1e3);
        v.range("scan.ripple_period_nm", sc.ripple_period_nm, 1e-3, 1e3);
        for (i, ph) in sc.ripple_phase_rad.iter().enumerate() {
            v.finite(&format!("scan.ripple_phase_rad[{i}]"), *ph);
        }
        v.range("scan.bow_pm", sc.bow_pm, -1e3, 1e3);
        v.range("scan.bow_half_span_nm", sc.bow_half_span_nm, 1e-3, 1e3);
        v.range("scan.bow_centre_nm", sc.bow_centre_nm, 400.0, 2500.0);
        let d = &self.drift;
        v.nonneg("drift.sigma_pm", d.sigma_pm, 100.0);
        for (i, gn) in d.channel_gain.iter().enumerate() {
            v.range(&format!("drift.channel_gain[{i}]"), *gn, -10.0, 10.0);
        }
        let e = &self.electronics;
        v.range("electronics.lin_pm_per_c", e.lin_pm_per_c, -100.0, 100.0);
        v.range("electronics.quad_pm_per_c2", e.quad_pm_per_c2, -10.0, 10.0);
        v.range("electronics.ref_c", e.ref_c, -100.0, 300.0);
        let n = &self.noise;
        v.nonneg("noise.pink_sigma_pm", n.pink_sigma_pm, 1e3);
        v.nonneg("noise.white_sigma_pm", n.white_sigma_pm, 1e3);
        if !(1..=40).contains(&n.pink_octaves) {
            v.fail("noise.pink_octaves", "must be in 1..=40");
        }
    }

    /// The pace and the scenario's name.
    fn check_pace_and_name(&self, v: &mut Checker) {
        let m = &self.measurands;
        let pc = &self.pace;
        v.range("pace.factor", pc.factor, Pace::FACTOR_MIN, Pace::FACTOR_MAX);
        if let Some(o) = pc.only {
            if !m.contains(&o) {
                let names: Vec<String> = m.iter().map(|x| x.column()).collect();
                v.fail("pace.only", &format!("`{o}` is not among the measurands ({})", names.join(", ")));
            }
        }
        if self.name.is_empty() || self.name.len() > MAX_NAME_LEN {
            v.fail("name", "must be 1 to 24 characters");
        }
    }
}

/// The checks of one strain trajectory (`strain` or `strain2`), its keys under `table`.
fn validate_strain(v: &mut Checker, table: &str, s: &Strain) {
    let key = |field: &str| format!("{table}.{field}");
    v.range(&key("level_lo_ue"), s.level_lo_ue, -1e4, 1e4);
    v.range(&key("level_hi_ue"), s.level_hi_ue, -1e4, 1e4);
    if s.level_hi_ue < s.level_lo_ue {
        v.fail(&key("level_hi_ue"), &format!("must be >= {}", key("level_lo_ue")));
    }
    v.range(&key("hold_s"), s.hold_s, 1e-3, 1e8);
    v.range(&key("ramp_s"), s.ramp_s, 0.0, 1e8);
    if s.ramp_s > s.hold_s {
        v.fail(&key("ramp_s"), &format!("must not exceed {}", key("hold_s")));
    }
    v.nonneg(&key("sine1_amp_ue"), s.sine1_amp_ue, 1e4);
    v.range(&key("sine1_period_s"), s.sine1_period_s, 1e-3, 1e9);
    v.nonneg(&key("sine2_amp_ue"), s.sine2_amp_ue, 1e4);
    v.range(&key("sine2_period_s"), s.sine2_period_s, 1e-3, 1e9);
    v.nonneg(&key("ar_sigma_ue"), s.ar_sigma_ue, 1e4);
    v.range(&key("ar_tau_s"), s.ar_tau_s, 1e-3, 1e8);
}

#[derive(Default)]
struct Checker {
    first: Option<(String, String)>,
}

impl Checker {
    fn ok(&self) -> bool {
        self.first.is_none()
    }
    fn fail(&mut self, key: &str, msg: &str) {
        if self.first.is_none() {
            self.first = Some((key.to_string(), msg.to_string()));
        }
    }
    fn finite(&mut self, key: &str, x: f64) {
        if !x.is_finite() {
            self.fail(key, "must be a finite number");
        }
    }
    fn range(&mut self, key: &str, x: f64, lo: f64, hi: f64) {
        if !(x.is_finite() && x >= lo && x <= hi) {
            self.fail(key, &format!("{} is out of range [{lo}, {hi}]", crate::error::ShortNumber(x)));
        }
    }
    fn nonneg(&mut self, key: &str, x: f64, hi: f64) {
        self.range(key, x, 0.0, hi)
    }
    fn result(self) -> Result<(), (String, String)> {
        match self.first {
            None => Ok(()),
            Some(e) => Err(e),
        }
    }
}
