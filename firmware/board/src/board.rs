//! Bring-up of the STM32F405 board: clocks, the link's USART, the alarm LED and the model
//! store, each handed out once.
//!
//! | what | where |
//! |---|---|
//! | link | USART1, TX PB6, RX PB7 (AF7), 115 200 Bd 8N1; QEMU's `serial0` |
//! | alarm | PC1, push-pull, high = on (the Adafruit Feather STM32F405's red LED) |
//! | model store | flash sectors 5–8 (`STORE` of `memory.x`) |
//! | clocks | HSI (16 MHz) through the PLL to 168 MHz; left at reset (HSI 16 MHz) in the emulator |
//!
//! The clocks come from the internal oscillator so that the image runs on any STM32F405 board,
//! whatever crystal it carries. In the emulator the HAL's clock setup is skipped: QEMU does not
//! model the RCC (its registers read 0), and `freeze` waits for a PLL-ready bit that never sets.

use stm32f4xx_hal::gpio::{Output, PushPull, PC1};
use stm32f4xx_hal::pac::{self, Interrupt, USART1};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::serial::Config;

use crate::serial::Link;
use crate::store_flash::StoreFlash;

/// Link speed.
pub const BAUD: u32 = 115_200;
/// The link's interrupt line (the receive wake-up).
pub const LINK_IRQ: Interrupt = Interrupt::USART1;
/// System clock on the part.
#[cfg(not(feature = "emulator"))]
pub const SYSCLK_HZ: u32 = 168_000_000;
/// System clock in the emulator (the reset clock, HSI).
#[cfg(feature = "emulator")]
pub const SYSCLK_HZ: u32 = 16_000_000;

/// The alarm output: an `embedded-hal` 1.0 `OutputPin`.
pub type Alarm = PC1<Output<PushPull>>;

/// What the images drive.
pub struct Board {
    /// The serial link.
    pub link: Link<USART1>,
    /// The alarm LED, off.
    pub alarm: Alarm,
    /// The model store's flash.
    pub store: StoreFlash,
}

/// Why the board could not be brought up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum BringUpError {
    /// The peripherals were taken already.
    Taken,
    /// The USART refused its configuration (no baud divider for the clock).
    Usart,
}

impl Board {
    /// Take the peripherals and bring the board up (once).
    pub fn take() -> Result<Board, BringUpError> {
        let dp = pac::Peripherals::take().ok_or(BringUpError::Taken)?;
        #[cfg(not(feature = "emulator"))]
        let mut rcc = dp.RCC.freeze(stm32f4xx_hal::rcc::Config::hsi().sysclk(SYSCLK_HZ.Hz()));
        #[cfg(feature = "emulator")]
        let mut rcc = dp.RCC.constrain();
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);
        let mut alarm = gpioc.pc1.into_push_pull_output();
        alarm.set_low();
        let serial = dp
            .USART1
            .serial::<u8>((gpiob.pb6, gpiob.pb7), Config::default().baudrate(BAUD.bps()), &mut rcc)
            .map_err(|_| BringUpError::Usart)?;
        let (tx, rx) = serial.split();
        Ok(Board { link: Link::new(tx, rx), alarm, store: StoreFlash::new(dp.FLASH) })
    }
}
