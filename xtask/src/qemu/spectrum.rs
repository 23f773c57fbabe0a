//! Spectrum frames on the product image: simulated 512-pixel spectra of three gratings sent
//! through `fbg-link` in chunks; every estimate must equal the host's (`fbg-shared` f32 on the
//! same frames: the same detector, shifts and compensator) bit for bit, flags included.

use std::fs;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, ensure, Context, Result};
use fbg_link::spectrum::{synthetic_frame, FrameAnswer, GratingSpec, SpectrumLinkError, SpectrumSetup};
use fbg_shared::protocol::{DeviceMsg, HostMsg, SpectrumError};
use fbg_shared::spectrum::{Grid, Method, Window};
use fbg_shared::Compensator;

use super::memory::read_dataset_inputs;
use crate::firmware;
use crate::firmware::session::LinkSession;
use crate::fixtures::Fixtures;
use crate::targets::PRODUCT_K;

/// Readings sent (two channel frames each: gratings 1 and 2 on channel 0, grating 3 on 1).
const READINGS: usize = 120;
/// Peak height over the floor and noise σ \[counts\]: 30 dB (10·log₁₀ of 20 000 / 20).
const HEIGHT: f64 = 20_000.0;
const SIGMA: f64 = 20.0;
const FLOOR: f64 = 1_000.0;
/// The gratings' FWHM \[nm\].
const FWHM_NM: f64 = 0.3;

/// The set-up: a 512-pixel spectrometer over ≈ 1510–1595 nm (a slight quadratic term, as an
/// I-MON calibration has), ±2 nm windows about each λ_ref, 16-bit full scale, cross-correlation.
pub fn setup(lambda_ref: &[f64]) -> SpectrumSetup {
    SpectrumSetup {
        grid: Grid::polynomial([1510.0, 0.166, 2.0e-6, 0.0, 0.0, 0.0]),
        pixels: 512,
        method: Method::CrossCorrelation,
        full_scale: 65_535.0,
        gratings: lambda_ref
            .iter()
            .enumerate()
            .map(|(g, &r)| GratingSpec {
                channel: if g < 2 { 0 } else { 1 },
                window: Window::centred(r as f32, 2.0),
                lambda_ref_nm: r,
            })
            .collect(),
    }
}

/// The model's λ_ref per grating (a stand-in 1530 + 20·g nm where it does not know it).
pub fn lambda_refs(params: &fbg_shared::ModelParams<f32, PRODUCT_K>, n: usize) -> Vec<f64> {
    (0..n).map(|g| params.field.lambda_ref(g).unwrap_or(1530.0 + 20.0 * g as f64)).collect()
}

/// A few readings of spectrum frames for `cargo xtask size` on the product with spectrum
/// frames (its serving stack peak must cover the spectrum path): the set-up, then `n` readings of two channel frames each.
pub(crate) fn serve_readings(
    link: &mut fbg_link::LinkClient<std::net::TcpStream>,
    default: &[u8],
    n: usize,
) -> Result<()> {
    let params = fbg_shared::blob::decode::<PRODUCT_K>(default).map_err(|e| anyhow::anyhow!("default model: {e}"))?;
    let refs = lambda_refs(&params, 3);
    let s = setup(&refs);
    link.setup_spectrum(&s)?;
    for i in 0..n {
        let peak = |g: usize| (refs[g] + 0.01 * i as f64, FWHM_NM, HEIGHT);
        let f0 = synthetic_frame(&s.grid, s.pixels, &[peak(0), peak(1)], FLOOR, SIGMA, i as u64);
        let f1 = synthetic_frame(&s.grid, s.pixels, &[peak(2)], FLOOR, SIGMA, i as u64 + 1000);
        link.send_frame(i as u32, 0, 60.0 * i as f32, 20.0, &f0, 96)?;
        match link.send_frame(i as u32, 1, 60.0 * i as f32, 20.0, &f1, 96)? {
            FrameAnswer::Estimate(_) => {}
            other => bail!("spectrum reading {i}: {other:?}"),
        }
    }
    Ok(())
}

/// The test on `product`, the product image built with spectrum frames.
pub(super) fn spectrum_test(root: &Path, qemu: &Path, product: &Path, fx: &Fixtures) -> Result<()> {
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
    let params = fbg_shared::blob::decode::<PRODUCT_K>(&default).map_err(|e| anyhow::anyhow!("default model: {e}"))?;
    let refs = lambda_refs(&params, 3);
    let s = setup(&refs);
    let mut host = Box::new(Compensator::<f32, PRODUCT_K>::new(&params).map_err(|e| anyhow::anyhow!("{e}"))?);
    // The paper hold-out's own shifts, T_amb and clock: readings inside the model's envelope.
    let rows = read_dataset_inputs(&fx.data)?;
    ensure!(rows.len() >= READINGS, "{}: fewer than {READINGS} rows", fx.data.display());
    let rows = &rows[rows.len() - READINGS..];

    let mut sess = LinkSession::start(root, qemu, product, "spectrum")?;
    let link = sess.link()?;
    // The readings are the model's own record: lead on the calibration clock, on both sides.
    link.reset_stream(1, fbg_shared::StreamClock::Calibration)?;
    host.set_clock(fbg_shared::StreamClock::Calibration);
    link.setup_spectrum(&s).context("spectrum set-up")?;
    let started = Instant::now();
    let mut peak_err2 = 0.0f64;
    let mut flagged = 0usize;
    let mut flags_seen = fbg_shared::Flags::OK;
    for (i, r) in rows.iter().enumerate() {
        let peak = |g: usize| (refs[g] + f64::from(r.dl_pm[g]) / 1000.0, FWHM_NM, HEIGHT);
        let f0 = synthetic_frame(&s.grid, s.pixels, &[peak(0), peak(1)], FLOOR, SIGMA, 2 * i as u64);
        let f1 = synthetic_frame(&s.grid, s.pixels, &[peak(2)], FLOOR, SIGMA, 2 * i as u64 + 1);
        let seq = i as u32;
        let chunk = [96, 64, 37][i % 3];
        let a0 = link.send_frame(seq, 0, r.t_s, r.t_amb_c, &f0, chunk).with_context(|| format!("reading {i}"))?;
        ensure!(a0 == FrameAnswer::Pending, "reading {i}: the first channel's frame was answered with {a0:?}");
        let FrameAnswer::Estimate(d) =
            link.send_frame(seq, 1, r.t_s, r.t_amb_c, &f1, chunk).with_context(|| format!("reading {i}"))?
        else {
            bail!("reading {i}: no estimate after both channels' frames");
        };
        let (sample, _) = s.reading(&[&f0, &f1], r.t_amb_c, r.t_s);
        for g in 0..3 {
            peak_err2 += (f64::from(sample.dl_pm[g]) - f64::from(r.dl_pm[g])).powi(2);
        }
        let h = s.estimate(&mut host, &[&f0, &f1], r.t_amb_c, r.t_s);
        if !d.flags.is_ok() {
            flagged += 1;
            flags_seen.insert(d.flags);
        }
        ensure!(d.flags == h.flags, "reading {i}: device flags {} vs host {}", d.flags, h.flags);
        ensure!(usize::from(d.outputs) == usize::from(h.outputs), "reading {i}: output counts differ");
        for o in 0..usize::from(d.outputs) {
            ensure!(
                d.values[o].to_bits() == h.values[o].to_bits() && d.band[o].to_bits() == h.band95[o].to_bits(),
                "reading {i}, output {o}: device {} ± {} vs host f32 {} ± {} (not bit for bit)",
                d.values[o],
                d.band[o],
                h.values[o],
                h.band95[o]
            );
        }
    }
    let secs = started.elapsed().as_secs_f64();
    // A skipped chunk is refused and counted, and the device keeps serving.
    let begin = HostMsg::SpectrumBegin { seq: 0, channel: 0, t_s: 0.0, t_amb_c: 20.0 };
    ensure!(matches!(link.request(&begin)?, DeviceMsg::SpectrumAck { received: 0 }));
    match link.request(&HostMsg::SpectrumPixels { first_pixel: 96, data: &[0u8; 192] })? {
        DeviceMsg::SpectrumRefused(r) if r.reason == SpectrumError::OutOfOrder && r.detail == 0 => {}
        other => bail!("an out-of-order chunk was answered with {other:?}"),
    }
    // More pixels than the frame has: the chunk past its end is an overrun.
    match link.send_frame(0, 0, 0.0, 20.0, &[0u16; 600], 96) {
        Err(SpectrumLinkError::Refused(r)) if r.reason == SpectrumError::Overrun && r.detail == 576 => {}
        other => bail!("a frame of 600 pixels to a 512-pixel set-up: {other:?}"),
    }
    let st = link.status()?;
    link.ping(77)?;
    sess.disconnect()?;
    sess.check_alive()?;
    ensure!(st.spectra.frames == 2 * READINGS as u32, "{} whole frames counted", st.spectra.frames);
    ensure!(st.spectra.refused == 2, "{} refusals counted (an out-of-order chunk, an overrun)", st.spectra.refused);
    ensure!(st.samples == READINGS as u32, "{} samples counted", st.samples);
    let rms = (peak_err2 / (3 * READINGS) as f64).sqrt();
    eprintln!(
        "xtask: spectrum frames: {READINGS} readings of 2 × 512-pixel frames (3 gratings, 30 dB, cross-correlation) \
         in chunks of 96/64/37 pixels, {:.1} s; every estimate bit for bit the host's f32, flags identical \
         ({flagged} flagged: {flags_seen}); peak shifts vs the simulated truth: RMS {rms:.3} pm; refusals counted: {}",
        secs, st.spectra.refused
    );
    ensure!(rms < 3.0, "the peak chain's RMS error {rms:.3} pm exceeds 3 pm on the 512-pixel grid");
    Ok(())
}

/// The default product (built without spectrum frames) refuses them as `Unsupported`, counts
/// the refusal and keeps serving.
pub(super) fn unsupported_test(root: &Path, qemu: &Path, product: &Path) -> Result<()> {
    let mut sess = LinkSession::start(root, qemu, product, "spectrum-unsupported")?;
    let link = sess.link()?;
    let begin = HostMsg::SpectrumBegin { seq: 0, channel: 0, t_s: 0.0, t_amb_c: 20.0 };
    match link.request(&begin)? {
        DeviceMsg::SpectrumRefused(r) if r.reason == SpectrumError::Unsupported && r.detail == 0 => {}
        other => bail!("the default product answered a spectrum message with {other:?}"),
    }
    let st = link.status()?;
    link.ping(78)?;
    sess.disconnect()?;
    sess.check_alive()?;
    ensure!(
        st.spectra.refused == 1 && st.spectra.frames == 0,
        "the default product's spectrum counters: {:?}",
        st.spectra
    );
    eprintln!(
        "xtask: the default product (without spectrum frames) refused a spectrum message as Unsupported, counted it"
    );
    Ok(())
}
