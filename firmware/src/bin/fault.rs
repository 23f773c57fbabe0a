//! Fatal-path test image: logs, then executes a permanently undefined instruction. The HardFault
//! handler must end the run through semihosting with a failure exit code (the QEMU tests check
//! that this image exits non-zero and that a hang is not mistaken for success).

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use fbg_firmware as _;

#[entry]
fn main() -> ! {
    defmt::info!("fault test: executing UDF");
    cortex_m::asm::udf()
}
