//! Spectrum frames: set-up, frames in chunks, refusals counted, readings answered exactly as
//! the host's `fbg-shared` f32 forms and compensates them.

use fbg_link::spectrum::{synthetic_frame, FrameAnswer, GratingSpec, SpectrumLinkError, SpectrumSetup};
use fbg_shared::protocol::{SpectrumError, SpectrumRefusal};
use fbg_shared::spectrum::{Grid, Method, Window};

use super::*;

/// The model's λ_ref of grating `g`, or a stand-in for a model that does not know it.
fn lambda_ref(g: usize) -> f64 {
    params(default_blob()).field.lambda_ref(g).unwrap_or(1530.0 + 20.0 * g as f64)
}

/// A 512-pixel spectrometer over ≈ 1510–1595 nm (a slight quadratic term), three gratings:
/// the first two on channel 0, the third on channel 1, ±2 nm windows about λ_ref.
fn setup() -> SpectrumSetup {
    SpectrumSetup {
        grid: Grid::polynomial([1510.0, 0.166, 2.0e-6, 0.0, 0.0, 0.0]),
        pixels: 512,
        method: Method::CrossCorrelation,
        full_scale: 65_535.0,
        gratings: (0..3)
            .map(|g| GratingSpec {
                channel: if g < 2 { 0 } else { 1 },
                window: Window::centred(lambda_ref(g) as f32, 2.0),
                lambda_ref_nm: lambda_ref(g),
            })
            .collect(),
    }
}

/// The two channels' frames of reading `i`: each grating shifted by a few tens of pm.
fn frames(s: &SpectrumSetup, i: u64) -> [Vec<u16>; 2] {
    let peak = |g: usize| (lambda_ref(g) + 0.013 * (i as f64 + 1.0) * (g as f64 + 1.0), 0.3, 20_000.0);
    [
        synthetic_frame(&s.grid, s.pixels, &[peak(0), peak(1)], 1000.0, 60.0, 2 * i),
        synthetic_frame(&s.grid, s.pixels, &[peak(2)], 1000.0, 60.0, 2 * i + 1),
    ]
}

fn refused(r: Result<impl core::fmt::Debug, SpectrumLinkError>) -> SpectrumRefusal {
    match r {
        Err(SpectrumLinkError::Refused(r)) => r,
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn complete_readings_are_answered_bit_for_bit_as_the_host_reads_and_compensates_them() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = setup();
    link.setup_spectrum(&s).unwrap();
    let mut host = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    for i in 0..12u64 {
        let [f0, f1] = frames(&s, i);
        let t_s = 60.0 * i as f32;
        // Chunks of 96 pixels (the largest), and of 37 for odd readings.
        let chunk = if i % 2 == 0 { 96 } else { 37 };
        assert_eq!(link.send_frame(i as u32, 0, t_s, 21.5, &f0, chunk).unwrap(), FrameAnswer::Pending);
        let FrameAnswer::Estimate(d) = link.send_frame(i as u32, 1, t_s, 21.5, &f1, chunk).unwrap() else {
            panic!("reading {i} not answered");
        };
        // The chain itself: the shifts the frames were made with, within a few pm.
        let (sample, _) = s.reading(&[&f0, &f1], 21.5, t_s);
        for g in 0..3 {
            let truth = 13.0 * (i as f64 + 1.0) * (g as f64 + 1.0);
            assert!((f64::from(sample.dl_pm[g]) - truth).abs() < 5.0, "reading {i} grating {g}: {}", sample.dl_pm[g]);
        }
        let h = s.estimate(&mut host, &[&f0, &f1], 21.5, t_s);
        assert_eq!(d.seq, i as u32);
        assert_eq!(d.flags, h.flags, "reading {i}");
        for o in 0..usize::from(d.outputs) {
            assert_eq!(d.values[o].to_bits(), h.values[o].to_bits(), "reading {i} output {o}");
            assert_eq!(d.band[o].to_bits(), h.band95[o].to_bits(), "reading {i} band {o}");
        }
        assert!(d.values().iter().all(|v| v.is_finite()));
    }
    let st = link.status().unwrap();
    assert_eq!(st.spectra.frames, 24);
    assert_eq!((st.spectra.refused, st.spectra.frames_dropped), (0, 0));
    assert_eq!(st.samples, 12);
}

#[test]
fn out_of_order_and_missing_chunks_are_refused_counted_and_the_frame_dropped() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = setup();
    // Before the set-up: no frame.
    assert_eq!(refused(link.send_frame(0, 0, 0.0, 20.0, &[0; 512], 96)).reason, SpectrumError::NotSetUp);
    link.setup_spectrum(&s).unwrap();
    let [f0, f1] = frames(&s, 0);
    let px = |first: u16, v: &[u16]| -> Vec<u8> {
        let _ = first;
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    };
    // Pixels without a frame.
    let d = px(0, &f0[..10]);
    let r = link.request(&HostMsg::SpectrumPixels { first_pixel: 0, data: &d }).unwrap();
    assert_eq!(r, DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::NoFrame, 0)));
    // A skipped chunk: refused with the pixel expected, the frame dropped.
    let begin = HostMsg::SpectrumBegin { seq: 5, channel: 0, t_s: 0.0, t_amb_c: 21.5 };
    assert_eq!(link.request(&begin).unwrap(), DeviceMsg::SpectrumAck { received: 0 });
    let d = px(0, &f0[..96]);
    assert_eq!(
        link.request(&HostMsg::SpectrumPixels { first_pixel: 0, data: &d }).unwrap(),
        DeviceMsg::SpectrumAck { received: 96 }
    );
    let d = px(192, &f0[192..288]);
    let r = link.request(&HostMsg::SpectrumPixels { first_pixel: 192, data: &d }).unwrap();
    assert_eq!(r, DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::OutOfOrder, 96)));
    // The frame is gone: its next chunk has no frame.
    let d = px(96, &f0[96..192]);
    let r = link.request(&HostMsg::SpectrumPixels { first_pixel: 96, data: &d }).unwrap();
    assert_eq!(r, DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::NoFrame, 0)));
    // A frame begun again drops the one in progress; an odd byte count and pixels past the
    // frame are overruns.
    assert_eq!(link.request(&begin).unwrap(), DeviceMsg::SpectrumAck { received: 0 });
    assert_eq!(link.request(&begin).unwrap(), DeviceMsg::SpectrumAck { received: 0 });
    let r = link.request(&HostMsg::SpectrumPixels { first_pixel: 0, data: &[1, 2, 3] }).unwrap();
    assert_eq!(r, DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::Overrun, 1)));
    assert_eq!(link.request(&begin).unwrap(), DeviceMsg::SpectrumAck { received: 0 });
    for k in 0..5u16 {
        let d = px(0, &f0[usize::from(k) * 96..usize::from(k) * 96 + 96]);
        assert!(matches!(
            link.request(&HostMsg::SpectrumPixels { first_pixel: k * 96, data: &d }).unwrap(),
            DeviceMsg::SpectrumAck { .. }
        ));
    }
    let d = px(0, &f0[..96]);
    let r = link.request(&HostMsg::SpectrumPixels { first_pixel: 480, data: &d }).unwrap();
    assert_eq!(r, DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::Overrun, 576)));
    let st = link.status().unwrap();
    // Refused: not set up, no frame ×2, out of order, overrun ×2; dropped: the out-of-order
    // frame, one begun again, the two overruns.
    assert_eq!(st.spectra.refused, 6);
    assert_eq!(st.spectra.frames_dropped, 4);
    assert_eq!(st.spectra.frames, 0);
    assert_eq!(st.spectra.last_refusal, Some(SpectrumRefusal::new(SpectrumError::Overrun, 576)));
    assert_eq!(st.samples, 0);
    // Whole frames still make a reading; frames of another time do not complete it.
    assert_eq!(link.send_frame(1, 0, 0.0, 21.5, &f0, 96).unwrap(), FrameAnswer::Pending);
    assert_eq!(link.send_frame(1, 1, 60.0, 21.5, &f1, 96).unwrap(), FrameAnswer::Pending);
    assert!(matches!(link.send_frame(1, 0, 60.0, 21.5, &f0, 96).unwrap(), FrameAnswer::Estimate(_)));
    assert_eq!(link.status().unwrap().spectra.frames, 3);
}

#[test]
fn a_bad_set_up_is_refused_with_its_reason() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let grid = |gratings: u8, pixels: u16, c1: f32, method: u8, full_scale: f32| HostMsg::SpectrumGrid {
        gratings,
        pixels,
        uniform: true,
        coefficients: [1510.0, c1, 0.0, 0.0, 0.0, 0.0],
        method,
        full_scale,
    };
    let refusal = |m: DeviceMsg| match m {
        DeviceMsg::SpectrumRefused(r) => (r.reason, r.detail),
        other => panic!("{other:?}"),
    };
    assert_eq!(refusal(link.request(&grid(0, 512, 0.166, 4, 65535.0)).unwrap()), (SpectrumError::BadGrid, 1));
    assert_eq!(refusal(link.request(&grid(9, 512, 0.166, 4, 65535.0)).unwrap()), (SpectrumError::BadGrid, 1));
    assert_eq!(refusal(link.request(&grid(3, 0, 0.166, 4, 65535.0)).unwrap()), (SpectrumError::BadGrid, 2));
    assert_eq!(refusal(link.request(&grid(3, 512, 0.0, 4, 65535.0)).unwrap()), (SpectrumError::BadGrid, 3));
    assert_eq!(refusal(link.request(&grid(3, 512, f32::NAN, 4, 65535.0)).unwrap()), (SpectrumError::BadGrid, 3));
    assert_eq!(refusal(link.request(&grid(3, 512, 0.166, 5, 65535.0)).unwrap()), (SpectrumError::BadGrid, 4));
    // The device runs the default method only.
    assert_eq!(refusal(link.request(&grid(3, 512, 0.166, 0, 65535.0)).unwrap()), (SpectrumError::BadGrid, 4));
    assert_eq!(refusal(link.request(&grid(3, 512, 0.166, 4, 0.0)).unwrap()), (SpectrumError::BadGrid, 5));
    assert_eq!(link.request(&grid(2, 512, 0.166, 4, 65535.0)).unwrap(), DeviceMsg::SpectrumSet { missing: 2 });
    let grating = |index: u8, channel: u8, lo_nm: f32, hi_nm: f32| HostMsg::SpectrumGrating {
        index,
        channel,
        lo_nm,
        hi_nm,
        ref_hi_nm: 1550.0,
        ref_lo_nm: 0.0,
    };
    // Index past the gratings; a window off the grid; a window wider than the device keeps.
    assert_eq!(refusal(link.request(&grating(2, 0, 1549.0, 1551.0)).unwrap()), (SpectrumError::BadGrating, 2));
    assert_eq!(refusal(link.request(&grating(0, 0, 1700.0, 1702.0)).unwrap()), (SpectrumError::BadGrating, 0));
    assert_eq!(refusal(link.request(&grating(0, 0, 1530.0, 1550.0)).unwrap()).0, SpectrumError::OverCapacity);
    assert_eq!(link.request(&grating(0, 0, 1545.0, 1555.0)).unwrap(), DeviceMsg::SpectrumSet { missing: 1 });
    // Two 61-pixel windows on one channel need more than the 128 kept pixels... they do not:
    // 122 fit; a third grating's would not, but only two are set up here.
    assert_eq!(link.request(&grating(1, 0, 1560.0, 1570.0)).unwrap(), DeviceMsg::SpectrumSet { missing: 0 });
    let st = link.status().unwrap();
    assert_eq!(st.spectra.refused, 11);
    // A new grid forgets the gratings.
    assert_eq!(link.request(&grid(2, 512, 0.166, 4, 65535.0)).unwrap(), DeviceMsg::SpectrumSet { missing: 2 });
    let begin = HostMsg::SpectrumBegin { seq: 0, channel: 0, t_s: 0.0, t_amb_c: 20.0 };
    assert_eq!(refusal(link.request(&begin).unwrap()), (SpectrumError::NotSetUp, 2));
}

#[test]
fn a_peak_fault_reaches_the_estimate_and_the_alarm() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = setup();
    link.setup_spectrum(&s).unwrap();
    let [f0, f1] = frames(&s, 3);
    let mut host = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    // Clip grating 3's peak at the full scale.
    let clipped: Vec<u16> =
        synthetic_frame(&s.grid, s.pixels, &[(lambda_ref(2) + 0.02, 0.3, 90_000.0)], 1000.0, 60.0, 99);
    assert_eq!(link.send_frame(0, 0, 0.0, 21.5, &f0, 96).unwrap(), FrameAnswer::Pending);
    let FrameAnswer::Estimate(d) = link.send_frame(0, 1, 0.0, 21.5, &clipped, 96).unwrap() else { panic!() };
    let h = s.estimate(&mut host, &[&f0, &clipped], 21.5, 0.0);
    assert!(d.flags.contains(Flags::PEAK_FAULT), "{:?}", d.flags);
    assert_eq!(d.flags, h.flags);
    assert!(link.get_ref().dev.alarm().is_on());
    // A clean reading turns it off again.
    assert_eq!(link.send_frame(1, 0, 60.0, 21.5, &f0, 96).unwrap(), FrameAnswer::Pending);
    let FrameAnswer::Estimate(d) = link.send_frame(1, 1, 60.0, 21.5, &f1, 96).unwrap() else { panic!() };
    assert!(!d.flags.contains(Flags::PEAK_FAULT) && !d.flags.contains(Flags::PEAK_QUALITY), "{:?}", d.flags);
    assert_eq!(link.get_ref().dev.alarm().is_on(), d.flags.is_fault());
    assert_eq!(d.flags, s.estimate(&mut host, &[&f0, &f1], 21.5, 60.0).flags);
}
