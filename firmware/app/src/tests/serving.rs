//! Serving: boot, the alarm, garbage on the link, model updates and the stream state, memory
//! models.

use super::*;

#[test]
fn boots_answers_pings_and_compensates_like_the_library() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    link.ping(7).unwrap();
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut reference, &samples(50), 0);
    let st = link.status().unwrap();
    assert_eq!(st.samples, 50);
    assert_eq!(st.frames_ok, 52);
    assert_eq!(st.frames_malformed, 0);
    assert_eq!(st.model_centres, n_default());
    assert_eq!(st.model_capacity, K as u16);
    assert_eq!(st.model_crc, blob::stored_crc(default_blob()).unwrap());
    assert_eq!(st.last_rejection, None);
}

#[test]
fn the_alarm_follows_the_flags() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let good = samples(1)[0];
    // Booted without a clock, a model whose band grows does not know the band's lead: said by
    // a flag that is no fault, so the alarm stays off.
    let p = params(default_blob());
    let e = link.compensate(0, &good).unwrap();
    assert!(!e.flags.is_fault());
    assert_eq!(e.flags.contains(Flags::LEAD_UNKNOWN), p.resid_var_growth.iter().any(|&q| q > 0.0));
    assert!(!link.get_ref().dev.alarm().is_on());
    // With the stream's start time (an hour after calibration ended) the lead is known.
    let start = p.field.cal_end_unix_s.unwrap() + 3600.0;
    let clock = fbg_shared::StreamClock::StartUnix(start);
    assert_eq!(link.request(&HostMsg::ResetStream { nonce: 9, clock }).unwrap(), DeviceMsg::Pong { nonce: 9 });
    // No lead flag now; the stream has no pace yet, so it falls back to Model-P (no fault).
    let e = link.compensate(0, &good).unwrap();
    assert!(!e.flags.contains(Flags::LEAD_UNKNOWN) && !e.flags.is_fault(), "{}", e.flags);
    assert!(!link.get_ref().dev.alarm().is_on());
    let mut nan = good;
    nan.dl_pm[1] = f32::NAN;
    let e = link.compensate(1, &nan).unwrap();
    assert_eq!(e.flags, Flags::NON_FINITE);
    assert!(link.get_ref().dev.alarm().is_on());
    let mut far = good;
    far.t_amb_c = 1.0e4;
    assert!(link.compensate(2, &far).unwrap().flags.contains(Flags::OUT_OF_ENVELOPE));
    assert!(link.get_ref().dev.alarm().is_on());
    assert!(!link.compensate(3, &good).unwrap().flags.is_fault());
    assert!(!link.get_ref().dev.alarm().is_on());
}

#[test]
fn garbage_is_counted_and_the_device_keeps_serving() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut damaged = {
        let mut buf = [0u8; 64];
        encode_host(&HostMsg::Ping { nonce: 1 }, &mut buf).unwrap().to_vec()
    };
    damaged[2] ^= 0x40; // a flipped bit: CRC mismatch
    let mut garbage = std::vec![0x01, 0x02, 0xFF, 0x00]; // 1 framing error
    garbage.extend(std::vec![0x11; 1000]); // 1 oversize frame
    garbage.push(0);
    garbage.extend(&damaged); // 1 CRC error
    garbage.extend([0, 0, 0]); // idle fill: not counted
    link.send_raw(&garbage).unwrap();
    link.ping(99).unwrap();
    let st = link.status().unwrap();
    assert_eq!(st.frames_malformed, 3);
    assert_eq!(st.frames_ok, 2);
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut reference, &samples(5), 0);
}

#[test]
fn a_valid_update_swaps_the_model_and_resets_the_stream() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = samples(40);
    let mut old = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut old, &s[..20], 0);
    let b = other_model();
    let r = link.update_model(&sign(&b, 1)).unwrap();
    assert_eq!(r, UpdateResult::Accepted { centres: n_default(), crc: blob::stored_crc(&b).unwrap() });
    let mut new = Compensator::<f32, K>::new(&params(&b)).unwrap();
    assert_serves(&mut link, &mut new, &s[20..], 20);
    // And the answers did change.
    let mut old_again = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let mut new_again = Compensator::<f32, K>::new(&params(&b)).unwrap();
    let differ = s.iter().any(|x| old_again.step(x).values != new_again.step(x).values);
    assert!(differ);
    let st = link.status().unwrap();
    assert_eq!((st.updates_accepted, st.updates_rejected), (1, 0));
    assert_eq!(st.model_crc, blob::stored_crc(&b).unwrap());
    assert_eq!((st.model_serial, st.model_key_id), (1, Some(trusted(&lab()).id)));
}

#[test]
fn bad_updates_are_rejected_with_the_reason_and_the_old_model_keeps_answering() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let s = samples(100);
    let good = other_model();

    let mut corrupt = good.clone();
    corrupt[100] ^= 0x10;
    // `encode` refuses invalid params, so patch a NaN into σ (header, output kinds 2 B each,
    // feature-set tag 1 B, σ_mult 4 B, then σ) and re-sign the blob.
    let mut nan_sigma = good.clone();
    let at = blob::HEADER_LEN + 6 + 1 + 4;
    nan_sigma[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let n = nan_sigma.len();
    let c = crc32(&nan_sigma[..n - 4]).to_le_bytes();
    nan_sigma[n - 4..].copy_from_slice(&c);
    let mut bad_version = good.clone();
    bad_version[4] = 9;
    // Nine gratings in the header (CRC recomputed): beyond the capacity of eight.
    let mut nine = good.clone();
    nine[6] = 9;
    let n = nine.len();
    let c = crc32(&nine[..n - 4]).to_le_bytes();
    nine[n - 4..].copy_from_slice(&c);
    let mut too_many = params(default_blob());
    too_many.centres.truncate(20);
    let small = encode(&too_many); // a valid, shorter model to cut short
    let cases: Vec<(&str, Vec<u8>, RejectReason)> = std::vec![
        ("corrupt byte", corrupt, RejectReason::BadCrc),
        ("bad version", bad_version, RejectReason::UnsupportedVersion),
        ("nan sigma", nan_sigma, RejectReason::BadParameter),
        ("nine gratings", nine, RejectReason::OverCapacity),
        ("truncated", small[..200].to_vec(), RejectReason::Truncated),
        ("not a blob", std::vec![0x42; 300], RejectReason::BadMagic),
        ("too large", std::vec![0; STAGE + 1], RejectReason::TooLarge),
    ];
    let mut rejected = 0;
    for (i, (name, bytes, reason)) in cases.iter().enumerate() {
        // Signed as they are: the signature holds, the blob inside does not.
        let bytes = if *reason == RejectReason::TooLarge { bytes.clone() } else { sign(bytes, 1) };
        let r = link.update_model(&bytes).unwrap();
        match r {
            UpdateResult::Rejected(rej) => {
                assert_eq!(rej.reason, *reason, "{name}: {rej}");
                if *reason == RejectReason::OverCapacity {
                    // The model's count and the capacity, both named.
                    assert_eq!(rej.detail, 9 << 16 | 8, "{name}");
                }
            }
            other => panic!("{name}: {other:?}"),
        }
        rejected += 1;
        let st = link.status().unwrap();
        assert_eq!(st.updates_rejected, rejected, "{name}");
        assert_eq!(st.model_crc, blob::stored_crc(default_blob()).unwrap(), "{name}: old model still active");
        assert_serves(&mut link, &mut reference, &s[i * 10..i * 10 + 10], i as u32 * 10);
    }

    // Transfer-level errors.
    let good = sign(&good, 1);
    let crc = crc32(&good);
    let r = link.update_model_with(&good, crc ^ 1, MAX_CHUNK).unwrap();
    assert_eq!(r, UpdateResult::Rejected(Rejection::new(RejectReason::TransferCrc)));
    let r = link.request(&HostMsg::ModelChunk { offset: 0, data: &[1, 2, 3] }).unwrap();
    assert_eq!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection::new(RejectReason::NoUpdateInProgress))));
    let r = link.request(&HostMsg::ModelCommit).unwrap();
    assert_eq!(r, DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection::new(RejectReason::NoUpdateInProgress))));
    let total_len = good.len() as u32;
    assert_eq!(
        link.request(&HostMsg::ModelBegin { total_len, crc32: crc }).unwrap(),
        DeviceMsg::UpdateProgress { received: 0 }
    );
    let r = link.request(&HostMsg::ModelChunk { offset: 5, data: &good[5..10] }).unwrap();
    assert_eq!(
        r,
        DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::OutOfOrder, detail: 0 }))
    );
    link.request(&HostMsg::ModelBegin { total_len: 24, crc32: crc }).unwrap();
    let r = link.request(&HostMsg::ModelChunk { offset: 0, data: &good[..30] }).unwrap();
    assert!(matches!(
        r,
        DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::Overrun, .. }))
    ));
    link.request(&HostMsg::ModelBegin { total_len, crc32: crc }).unwrap();
    link.request(&HostMsg::ModelChunk { offset: 0, data: &good[..100] }).unwrap();
    let r = link.request(&HostMsg::ModelCommit).unwrap();
    assert_eq!(
        r,
        DeviceMsg::UpdateResult(UpdateResult::Rejected(Rejection { reason: RejectReason::Incomplete, detail: 100 }))
    );

    assert_serves(&mut link, &mut reference, &s[70..], 70);
    let st = link.status().unwrap();
    assert_eq!(st.updates_accepted, 0);
    assert_eq!(st.last_rejection.map(|r| r.reason), Some(RejectReason::Incomplete));

    // Finally a good one still goes through.
    assert!(matches!(link.update_model(&good).unwrap(), UpdateResult::Accepted { .. }));
}

#[test]
fn a_model_beyond_the_capacity_is_refused() {
    // A device built for 16 centres refuses a 32-centre model.
    let b32 = encode(&with_centres(params(default_blob()), 32));
    let mut comp = std::boxed::Box::new(unloaded::<16>());
    let e = load_blob(&Kernel::LIBRARY, &mut comp, &b32).err().unwrap();
    assert_eq!(e.reason, RejectReason::WrongDims);
    assert_eq!(e.detail, 32 << 16 | 16);
    assert_eq!(comp.n_centres(), 0, "still unloaded");
}

#[test]
fn an_unloaded_compensator_is_usable() {
    // All-zero bytes: no centres, no output fitted, latches that have seen nothing.
    let mut comp = std::boxed::Box::new(unloaded::<K>());
    assert_eq!(comp.n_centres(), 0);
    assert_eq!(comp.state().latch_values(), [0.0; 8]);
    // No model: no output, and every sample (its gratings are not the model's none) is
    // answered as non-finite.
    let e = comp.step(&samples(1)[0]);
    assert!(e.values().is_empty() && e.band().is_empty(), "{e:?}");
    assert_eq!(e.flags, fbg_shared::Flags::NON_FINITE, "{e:?}");
    // Loading into it gives exactly `Compensator::new`.
    let info = load_blob(&Kernel::LIBRARY, &mut comp, default_blob()).unwrap();
    assert_eq!(
        info,
        ModelInfo { centres: n_default(), crc: blob::stored_crc(default_blob()).unwrap(), serial: 0, key_id: None }
    );
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    for x in samples(30) {
        assert_eq!(format!("{:?}", comp.step(&x)), format!("{:?}", reference.step(&x)));
    }
}

#[test]
fn serving_goes_on_across_updates_and_a_partial_frame_does_not_survive_a_new_device() {
    // Updates do not disturb the frame reader: pings before, between and after them.
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    link.ping(3).unwrap();
    assert!(matches!(link.update_model(&sign(&other_model(), 1)).unwrap(), UpdateResult::Accepted { .. }));
    link.ping(4).unwrap();
    assert!(matches!(link.update_model(&sign(default_blob(), 2)).unwrap(), UpdateResult::Accepted { .. }));
    link.ping(5).unwrap();
    assert_eq!(link.status().unwrap().frames_malformed, 0);
    drop(link);
    // A reader left inside a frame is reset when a device starts serving with it.
    let mut buf = [0u8; 64];
    let ping = encode_host(&HostMsg::Ping { nonce: 9 }, &mut buf).unwrap().to_vec();
    let (ev, _) = mem.reader.feed::<HostMsg<'_>>(&ping[..3]);
    assert_eq!(ev, Feed::Pending);
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    let mut tx = Tx::default();
    dev.feed(&ping, &mut tx).unwrap();
    assert_eq!(dev.status().frames_malformed, 0);
    assert_eq!(dev.status().frames_ok, 1);
}

#[test]
fn a_failed_load_keeps_the_old_model_and_its_stream_state() {
    let mut mem = Mem::new();
    let info = mem.boot(default_blob()).unwrap();
    let s = samples(40);
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    for x in &s[..20] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
    // A blob that parses but does not fold (σ so small that the f32 folding overflows) and one
    // that does not parse: both leave the model and the latches as they were.
    let mut p = params(other_model().as_slice());
    p.hyper.sigma = 1e-38;
    let tiny_sigma = encode(&p);
    let mut corrupt = other_model();
    corrupt[50] ^= 1;
    for bad in [tiny_sigma, corrupt] {
        let before = mem.comp.state().latch_values();
        assert!(load(&Kernel::LIBRARY, &mut mem.comp, &bad).is_err());
        assert_eq!(mem.comp.state().latch_values(), before);
    }
    for x in &s[20..] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
    let _ = info;
}

#[test]
fn a_link_error_ends_serve() {
    struct Script {
        input: VecDeque<u8>,
        out: Vec<u8>,
    }
    #[derive(Debug)]
    struct End;
    impl core::fmt::Display for End {
        fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            f.write_str("end")
        }
    }
    impl core::error::Error for End {}
    impl embedded_io::Error for End {
        fn kind(&self) -> embedded_io::ErrorKind {
            embedded_io::ErrorKind::BrokenPipe
        }
    }
    impl embedded_io::ErrorType for Script {
        type Error = End;
    }
    impl Read for Script {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, End> {
            if self.input.is_empty() {
                return Err(End);
            }
            let n = buf.len().min(self.input.len()).min(3);
            for b in buf.iter_mut().take(n) {
                *b = self.input.pop_front().unwrap();
            }
            Ok(n)
        }
    }
    impl Write for Script {
        fn write(&mut self, buf: &[u8]) -> Result<usize, End> {
            self.out.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> Result<(), End> {
            Ok(())
        }
    }
    let mut buf = [0u8; 64];
    let ping = encode_host(&HostMsg::Ping { nonce: 5 }, &mut buf).unwrap().to_vec();
    let mut mem = Mem::new();
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    dev.set_stack_probe(|| 1234, 4321);
    let mut script = Script { input: ping.iter().copied().chain(ping.iter().copied()).collect(), out: Vec::new() };
    assert!(dev.serve(&mut script).is_err());
    let mut r = FrameReader::<DEVICE_MAX_FRAME>::new();
    let mut w = &script.out[..];
    let mut pongs = 0;
    while !w.is_empty() {
        let (ev, rest) = r.feed::<DeviceMsg>(w);
        w = rest;
        if ev == Feed::Message(DeviceMsg::Pong { nonce: 5 }) {
            pongs += 1;
        }
    }
    assert_eq!(pongs, 2);
    assert_eq!(dev.status().stack_peak_bytes, 1234);
    assert_eq!(dev.status().stack_boot_bytes, 4321);
    let _: Option<LinkError> = None;
}

#[test]
fn a_zeroed_memory_bank_is_the_default_one() {
    // The bank of an unloaded compensator (`MemoryBank::off`) is all zero bytes, which is what
    // keeps the firmware's static compensator in `.bss`.
    // SAFETY: every field of the bank is a float, an integer or a bool, all valid as zeros.
    let zeroed: MemoryBank<f32> = unsafe { core::mem::MaybeUninit::zeroed().assume_init() };
    assert_eq!(zeroed, MemoryBank::off());
    assert_eq!(zeroed, MemoryBank::default());
    assert!(!zeroed.is_active());
    assert_eq!(zeroed.state(), fbg_shared::MemoryState::new());
}

#[test]
fn a_memory_model_is_served_like_the_library_across_gaps_resets_and_updates() {
    let mem_blob = memory_model();
    let s = timed_samples(400);
    // Booted with the memory model.
    let mut mem = Mem::new();
    let mut link = mem.link(&mem_blob);
    let mut reference = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    assert!(reference.has_memory());
    assert_serves(&mut link, &mut reference, &s[..250], 0);
    // ResetStream forgets the memory (and the latches), on the device as in the library.
    assert_eq!(
        link.request(&HostMsg::ResetStream { nonce: 4, clock: fbg_shared::StreamClock::Unknown }).unwrap(),
        DeviceMsg::Pong { nonce: 4 }
    );
    reference.reset();
    assert_serves(&mut link, &mut reference, &s[250..], 250);
    // Swapped in by an update from a model without memory, and back.
    let mut mem2 = Mem::new();
    let mut link2 = mem2.link(default_blob());
    assert!(matches!(link2.update_model(&sign(&mem_blob, 1)).unwrap(), UpdateResult::Accepted { .. }));
    let mut reference2 = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    assert_serves(&mut link2, &mut reference2, &s, 0);
    assert!(matches!(link2.update_model(&sign(default_blob(), 2)).unwrap(), UpdateResult::Accepted { .. }));
    let mut plain = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link2, &mut plain, &s[..50], 400);
    // The memory terms do move the answers.
    let mut a = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    let mut b = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert!(s.iter().any(|x| a.step(x).values != b.step(x).values));
}

#[test]
fn a_failed_load_keeps_the_memory_state() {
    let mem_blob = memory_model();
    let mut mem = Mem::new();
    mem.boot(&mem_blob).unwrap();
    let s = timed_samples(80);
    let mut reference = Compensator::<f32, K>::new(&params(&mem_blob)).unwrap();
    for x in &s[..40] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
    let mut p = params(&mem_blob);
    p.hyper.sigma = 1e-38; // parses, does not fold in f32
    let tiny_sigma = encode(&p);
    let before = *mem.comp.state();
    assert!(load_blob(&Kernel::LIBRARY, &mut mem.comp, &tiny_sigma).is_err());
    assert_eq!(*mem.comp.state(), before);
    for x in &s[40..] {
        assert_eq!(format!("{:?}", mem.comp.step(x)), format!("{:?}", reference.step(x)));
    }
}

/// A build without spectrum frames refuses every spectrum message as `Unsupported`, counts
/// the refusals in its status and keeps serving.
#[cfg(not(feature = "spectrum"))]
#[test]
fn a_build_without_spectrum_frames_refuses_them_and_keeps_serving() {
    use fbg_shared::protocol::{DeviceMsg, SpectrumError, SpectrumRefusal};
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let unsupported = DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::Unsupported, 0));
    let begin = HostMsg::SpectrumBegin { seq: 1, channel: 0, t_s: 0.0, t_amb_c: 20.0 };
    assert_eq!(link.request(&begin).unwrap(), unsupported);
    let pixels = HostMsg::SpectrumPixels { first_pixel: 0, data: &[0u8; 8] };
    assert_eq!(link.request(&pixels).unwrap(), unsupported);
    let st = link.status().unwrap();
    assert_eq!(st.spectra.refused, 2);
    assert_eq!(st.spectra.frames, 0);
    assert_eq!(st.spectra.last_refusal, Some(SpectrumRefusal::new(SpectrumError::Unsupported, 0)));
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    assert_serves(&mut link, &mut reference, &samples(5), 0);
}
