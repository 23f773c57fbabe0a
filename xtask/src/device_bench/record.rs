//! `target/bench/device.json`, typed: what the device bench writes and what `cargo xtask
//! bench` reads back into BENCHMARKS.json (`bench::report::DeviceResults` flattens it).
//!
//! The key names are the file's contract: a field is named as its key. Figures are rounded as
//! the file always carried them ([`rounded`]: instructions to 0.1, instructions per SysTick
//! tick to 1e-4, the signature check to a whole instruction and the step target as an integer).

use fbg_report::nan;
use serde::{Deserialize, Serialize};

use super::store::StoreBench;
use super::{SizeReport, StepBench, TypeSizes, VerifyBench};
use crate::targets::{
    PRODUCT_K, TARGET_BLOB, TARGET_BOOT_US, TARGET_ERASES_PER_UPDATE, TARGET_FLASH, TARGET_INSNS_K32, TARGET_RAM,
    TARGET_RAM_LOAD,
};

/// How the step figures were measured.
const METHOD: &str = "qemu-system-arm mps2-an386 -icount shift=0, SysTick deltas, (step - empty loop) difference between n=200 and n=800 steps; mode regular: the samples on their 60 s clock, jitter: a new dt every step";

/// What the signature check times.
const VERIFY_WHAT: &str = "fbg_firmware_app::authenticate: signature trailer, trusted-key lookup, Ed25519 verification (salty, Cortex-M4 assembly), serial check; once per model update";

/// The whole file.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DeviceRecord {
    pub method: String,
    pub step: Vec<StepRow>,
    pub sizes: Sizes,
    pub signature_verification: SignatureVerification,
    pub product: Product,
    pub targets: Targets,
    /// The persistent model store (absent from files written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub store: Option<Store>,
    /// The STM32F405 board's images (`cargo xtask board`); absent when not measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board: Option<crate::board::BoardRecord>,
    /// Spectrum frames on the device (absent from files written before them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<SpectrumRow>,
    /// The product built with spectrum frames (`--features spectrum`), beside the default
    /// `product`; not checked against the RAM budgets (absent from files written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectrum_product: Option<SpectrumProduct>,
    /// The Ed25519 verifier candidates, verify-only images ([`super::verifiers`]); absent when
    /// not measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verifiers: Option<Vec<super::verifiers::VerifierRow>>,
}

/// Footprint of the product built with spectrum frames (`spectrum_product` in device.json).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SpectrumProduct {
    pub flash_bytes: u64,
    pub static_ram_bytes: u64,
    pub stack_peak_boot_bytes: u64,
    /// Serving samples and spectrum frames.
    pub stack_peak_serving_bytes: u64,
    pub stack_peak_update_bytes: u64,
    /// Static RAM + the larger of the boot and update stack peaks.
    pub static_ram_plus_stack_bytes: u64,
    pub static_ram_plus_serving_stack_bytes: u64,
}

impl SpectrumProduct {
    /// The row of the spectrum build's size report.
    pub fn new(r: &SizeReport) -> Self {
        let f = &r.footprint;
        SpectrumProduct {
            flash_bytes: f.flash,
            static_ram_bytes: f.ram_static,
            stack_peak_boot_bytes: r.stack_boot.into(),
            stack_peak_serving_bytes: r.stack_serving.into(),
            stack_peak_update_bytes: r.stack_update.into(),
            static_ram_plus_stack_bytes: f.ram_static + u64::from(r.stack_update.max(r.stack_boot)),
            static_ram_plus_serving_stack_bytes: f.ram_static + u64::from(r.stack_serving),
        }
    }
}

/// Instructions per 512-pixel channel frame with three gratings (`spectrum` in device.json).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SpectrumRow {
    pub what: String,
    pub pixels: u32,
    pub gratings: u32,
    pub method: String,
    pub instructions_per_frame: f64,
    pub per_run: Vec<PerRun>,
    pub target: u64,
    pub met: bool,
    /// A frame's reception alone (begin and chunks on a channel without gratings).
    pub instructions_reception_per_frame: f64,
    /// One 25-pixel window's detection by cross-correlation / by the maximum (the common part).
    pub instructions_per_window_cross_correlation: f64,
    pub instructions_per_window_maximum: f64,
}

impl SpectrumRow {
    /// The row of one spectrum bench.
    pub fn new(b: &super::SpectrumBench) -> Self {
        SpectrumRow {
            what: "fbg_firmware_app::spectrum::SpectrumFront: SpectrumBegin, 6 chunks of 96 pixels (the windows' pixels kept), 3 peaks detected in f32; without the link's framing and the step".into(),
            pixels: 512,
            gratings: 3,
            method: "cross-correlation".into(),
            instructions_per_frame: rounded(b.insns_per_frame, 1),
            per_run: b.per_run.iter().map(|&(n, v)| PerRun { n, instructions_per_step: rounded(v, 1) }).collect(),
            target: super::TARGET_INSNS_SPECTRUM_FRAME as u64,
            met: b.insns_per_frame <= super::TARGET_INSNS_SPECTRUM_FRAME,
            instructions_reception_per_frame: rounded(b.ingest_per_frame, 1),
            instructions_per_window_cross_correlation: rounded(b.window_cross_correlation, 1),
            instructions_per_window_maximum: rounded(b.window_maximum, 1),
        }
    }
}

/// The persistent model store: one update's flash operations, boot time with a full log.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Store {
    pub what: String,
    pub update_bytes: u64,
    pub updates_measured: u32,
    pub flash_ops_per_update: u32,
    pub erases_per_update: u32,
    pub erases_per_update_target: u32,
    pub erases_per_update_met: bool,
    /// Erases of the update whose record rotated the full log (the worst case).
    pub erases_update_rotating_log: u32,
    pub log_records_at_boot: u32,
    pub boot_us_full_log: u32,
    pub boot_us_target: u32,
    pub boot_us_full_log_met: bool,
    pub boot_us_factory_fresh: u32,
    /// The model in a slot, one record in the log.
    pub boot_us_one_record: u32,
    /// Slot A, slot B, log 0, log 1 at the end (refused transfers erase the inactive slot too).
    pub erases_per_sector: [u32; 4],
}

/// How the store figures were measured.
const STORE_WHAT: &str = "product image over the link: accepted updates (one signed model re-installed) and 8 unsigned refusals between two, until both log sectors are full, then one more accepted update (its record rotates the log); flash operations and erases from Status::store before and after each accepted update (the most seen); boot time = Status::store.boot_time_us (SysTick from main to serving) after a power cycle under -icount shift=0 (1 ns per instruction)";

/// One bench model under QEMU -icount.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StepRow {
    pub name: String,
    pub k: usize,
    pub memory_terms: usize,
    pub capacity: usize,
    /// Where the model comes from.
    pub model: String,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub instructions_per_step: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub instructions_per_step_new_dt_every_step: f64,
    /// The estimate of each run on its own ((step − empty) / n).
    pub per_run: Vec<PerRun>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub instructions_per_systick_tick: f64,
    /// 0 under QEMU, which does not model cycles.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub dwt_cycles_per_step: f64,
    pub stack_peak_bytes: u32,
    pub blob_bytes: u64,
    pub lower_bound_ops: usize,
}

/// One run of `n` steps.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PerRun {
    pub n: u32,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub instructions_per_step: f64,
}

/// `size_of` of the device types on the target \[B\].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Sizes {
    pub k: usize,
    pub memory_state_bytes: u64,
    pub stream_state_bytes: u64,
    pub memory_bank_bytes: u64,
    pub compensator_bytes: u64,
    pub model_params_bytes: u64,
    pub frame_reader_bytes: u64,
    pub staging_bytes: u64,
}

/// One signature check of a model update.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SignatureVerification {
    pub what: String,
    pub signed_model_bytes: u64,
    pub instructions: u64,
    pub stack_peak_bytes: u32,
}

/// The product image's footprint \[B\].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Product {
    pub k: usize,
    pub default_model_centres: usize,
    pub default_model_memory_terms: usize,
    pub flash_bytes: u64,
    pub static_ram_bytes: u64,
    pub stack_peak_boot_bytes: u64,
    pub stack_peak_serving_bytes: u64,
    pub stack_peak_update_bytes: u64,
    /// Static RAM + the larger of the boot and update stack peaks.
    pub static_ram_plus_stack_bytes: u64,
    pub static_ram_plus_serving_stack_bytes: u64,
    pub default_blob_bytes: u64,
}

/// The targets of DESIGN §8 against the measurements.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Targets {
    pub instructions_per_step_default: StepTarget,
    pub flash_bytes: Target,
    pub static_ram_plus_stack_bytes: RamTarget,
    pub blob_bytes: Target,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StepTarget {
    pub target: u64,
    pub k: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub measured: f64,
    pub met: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Target {
    pub target: u64,
    pub measured: u64,
    pub met: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RamTarget {
    pub target_serving: u64,
    pub serving_only: u64,
    pub serving_only_met: bool,
    pub target_load_peak: u64,
    pub measured: u64,
    pub met: bool,
}

/// `x` rounded to `digits` decimals exactly as `format!("{x:.digits$}")` prints it (NaN stays
/// NaN).
pub fn rounded(x: f64, digits: usize) -> f64 {
    format!("{x:.digits$}").parse().unwrap_or(f64::NAN)
}

impl Sizes {
    /// The sizes the bench image reported.
    fn of(t: &TypeSizes) -> Self {
        Sizes {
            k: t.k,
            memory_state_bytes: t.memory_state,
            stream_state_bytes: t.stream_state,
            memory_bank_bytes: t.memory_bank,
            compensator_bytes: t.compensator,
            model_params_bytes: t.model_params,
            frame_reader_bytes: t.reader,
            staging_bytes: t.staging,
        }
    }
}

impl DeviceRecord {
    /// The file of one device bench run.
    pub fn new(
        steps: &[StepBench],
        t: &TypeSizes,
        size: &SizeReport,
        v: &VerifyBench,
        store: Option<&StoreBench>,
    ) -> Self {
        let default = steps.iter().find(|b| b.name == "default");
        let dk = default.map(|b| b.k).unwrap_or(0);
        let dins = default.map(|b| b.insns_per_step).unwrap_or(f64::NAN);
        let step = steps
            .iter()
            .map(|b| StepRow {
                name: b.name.to_string(),
                k: b.k,
                memory_terms: b.memory_terms,
                capacity: b.capacity,
                model: b.model_source.to_string(),
                instructions_per_step: rounded(b.insns_per_step, 1),
                instructions_per_step_new_dt_every_step: rounded(b.insns_per_step_jitter, 1),
                per_run: b.per_run.iter().map(|&(n, v)| PerRun { n, instructions_per_step: rounded(v, 1) }).collect(),
                instructions_per_systick_tick: rounded(b.insns_per_tick, 4),
                dwt_cycles_per_step: rounded(b.cycles_per_step, 1),
                stack_peak_bytes: b.stack_peak,
                blob_bytes: b.blob_bytes,
                lower_bound_ops: b.lower_bound_ops,
            })
            .collect();
        DeviceRecord {
            method: METHOD.to_string(),
            step,
            sizes: Sizes::of(t),
            signature_verification: SignatureVerification {
                what: VERIFY_WHAT.to_string(),
                signed_model_bytes: v.bytes,
                instructions: rounded(v.instructions, 0) as u64,
                stack_peak_bytes: v.stack_peak,
            },
            product: product(size, default.map(|b| (b.k, b.memory_terms))),
            targets: targets(size, dk, dins),
            board: None,
            verifiers: None,
            spectrum: None,
            spectrum_product: size.spectrum.as_deref().map(SpectrumProduct::new),
            store: store.map(|b| Store {
                what: STORE_WHAT.to_string(),
                update_bytes: b.update_bytes,
                updates_measured: b.updates,
                flash_ops_per_update: b.ops_per_update,
                erases_per_update: b.erases_per_update,
                erases_per_update_target: TARGET_ERASES_PER_UPDATE,
                erases_per_update_met: b.erases_per_update <= TARGET_ERASES_PER_UPDATE,
                erases_update_rotating_log: b.rotation_erases,
                log_records_at_boot: b.log_events,
                boot_us_full_log: b.boot_us_full_log,
                boot_us_target: TARGET_BOOT_US,
                boot_us_full_log_met: b.boot_us_full_log <= TARGET_BOOT_US,
                boot_us_factory_fresh: b.boot_us_empty,
                boot_us_one_record: b.boot_us_one_record,
                erases_per_sector: b.erases,
            }),
        }
    }
}

/// The product image's figures of `size`; `default`: the default model's (centres, memory
/// terms).
fn product(size: &SizeReport, default: Option<(usize, usize)>) -> Product {
    let f = &size.footprint;
    let total = f.ram_static + size.stack_update.max(size.stack_boot) as u64;
    let serving = f.ram_static + size.stack_serving as u64;
    Product {
        k: PRODUCT_K,
        default_model_centres: default.map(|d| d.0).unwrap_or(0),
        default_model_memory_terms: default.map(|d| d.1).unwrap_or(0),
        flash_bytes: f.flash,
        static_ram_bytes: f.ram_static,
        stack_peak_boot_bytes: size.stack_boot.into(),
        stack_peak_serving_bytes: size.stack_serving.into(),
        stack_peak_update_bytes: size.stack_update.into(),
        static_ram_plus_stack_bytes: total,
        static_ram_plus_serving_stack_bytes: serving,
        default_blob_bytes: size.blob_bytes,
    }
}

/// The targets against `size` and the default model's step (`dk` centres, `dins`
/// instructions).
fn targets(size: &SizeReport, dk: usize, dins: f64) -> Targets {
    let f = &size.footprint;
    let total = f.ram_static + size.stack_update.max(size.stack_boot) as u64;
    let serving = f.ram_static + size.stack_serving as u64;
    Targets {
        instructions_per_step_default: StepTarget {
            target: TARGET_INSNS_K32 as u64,
            k: dk,
            measured: rounded(dins, 1),
            met: dins <= TARGET_INSNS_K32,
        },
        flash_bytes: Target { target: TARGET_FLASH, measured: f.flash, met: f.flash <= TARGET_FLASH },
        static_ram_plus_stack_bytes: RamTarget {
            target_serving: TARGET_RAM,
            serving_only: serving,
            serving_only_met: serving <= TARGET_RAM,
            target_load_peak: TARGET_RAM_LOAD,
            measured: total,
            met: total <= TARGET_RAM_LOAD,
        },
        blob_bytes: Target { target: TARGET_BLOB, measured: size.blob_bytes, met: size.blob_bytes <= TARGET_BLOB },
    }
}

impl DeviceRecord {
    /// The product images' figures measured again (`cargo xtask bench --footprint-only`): the
    /// device types' sizes, the default product's and the spectrum build's footprint and
    /// stack, and the targets that follow from them; the step figures stay.
    pub fn set_footprint(&mut self, size: &SizeReport, t: &TypeSizes) {
        self.sizes = Sizes::of(t);
        let p = &self.product;
        self.product = product(size, Some((p.default_model_centres, p.default_model_memory_terms)));
        let st = &self.targets.instructions_per_step_default;
        self.targets = targets(size, st.k, st.measured);
        self.spectrum_product = size.spectrum.as_deref().map(SpectrumProduct::new);
    }
}

#[cfg(test)]
mod tests;
