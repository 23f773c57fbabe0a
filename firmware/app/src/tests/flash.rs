//! The staging flash: erases within the budget, any chunking, refusals, flash failures; and
//! wrong or implausible models.

use super::*;

#[test]
fn the_test_flash_behaves_like_nor_flash() {
    let mut f = Nor::<4, 256>::new(2);
    assert_ne!(f.mem[0], 0xFF, "starts with garbage");
    assert_eq!(f.write(0, &[1, 2, 3, 4]), Err(NorFlashErrorKind::Other), "not erased");
    f.erase(0, 256).unwrap();
    assert!(f.mem[..256].iter().all(|&b| b == 0xFF));
    assert!(f.mem[256..].iter().any(|&b| b != 0xFF), "only the erased unit");
    assert_eq!(f.erase(0, 100), Err(NorFlashErrorKind::NotAligned));
    assert_eq!(f.erase(0, 1024), Err(NorFlashErrorKind::OutOfBounds));
    assert_eq!(f.write(2, &[1, 2, 3, 4]), Err(NorFlashErrorKind::NotAligned));
    assert_eq!(f.write(0, &[1, 2, 3]), Err(NorFlashErrorKind::NotAligned));
    f.write(0, &[1, 2, 3, 4]).unwrap();
    assert_eq!(f.write(0, &[1, 2, 3, 4]), Err(NorFlashErrorKind::Other), "written twice");
    let mut back = [0u8; 4];
    f.read(0, &mut back).unwrap();
    assert_eq!(back, [1, 2, 3, 4]);
    assert_eq!(&f.contents()[..4], &[1, 2, 3, 4]);
}

/// Stage `bytes` into a fresh `Nor<W, E>` (its first units erased by hand, as the store does)
/// in chunks of the lengths `sizes` (cycled) and check what the flash holds: the bytes, `0xFF`
/// up to the end of the last write unit, and nothing written beyond.
fn stage_in<const W: usize, const E: usize>(bytes: &[u8], sizes: &[usize]) {
    let mut flash = Nor::<W, E>::for_len(STAGE);
    let erased_end = bytes.len().div_ceil(E) * E;
    flash.erase(0, erased_end as u32).unwrap();
    let garbage = flash.mem.clone();
    let mut st = Staging::new(0, STAGE);
    st.check(bytes.len()).unwrap();
    st.begin(0, bytes.len(), crc32(bytes));
    let (mut at, mut i) = (0, 0);
    while at < bytes.len() {
        let n = sizes[i % sizes.len()].min(bytes.len() - at);
        assert_eq!(st.chunk(&mut flash, at as u32, &bytes[at..at + n]), Ok(at + n), "W {W}, chunks {sizes:?}");
        at += n;
        i += 1;
    }
    assert_eq!(st.finish(&mut flash), Ok(bytes.len()), "W {W}, chunks {sizes:?}");
    assert_eq!(&flash.mem[..bytes.len()], bytes, "W {W}, chunks {sizes:?}");
    let unit_end = bytes.len().div_ceil(W) * W;
    assert!(flash.mem[bytes.len()..erased_end].iter().all(|&b| b == 0xFF), "W {W}: padded with the erased value");
    assert_eq!(flash.mem[erased_end..], garbage[erased_end..], "E {E}: the rest of the flash untouched");
    assert!(flash.writes <= unit_end / W, "W {W}: every unit written once at most");
}

#[test]
fn an_update_is_staged_at_the_flash_granularity_whatever_the_chunks() {
    let signed = sign(&other_model(), 1);
    let odd = &signed[..signed.len() - 3];
    for bytes in [&signed[..], odd] {
        for sizes in [&[MAX_CHUNK][..], &[1], &[3, 7, 64], &[5, MAX_CHUNK, 2, 31]] {
            stage_in::<1, 256>(bytes, sizes);
            stage_in::<4, 4096>(bytes, sizes);
            stage_in::<8, 2048>(bytes, sizes);
            stage_in::<32, 128>(bytes, sizes);
        }
    }
}

#[test]
fn staging_refuses_what_does_not_fit_or_comes_out_of_turn() {
    let mut flash = Nor::<4, 256>::new(4);
    flash.erase(0, 1024).unwrap();
    let mut st = Staging::new(0, 1024);
    assert_eq!(st.limit(), 1024);
    fn r<T>(reason: RejectReason, detail: u32) -> Result<T, Rejection> {
        Err(Rejection { reason, detail })
    }
    assert_eq!(st.check(1025), r(RejectReason::TooLarge, 1025));
    assert_eq!(st.check(4), r(RejectReason::Truncated, 4));
    assert_eq!(st.chunk(&mut flash, 0, &[1]), r(RejectReason::NoUpdateInProgress, 0));
    const N: usize = 40;
    st.check(N).unwrap();
    st.begin(0, N, crc32(&[7; N]));
    assert_eq!(st.announced(), Some(N));
    assert_eq!(st.chunk(&mut flash, 1, &[7]), r(RejectReason::OutOfOrder, 0));
    assert_eq!(st.chunk(&mut flash, 0, &[7; 26]), Ok(26));
    assert_eq!(st.chunk(&mut flash, 26, &[7; 15]), r(RejectReason::Overrun, 26));
    assert_eq!(st.finish(&mut flash), r(RejectReason::Incomplete, 26));
    assert_eq!(st.finish(&mut flash), r(RejectReason::NoUpdateInProgress, 0), "the transfer ended");
    // Again from the start, in a window the caller made blank again.
    flash.erase(0, 256).unwrap();
    st.begin(0, N, crc32(&[7; N]) ^ 1);
    assert_eq!(st.chunk(&mut flash, 0, &[7; N]), Ok(N));
    assert_eq!(st.finish(&mut flash), r(RejectReason::TransferCrc, 0));
    flash.erase(0, 256).unwrap();
    st.begin(256, N, crc32(&[7; N]));
    st.chunk(&mut flash, 0, &[7; N]).unwrap();
    assert_eq!(st.finish(&mut flash), Ok(N));
    assert_eq!(&flash.mem[256..256 + N], &[7u8; N][..], "at the window's offset");
}

#[test]
fn a_flash_failure_refuses_the_update_and_the_old_model_keeps_serving() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let s = samples(40);
    assert_serves(&mut link, &mut reference, &s[..10], 0);
    let other = other_model();
    let good = sign(&other, 1);
    let inject = |link: &LinkClient<Wire<'_>>, f: Fault| link.get_ref().dev.store().flash().fault.set(f);

    inject(&link, Fault::Erase);
    let r = link.update_model(&good).unwrap();
    assert_eq!(r, UpdateResult::Rejected(Rejection { reason: RejectReason::Storage, detail: 0 }));
    assert_serves(&mut link, &mut reference, &s[10..20], 10);
    // A write that fails in the third chunk: refused with the offset of the failed write.
    inject(&link, Fault::WriteAt(crate::store::format::PAYLOAD_AT + 2 * MAX_CHUNK + 5));
    let r = link.update_model(&good).unwrap();
    assert_eq!(r, UpdateResult::Rejected(Rejection { reason: RejectReason::Storage, detail: (2 * MAX_CHUNK) as u32 }));
    assert_serves(&mut link, &mut reference, &s[20..30], 20);
    let st = link.status().unwrap();
    assert_eq!((st.updates_accepted, st.updates_rejected), (0, 2));
    assert_eq!(st.model_crc, blob::stored_crc(default_blob()).unwrap());
    // The flash works again: the same update goes through.
    inject(&link, Fault::None);
    assert!(matches!(link.update_model(&good).unwrap(), UpdateResult::Accepted { .. }));
    let mut new = Compensator::<f32, K>::new(&params(&other)).unwrap();
    assert_serves(&mut link, &mut new, &s[30..], 30);
}

/// The default model reading T 500 °C high (a wrong zero): every number in range, so it
/// decodes, signs and loads; every estimate is outside T's calibration envelope.
fn wrong_model() -> Vec<u8> {
    let mut p = params(default_blob());
    p.poly[0][0] += 500.0;
    encode(&p)
}

#[test]
fn a_wrong_model_turns_the_alarm_on() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let s = samples(30);
    let clock = fbg_shared::StreamClock::StartUnix(params(default_blob()).field.cal_end_unix_s.unwrap() + 3600.0);
    assert_eq!(link.request(&HostMsg::ResetStream { nonce: 1, clock }).unwrap(), DeviceMsg::Pong { nonce: 1 });
    // A stream that has just started has no pace yet: its estimates fall back to Model-P
    // (a flag that is no fault), so the alarm stays off.
    for (i, x) in s[..10].iter().enumerate() {
        assert!(!link.compensate(i as u32, x).unwrap().flags.is_fault());
        assert!(!link.get_ref().dev.alarm().is_on());
    }
    let wrong = wrong_model();
    assert!(matches!(link.update_model(&sign(&wrong, 1)).unwrap(), UpdateResult::Accepted { .. }));
    let mut reference = Compensator::<f32, K>::new(&params(&wrong)).unwrap();
    reference.set_clock(clock);
    for (i, x) in s[10..20].iter().enumerate() {
        let e = link.compensate(10 + i as u32, x).unwrap();
        assert!(e.flags.contains(Flags::IMPLAUSIBLE) && e.flags.is_fault(), "sample {i}: {}", e.flags);
        assert_eq!(e.flags, reference.step(x).flags);
        assert!(link.get_ref().dev.alarm().is_on(), "sample {i}");
    }
    // The right model again: the alarm goes off.
    assert!(matches!(link.update_model(&sign(default_blob(), 2)).unwrap(), UpdateResult::Accepted { .. }));
    for (i, x) in s[20..].iter().enumerate() {
        assert!(!link.compensate(20 + i as u32, x).unwrap().flags.is_fault());
        assert!(!link.get_ref().dev.alarm().is_on());
    }
}

#[test]
fn an_implausible_update_is_refused_and_the_old_model_keeps_serving() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let mut reference = Compensator::<f32, K>::new(&params(default_blob())).unwrap();
    let s = samples(30);
    // The cases, each with a valid CRC and a valid signature.
    let base = params(default_blob());
    let s1 = base.dims.stage1_len();
    let mut intercept = base.clone();
    intercept.stage1[0][s1 - 1] = 3.4e38;
    let mut variance = base.clone();
    variance.centres[0].v[1] = 3.4e38;
    let mut index = base.clone();
    let outs = [
        fbg_shared::layout::Output::first(fbg_shared::layout::Quantity::Temperature),
        fbg_shared::layout::Output { quantity: fbg_shared::layout::Quantity::Strain, index: 200 },
        fbg_shared::layout::Output::first(fbg_shared::layout::Quantity::Pressure),
    ];
    index.dims = fbg_shared::layout::Dims::new(base.dims.gratings(), base.dims.ambient(), &outs).unwrap();
    for (i, p) in [intercept, variance, index].iter().enumerate() {
        let mut buf = std::vec![0u8; STAGE];
        let n = blob::encode_unchecked(p, &mut buf).unwrap();
        let r = link.update_model(&sign(&buf[..n], 1 + i as u64)).unwrap();
        assert_eq!(r, UpdateResult::Rejected(Rejection::new(RejectReason::BadParameter)), "case {i}");
        assert_serves(&mut link, &mut reference, &s[i * 10..i * 10 + 10], i as u32 * 10);
        assert!(!link.get_ref().dev.alarm().is_on());
    }
    assert_eq!(link.status().unwrap().model_crc, blob::stored_crc(default_blob()).unwrap());
}
