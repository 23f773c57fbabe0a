//! Where Model-H may be trusted (DESIGN §4, the second rule), measured on the calibration
//! batch: each grating's noise, the play radii that noise alone cannot cross, and the
//! conditions the blob carries ([`fbg_shared::trust`]: rate limits, the largest quiet time,
//! Model-P's band to fade to, the calibration's pace).

use fbg_shared::compensator::SwingFilter;
use fbg_shared::layout::{MAX_ENVELOPE, MAX_GRATINGS, N_PLAYS};
use fbg_shared::TrustSpec;

use super::host::HostParams;
use super::memory_core::{walk_bank, MemoryOptions};
use crate::data::Dataset;

/// A play radius must be at least this many white-noise σ of the grating: noise alone then
/// does not push it across its dead band (2r = 10σ) during a hold of days.
pub const RADIUS_NOISE_FACTOR: f64 = 5.0;

/// Smallest play radius the menu starts from \[pm\] (the default menu's first radius).
pub const MIN_RADIUS_PM: f64 = 2.0;

/// White-noise σ \[pm\] of each grating's shift on the calibration rows `cal`: the robust
/// spread of second differences of consecutive rows (1.4826 · MAD / √6). Second differences
/// remove a level and a trend; a measurand that is rough from one sample to the next (a strain
/// grating's fast fluctuations) adds its roughness, so the figure is an upper bound of the
/// interrogator's noise — what a play radius must stand above either way. NaN for a grating
/// with fewer than 3 consecutive finite rows.
pub fn white_noise_pm(d: &Dataset, cal: &[usize]) -> Vec<f64> {
    let n = d.dl_pm.len();
    (0..n)
        .map(|g| {
            let x = &d.dl_pm[g];
            let mut d2: Vec<f64> = cal
                .windows(3)
                .filter(|w| w[1] == w[0] + 1 && w[2] == w[1] + 1)
                .map(|w| x[w[2]] - 2.0 * x[w[1]] + x[w[0]])
                .filter(|v| v.is_finite())
                .collect();
            if d2.is_empty() {
                return f64::NAN;
            }
            let med = crate::stats::median(&d2);
            for v in d2.iter_mut() {
                *v = (*v - med).abs();
            }
            1.4826 * crate::stats::median(&d2) / 6f64.sqrt()
        })
        .collect()
}

/// The memory menu with play radii no noise crosses: r₀ = max([`MIN_RADIUS_PM`],
/// [`RADIUS_NOISE_FACTOR`] · the largest grating σ), then 2r₀, 4r₀, … (one octave apart, as the
/// default menu). A menu without plays is returned as it is.
pub fn noise_floored(menu: &MemoryOptions, sigma_pm: &[f64]) -> MemoryOptions {
    let mut out = menu.clone();
    if !out.menu.play_half_width_pm.iter().any(|&r| r > 0.0) {
        return out;
    }
    let sigma = sigma_pm.iter().copied().filter(|s| s.is_finite()).fold(0.0, f64::max);
    let r0 = MIN_RADIUS_PM.max(RADIUS_NOISE_FACTOR * sigma);
    let mut r = r0;
    for slot in out.menu.play_half_width_pm.iter_mut().take(N_PLAYS) {
        *slot = r;
        r *= 2.0;
    }
    out
}

/// The trust spec of Model-H `h` (with Model-P `p` to fade to) from the calibration rows `cal`
/// of `d`: the largest |Δx|/Δt of each envelope input between consecutive calibration rows,
/// each grating's largest quiet time over the batch (the time since its narrowest play last
/// reversed, the bank run from the first row as the compensator runs it; 0 without play
/// operators), Model-P's band, and each envelope input's largest RMS swing and speed (the pace).
pub fn spec(h: &HostParams, p: &HostParams, d: &Dataset, cal: &[usize]) -> TrustSpec<f64> {
    let mut t = TrustSpec::off();
    let dims = &h.dims;
    let ne = dims.envelope_len().min(MAX_ENVELOPE);
    let input = |k: usize, i: usize| envelope_input(dims, d, k, i);
    for w in cal.windows(2) {
        let dt = d.t_s[w[1]] - d.t_s[w[0]];
        // A repeated or backward time stamp (or NaN) gives no rate.
        if dt.is_nan() || dt <= 0.0 {
            continue;
        }
        for (k, r) in t.rate_max.iter_mut().enumerate().take(ne) {
            let rate = (input(k, w[1]) - input(k, w[0])).abs() / dt;
            if rate.is_finite() && rate > *r {
                *r = rate;
            }
        }
    }
    if h.memory.play_half_width_pm.iter().any(|&r| r > 0.0) {
        t.quiet_max_s = quiet_max_s(h, d, cal);
    }
    let m = dims.n_outputs();
    for o in 0..m {
        let k2 = p.band_k[o] * p.band_k[o];
        t.fallback_var[o] = k2 * p.resid_var[o];
        t.fallback_var_growth[o] = k2 * p.resid_var_growth[o];
    }
    [t.swing_rms_max, t.speed_rms_max, t.swing_rms_min] = pace_extremes(dims, d, cal);
    t
}

/// Envelope input `k` of row `i` (Δλ_1..N \[pm\], then T_amb \[°C\]; NaN without an ambient
/// column).
fn envelope_input(dims: &fbg_shared::layout::Dims, d: &Dataset, k: usize, i: usize) -> f64 {
    if k < dims.gratings() {
        d.dl_pm[k][i]
    } else {
        d.t_amb_c.as_ref().map(|a| a[i]).unwrap_or(f64::NAN)
    }
}

/// The pace filters settle within this many pace windows of the first calibration row: the
/// smallest swing is taken after it (before, the power still grows from 0).
pub const PACE_SETTLE_WINDOWS: f64 = 3.0;

/// The calibration's pace ([`fbg_shared::trust`]): each envelope input's largest RMS swing
/// √P_max, largest RMS speed √Q_max and smallest RMS swing √P_min (once the filter has
/// settled; 0 when the batch is too short to tell) over the calibration rows `cal`, the filter
/// run over them as the device runs it over the samples its gate lets in.
fn pace_extremes(dims: &fbg_shared::layout::Dims, d: &Dataset, cal: &[usize]) -> [[f64; MAX_ENVELOPE]; 3] {
    let ne = dims.envelope_len().min(MAX_ENVELOPE);
    let mut filter = SwingFilter::<f64>::new();
    let mut last_t = f64::NAN;
    let (mut p_max, mut q_max) = ([0.0f64; MAX_ENVELOPE], [0.0f64; MAX_ENVELOPE]);
    let mut p_min = [f64::INFINITY; MAX_ENVELOPE];
    let mut t_first = f64::NAN;
    let settle_s = PACE_SETTLE_WINDOWS * fbg_shared::compensator::PACE_WINDOW_S;
    for &i in cal {
        let mut x = [0.0; MAX_ENVELOPE];
        for (k, v) in x.iter_mut().enumerate().take(ne) {
            *v = envelope_input(dims, d, k, i);
        }
        let t_s = d.t_s[i];
        if !x.iter().take(ne).all(|v| v.is_finite()) || !t_s.is_finite() {
            continue;
        }
        filter.update(&x, ne, t_s - last_t);
        last_t = t_s;
        if t_first.is_nan() {
            t_first = t_s;
        }
        let settled = t_s - t_first >= settle_s;
        for (k, ((p, q), lo)) in p_max.iter_mut().zip(q_max.iter_mut()).zip(p_min.iter_mut()).enumerate().take(ne) {
            *p = p.max(filter.power(k));
            *q = q.max(filter.speed_power(k));
            if settled {
                *lo = lo.min(filter.power(k));
            }
        }
    }
    let p_min = p_min.map(|v| if v.is_finite() { v.sqrt() } else { 0.0 });
    [p_max.map(f64::sqrt), q_max.map(f64::sqrt), p_min]
}

/// The largest quiet time \[s\] of each grating of `h`'s memory over the calibration rows
/// `cal`.
fn quiet_max_s(h: &HostParams, d: &Dataset, cal: &[usize]) -> [f64; MAX_GRATINGS] {
    let mut q_max = [0.0f64; MAX_GRATINGS];
    walk_bank(&h.memory, &h.dims, d, cal, |bank, m, t_s| {
        if m.is_some() {
            let st = bank.state();
            for (g, q) in q_max.iter_mut().enumerate().take(h.dims.gratings()) {
                *q = q.max(st.quiet_s(g, t_s));
            }
        }
    });
    q_max
}
