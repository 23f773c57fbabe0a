//! The product firmware: boot the embedded default model, then serve the serial link (samples,
//! status, model updates) and drive the alarm output, forever.

#![no_std]
#![no_main]

use fbg_firmware::POLICY;

include!("product.rs");
