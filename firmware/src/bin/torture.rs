//! A QEMU test image: the product firmware whose store flash loses power in one chosen erase
//! or program (`fbg_firmware_app::store::PowerCut`), for the power-loss torture test of
//! `cargo xtask qemu`.
//!
//! The operation is the `cut=N` argument of the semihosting command line (QEMU's
//! `-semihosting-config arg=…`; N counts the erases and programs of the store since boot,
//! from 1). That operation is done in part — as when the supply fails in the middle of it —
//! and written through to the flash file like any other (`fbg_firmware::store_flash`); then
//! the run ends at once with exit code [`CUT_EXIT`], so that the flash file holds exactly what
//! a device that lost power there would find at its next boot. The harness then boots the
//! product image on that file.

#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use fbg_firmware::product::run_product;
use fbg_firmware::store_flash::StoreFlash;
use fbg_firmware_app::store::PowerCut;

/// Exit code of a run ended by the power cut (1 is a failure, 0 never happens: the product
/// serves forever).
pub const CUT_EXIT: i32 = 3;

/// The operation the power fails in: `cut=N` on the semihosting command line. A missing or
/// malformed one ends the run with failure (the image exists only for the cut).
fn cut_at() -> u32 {
    let mut buf = [MaybeUninit::<u8>::uninit(); 80];
    let Ok(line) = semihosting::sys::arm_compat::sys_get_cmdline_uninit(&mut buf) else {
        defmt::error!("torture: no semihosting command line (cut=N)");
        fbg_firmware::exit_failure()
    };
    let cut = core::str::from_utf8(line)
        .ok()
        .and_then(|l| l.split_ascii_whitespace().find_map(|a| a.strip_prefix("cut=")))
        .and_then(|n| n.parse::<u32>().ok())
        .filter(|&n| n > 0);
    match cut {
        Some(n) => n,
        None => {
            defmt::error!("torture: the command line names no cut=N (N ≥ 1)");
            fbg_firmware::exit_failure()
        }
    }
}

/// The power fails: end the run now, as a board would lose its supply.
fn on_cut() {
    defmt::warn!("torture: power cut");
    semihosting::process::exit(CUT_EXIT)
}

/// The store's flash, as the product's, losing power in operation [`cut_at`].
fn store_flash() -> PowerCut<StoreFlash> {
    let cut = cut_at();
    defmt::info!("torture: the power fails in the store's flash operation {=u32}", cut);
    // SAFETY: called once (`Board::bring_up`): the only driver of the region.
    PowerCut::new(unsafe { StoreFlash::open() }, cut, on_cut)
}

// The product on the MPS2 board, its store's flash losing power in one operation.
fbg_firmware::mps2_board!(Torture, policy: fbg_firmware::POLICY, flash: PowerCut<StoreFlash> = store_flash());

#[entry]
fn main() -> ! {
    run_product::<Torture>()
}
