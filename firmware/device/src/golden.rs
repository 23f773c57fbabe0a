//! What every board's golden-vector image runs: the store flash's NOR semantics on the target
//! ([`check_store_flash`]), then every record of the golden pack compensated the way the
//! product does and sent as protocol `Estimate` frames ([`compensate_pack`]); the host
//! compares them with its f64 answers.

use embedded_io::Write;
use embedded_storage::nor_flash::ReadNorFlash;
use fbg_firmware_app::{load_blob, MappedFlash};
use fbg_firmware_kernel::{step, K, KERNEL, STAGING_LEN};
use fbg_shared::protocol::{encode_device, DeviceEstimate, DeviceMsg, DEVICE_MAX_FRAME};
use fbg_shared::Compensator;

/// The errors a store flash driver must give for a write over written bytes, an unaligned
/// operation and one out of bounds.
pub struct Refusals<E> {
    /// A write over bytes not erased since they were written.
    pub not_erased: E,
    /// A write or erase off the driver's alignment.
    pub not_aligned: E,
    /// An erase beyond the capacity.
    pub out_of_bounds: E,
}

/// The store flash's NOR semantics: `units` erase units of `erase_size` bytes, each large
/// enough for the longest update; an erase sets `0xFF`; a write lands and reads back; a second
/// write over written bytes and unaligned or out-of-bounds operations are refused with
/// `refusals`. Erases the first unit. The first check that fails is logged and ends in `fatal`.
pub fn check_store_flash<F>(
    flash: &mut F,
    units: usize,
    erase_size: usize,
    refusals: Refusals<F::Error>,
    fatal: fn() -> !,
) where
    F: MappedFlash,
    F::Error: PartialEq,
{
    let e = erase_size as u32;
    let word = [0x12, 0x34, 0x56, 0x78];
    let mut back = [0u8; 4];
    let checks = [
        flash.capacity() == units * erase_size && erase_size >= STAGING_LEN,
        flash.erase(0, e).is_ok(),
        flash.contents().get(..erase_size).is_some_and(|b| b.iter().all(|&x| x == 0xFF)),
        flash.write(8, &word).is_ok(),
        flash.read(8, &mut back).is_ok() && back == word,
        flash.contents().get(8..12) == Some(&word[..]),
        flash.write(8, &word) == Err(refusals.not_erased),
        flash.write(2, &word).as_ref() == Err(&refusals.not_aligned),
        flash.write(8, &word[..3]).as_ref() == Err(&refusals.not_aligned),
        flash.erase(0, e / 2).as_ref() == Err(&refusals.not_aligned),
        flash.erase(0, flash.capacity() as u32 + e) == Err(refusals.out_of_bounds),
        flash.erase(0, e).is_ok() && flash.write(8, &word).is_ok(),
        flash.erase(0, e).is_ok(),
    ];
    if let Some(i) = checks.iter().position(|ok| !ok) {
        defmt::error!("store flash: check {=usize} failed", i);
        fatal()
    }
    defmt::info!("golden: the store flash ({=usize} units of {=usize} B) behaves as NOR flash", units, erase_size);
}

/// Every record of `pack` (`fbg_shared::golden::records`: a model blob and its samples): the
/// model loaded into `model` as the product loads an update (a fresh stream state each time),
/// each sample compensated and its estimate sent on `link` as an `Estimate` frame, numbered
/// across the records. Returns the samples sent; a malformed pack or a refused model is logged
/// and ends in `fatal`.
pub fn compensate_pack(pack: &[u8], model: &mut Compensator<f32, K>, link: &mut impl Write, fatal: fn() -> !) -> u32 {
    if pack.is_empty() {
        defmt::error!("golden pack missing (FBG_GOLDEN_PACK)");
        fatal()
    }
    let mut n = 0u32;
    for (i, rec) in fbg_shared::golden::records(pack).enumerate() {
        let Some(rec) = rec else {
            defmt::error!("golden pack malformed at record {=usize}", i);
            fatal()
        };
        if let Err(r) = load_blob(&KERNEL, model, rec.blob) {
            defmt::error!("golden model {=usize} rejected: {} (detail {=u32})", i, r.reason, r.detail);
            fatal()
        }
        for s in rec.iter() {
            let e = step(model, &s);
            let msg = DeviceMsg::Estimate(DeviceEstimate::new(n, &e));
            let mut buf = [0u8; DEVICE_MAX_FRAME];
            let Ok(frame) = encode_device(&msg, &mut buf) else { fatal() };
            // A frame lost on the link is what the host's count of the estimates catches.
            let _ = link.write_all(frame);
            n += 1;
        }
        defmt::info!("golden: model {=usize}: {=usize} samples compensated", i, rec.len());
    }
    let _ = link.flush();
    n
}
