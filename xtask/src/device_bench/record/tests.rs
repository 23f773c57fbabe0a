//! The typed file against the `format!` writer it replaced (kept here as the oracle of the
//! format), and against the committed BENCHMARKS.json.

use std::fmt::Write as _;

use super::*;
use crate::elf::Footprint;
use crate::targets::{PRODUCT_K, TARGET_BLOB, TARGET_FLASH, TARGET_INSNS_K32, TARGET_RAM, TARGET_RAM_LOAD};

fn sample() -> (Vec<StepBench>, TypeSizes, SizeReport, VerifyBench) {
    let step = |name: &'static str, k: usize, insns: f64| StepBench {
        name,
        k,
        memory_terms: 14,
        capacity: 32,
        insns_per_tick: 40.000049,
        insns_per_step: insns,
        per_run: vec![(200, insns - 2.25), (800, insns - 0.55)],
        insns_per_step_jitter: insns + 321.049_999,
        stack_peak: 5340,
        blob_bytes: 1464,
        lower_bound_ops: 486,
        cycles_per_step: 0.0,
        model_source: "fbg-trainer train (paper preset, seed 7): the product's default model",
    };
    let steps = vec![step("default", 8, 2343.2499), step("plain_k64", 64, 4100.05), step("memory_k0", 0, 2141.0)];
    let sizes = TypeSizes {
        k: 32,
        memory_state: 320,
        stream_state: 384,
        memory_bank: 492,
        compensator: 6280,
        model_params: 2312,
        reader: 264,
        staging: 4192,
    };
    let size = SizeReport {
        footprint: Footprint { flash: 52256, ram_static: 6560, sections: Vec::new() },
        stack_boot: 5156,
        stack_serving: 1584,
        stack_update: 5300,
        blob_bytes: 1464,
        store_region: 65536,
        spectrum: None,
    };
    let verify = VerifyBench { bytes: 1552, instructions: 3_959_319.6, stack_peak: 3620 };
    (steps, sizes, size, verify)
}

#[test]
fn the_typed_file_has_the_keys_and_values_of_the_format_writer() {
    let (steps, sizes, size, verify) = sample();
    let old: serde_json::Value = serde_json::from_str(&to_json(&steps, &sizes, &size, &verify)).unwrap();
    let record = DeviceRecord::new(&steps, &sizes, &size, &verify, None);
    let new = serde_json::to_value(&record).unwrap();
    assert_eq!(new, old);
    // And it reads back into the same type.
    let back: DeviceRecord = serde_json::from_value(new.clone()).unwrap();
    assert_eq!(serde_json::to_value(&back).unwrap(), new);
}

#[test]
fn the_committed_device_results_read_into_the_record() {
    let path = crate::cmd::root().join("BENCHMARKS.json");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let mut device = v["device"].clone();
    for k in ["command", "reused_existing_results", "arithmetic_lower_bound"] {
        device.as_object_mut().unwrap().remove(k);
    }
    let r: DeviceRecord = serde_json::from_value(device.clone()).unwrap();
    assert_eq!(serde_json::to_value(&r).unwrap(), device);
}

/// The writer `device.json` had before it was typed, verbatim.
fn to_json(steps: &[StepBench], t: &TypeSizes, size: &SizeReport, v: &VerifyBench) -> String {
    let mut s = String::from("{\n  \"method\": \"qemu-system-arm mps2-an386 -icount shift=0, SysTick deltas, (step - empty loop) difference between n=200 and n=800 steps; mode regular: the samples on their 60 s clock, jitter: a new dt every step\",\n  \"step\": [\n");
    for (i, b) in steps.iter().enumerate() {
        let _ = write!(
            s,
            "    {{\"name\": {:?}, \"k\": {}, \"memory_terms\": {}, \"capacity\": {}, \"model\": {:?}, \"instructions_per_step\": {:.1}, \"instructions_per_step_new_dt_every_step\": {:.1}, \"per_run\": [{}], \"instructions_per_systick_tick\": {:.4}, \"dwt_cycles_per_step\": {:.1}, \"stack_peak_bytes\": {}, \"blob_bytes\": {}, \"lower_bound_ops\": {}}}{}",
            b.name,
            b.k,
            b.memory_terms,
            b.capacity,
            b.model_source,
            b.insns_per_step,
            b.insns_per_step_jitter,
            b.per_run.iter().map(|(n, v)| format!("{{\"n\": {n}, \"instructions_per_step\": {v:.1}}}")).collect::<Vec<_>>().join(", "),
            b.insns_per_tick,
            b.cycles_per_step,
            b.stack_peak,
            b.blob_bytes,
            b.lower_bound_ops,
            if i + 1 < steps.len() { "," } else { "" }
        );
        s.push('\n');
    }
    let _ = write!(
        s,
        "  ],\n  \"sizes\": {{\"k\": {}, \"memory_state_bytes\": {}, \"stream_state_bytes\": {}, \"memory_bank_bytes\": {}, \"compensator_bytes\": {}, \"model_params_bytes\": {}, \"frame_reader_bytes\": {}, \"staging_bytes\": {}}},\n",
        t.k, t.memory_state, t.stream_state, t.memory_bank, t.compensator, t.model_params, t.reader, t.staging
    );
    let _ = writeln!(
        s,
        "  \"signature_verification\": {{\"what\": \"fbg_firmware_app::authenticate: signature trailer, trusted-key lookup, Ed25519 verification (salty, Cortex-M4 assembly), serial check; once per model update\", \"signed_model_bytes\": {}, \"instructions\": {:.0}, \"stack_peak_bytes\": {}}},",
        v.bytes, v.instructions, v.stack_peak
    );
    let f = &size.footprint;
    let total = f.ram_static + size.stack_update.max(size.stack_boot) as u64;
    let serving = f.ram_static + size.stack_serving as u64;
    let default = steps.iter().find(|b| b.name == "default");
    let dk = default.map(|b| b.k).unwrap_or(0);
    let dins = default.map(|b| b.insns_per_step).unwrap_or(f64::NAN);
    let _ = writeln!(
        s,
        "  \"product\": {{\"k\": {PRODUCT_K}, \"default_model_centres\": {dk}, \"default_model_memory_terms\": {}, \"flash_bytes\": {}, \"static_ram_bytes\": {}, \"stack_peak_boot_bytes\": {}, \"stack_peak_serving_bytes\": {}, \"stack_peak_update_bytes\": {}, \"static_ram_plus_stack_bytes\": {}, \"static_ram_plus_serving_stack_bytes\": {}, \"default_blob_bytes\": {}}},",
        default.map(|b| b.memory_terms).unwrap_or(0), f.flash, f.ram_static, size.stack_boot, size.stack_serving, size.stack_update, total, serving, size.blob_bytes
    );
    let _ = write!(
        s,
        "  \"targets\": {{\"instructions_per_step_default\": {{\"target\": {TARGET_INSNS_K32}, \"k\": {dk}, \"measured\": {dins:.1}, \"met\": {}}}, \"flash_bytes\": {{\"target\": {TARGET_FLASH}, \"measured\": {}, \"met\": {}}}, \"static_ram_plus_stack_bytes\": {{\"target_serving\": {TARGET_RAM}, \"serving_only\": {serving}, \"serving_only_met\": {}, \"target_load_peak\": {TARGET_RAM_LOAD}, \"measured\": {total}, \"met\": {}}}, \"blob_bytes\": {{\"target\": {TARGET_BLOB}, \"measured\": {}, \"met\": {}}}}}\n}}",
        dins <= TARGET_INSNS_K32,
        f.flash,
        f.flash <= TARGET_FLASH,
        serving <= TARGET_RAM,
        total <= TARGET_RAM_LOAD,
        size.blob_bytes,
        size.blob_bytes <= TARGET_BLOB
    );
    s.push('\n');
    s
}
