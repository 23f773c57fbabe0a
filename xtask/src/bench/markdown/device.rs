//! The device section: instructions per step, the types' sizes, the product image.

use super::*;

pub(super) fn device(s: &mut String, rep: &Report) {
    out!(s, "## Device (Cortex-M4F under QEMU)\n");
    let dev = match &rep.device {
        crate::bench::report::Device::Failed { error } => {
            out!(s, "**The device bench failed:** {error}\n");
            return;
        }
        crate::bench::report::Device::Measured(d) => d,
    };
    out!(
        s,
        "{}. Models: the device bench's fixtures at each K (`xtask/src/fixtures.rs`). Lower bound: the arithmetic operations of one f32 `step` counted from the code ({} operations; table in `shared/src/lib.rs`), each at least one instruction.{}\n",
        dev.record.method,
        dev.arithmetic_lower_bound.as_ref().map_or("", |b| &b.formula),
        if dev.reused_existing_results { " **Reused from an earlier run (--no-device).**" } else { "" }
    );
    out!(s, "Linear algebra in `fbg-shared` (B·φ through nalgebra, the RBF distances as loops): the loops-against-nalgebra table (instructions per step, flash, host time, build time) is in docs/DESIGN.md §7.1, measured once on variant builds the bench does not rebuild.\n");
    out!(s, "| model | K | memory terms | instructions per step | new Δt every step | arithmetic lower bound | measured / bound | blob | bench image stack |\n|---|---|---|---|---|---|---|---|---|");
    for st in &dev.record.step {
        step_row(s, st);
    }
    let sz = &dev.record.sizes;
    out!(
        s,
        "\nDevice types (`size_of` on the target, K = {}): memory state `MemoryState<f32>` {} B, stream state (latches + memory) {} B, `MemoryBank<f32>` {} B, `Compensator<f32, {}>` {} B, parameter slot `ModelParams<f32, 0, 0>` (on the stack during a load; the centres, one at a time, and Γ are read from the blob) {} B, longest staged update {} B (staged in a flash slot outside the image, not in RAM).",
        sz.k,
        sz.memory_state_bytes,
        sz.stream_state_bytes,
        sz.memory_bank_bytes,
        sz.k,
        sz.compensator_bytes,
        sz.model_params_bytes,
        sz.staging_bytes
    );
    let pr = &dev.record.product;
    out!(
        s,
        "\nProduct image (K = {}): flash {} B, static RAM {} B, stack peak {} B at boot, {} B while serving, {} B through a model update; default blob {} B.\n\n    {}\n",
        pr.k,
        pr.flash_bytes,
        pr.static_ram_bytes,
        pr.stack_peak_boot_bytes,
        pr.stack_peak_serving_bytes,
        pr.stack_peak_update_bytes,
        pr.default_blob_bytes,
        dev.command
    );
    if let Some(st) = &dev.record.store {
        out!(
            s,
            "Model store ({}): one update of a {} B signed model takes {} flash operations and at most {} erase(s) ({} when its record rotates the log; {} updates measured; target ≤ {}: {}); boot to serving with a full event log ({} records, the model from a slot, its signature checked) takes {} µs of emulated time (1 ns per instruction; target ≤ {} ms: {}), {} µs from a slot with one record, {} µs factory-fresh; erases per sector at the end (refused transfers erase the inactive slot too): slot A {}, slot B {}, log 0 {}, log 1 {}.\n",
            st.what,
            st.update_bytes,
            st.flash_ops_per_update,
            st.erases_per_update,
            st.erases_update_rotating_log,
            st.updates_measured,
            st.erases_per_update_target,
            if st.erases_per_update_met { "met" } else { "MISSED" },
            st.log_records_at_boot,
            st.boot_us_full_log,
            st.boot_us_target / 1000,
            if st.boot_us_full_log_met { "met" } else { "MISSED" },
            st.boot_us_one_record,
            st.boot_us_factory_fresh,
            st.erases_per_sector[0],
            st.erases_per_sector[1],
            st.erases_per_sector[2],
            st.erases_per_sector[3]
        );
    }
    spectrum(s, &dev.record);
    board(s, dev.record.board.as_ref());
    verifiers(s, dev.record.verifiers.as_deref());
}

/// The Ed25519 verifier candidates (verify-only images), when measured.
fn verifiers(s: &mut String, rows: Option<&[crate::device_bench::verifiers::VerifierRow]>) {
    let Some(rows) = rows else { return };
    out!(
        s,
        "\nEd25519 verifiers, verify-only images on QEMU mps2-an386 (`firmware/verifiers/`; `-icount shift=0`, SysTick calibrated to instructions; flash above the same image without a verifier; stack above the harness's; the RFC 8032 vectors TEST 1, 2, 3 and SHA(abc) on the device, each also refused with a flipped signature bit, a longer message and S + L):\n"
    );
    out!(s, "| verifier | build | flash | stack | instructions per verification | signed model | RFC 8032 | in the product |");
    out!(s, "|---|---|---|---|---|---|---|---|");
    for r in rows {
        out!(
            s,
            "| {} | {} | {} B | {} B | {} | {} B | {}/4 | {} |",
            r.verifier,
            r.options,
            r.flash_bytes,
            r.stack_bytes,
            r.instructions,
            r.signed_model_bytes,
            r.rfc8032_vectors_passed,
            if r.in_product { "yes" } else { "" }
        );
    }
    out!(s, "\n    cargo xtask bench --footprint-only\n");
}

/// Spectrum frames on the device: instructions per frame, and the product built with them.
fn spectrum(s: &mut String, r: &crate::device_bench::record::DeviceRecord) {
    if let Some(sp) = &r.spectrum {
        out!(
            s,
            "Spectrum frames ({}): {} instructions per {}-pixel channel frame with {} gratings, {} (target ≤ {}: {}); of which the frame's reception {} and one 25-pixel window's detection {} ({} with the maximum method: the detector's common part).\n",
            sp.what,
            sp.instructions_per_frame,
            sp.pixels,
            sp.gratings,
            sp.method,
            sp.target,
            if sp.met { "met" } else { "not met" },
            sp.instructions_reception_per_frame,
            sp.instructions_per_window_cross_correlation,
            sp.instructions_per_window_maximum
        );
    }
    if let Some(p) = &r.spectrum_product {
        out!(
            s,
            "Product built with spectrum frames (`--features spectrum`; the default product above is built without them and is the one held to the budgets): flash {} B, static RAM {} B, stack peak {} B at boot, {} B serving samples and spectrum frames, {} B through a model update; static RAM + stack {} B serving (budget 8 192 B: {}), {} B at the update peak (budget 12 288 B: {}).\n",
            p.flash_bytes,
            p.static_ram_bytes,
            p.stack_peak_boot_bytes,
            p.stack_peak_serving_bytes,
            p.stack_peak_update_bytes,
            p.static_ram_plus_serving_stack_bytes,
            if p.static_ram_plus_serving_stack_bytes <= 8192 { "met" } else { "not met" },
            p.static_ram_plus_stack_bytes,
            if p.static_ram_plus_stack_bytes <= 12288 { "met" } else { "not met" }
        );
    }
}

/// The STM32F405 board's images (`cargo xtask board`), or "not measured".
fn board(s: &mut String, b: Option<&crate::board::BoardRecord>) {
    let Some(b) = b else {
        out!(s, "STM32F405 board image (`firmware/board/`): not measured (`cargo xtask board`).\n");
        return;
    };
    let stack = match &b.stack {
        Some(st) => format!(
            "stack peak {} B at boot, {} B while serving, {} B through a model update (the `emulator` build on {}, painted)",
            st.boot, st.serving, st.update, b.golden_machine
        ),
        None => "stack not measured".into(),
    };
    let total = match (b.static_ram_plus_stack_bytes, b.static_ram_plus_stack_met) {
        (Some(t), Some(met)) => format!(
            "static RAM + update stack {t} B (target ≤ {} B: {})",
            b.target_static_ram_plus_stack_bytes,
            if met { "met" } else { "not met" }
        ),
        _ => "static RAM + stack not measured".into(),
    };
    out!(
        s,
        "STM32F405 board image (`firmware/board/`, {}, K = {}): flash {} B (target ≤ {} B: {}), static RAM {} B; {stack}; {total}. Golden vectors on {}: {} sets, {} samples ({} flagged) identical to the host within tolerance.\n\n    cargo xtask board\n",
        b.chip,
        b.k,
        b.flash_bytes,
        b.target_flash_bytes,
        if b.flash_met { "met" } else { "not met" },
        b.static_ram_bytes,
        b.golden_machine,
        b.golden_sets,
        b.golden_samples,
        b.golden_flagged
    );
}

pub(super) fn step_row(s: &mut String, st: &StepRow) {
    let (i, lb) = (st.instructions_per_step, st.lower_bound_ops as f64);
    out!(
        s,
        "| {} | {} | {} | {} | {} | {} | {:.2} | {} B | {} B |",
        st.name,
        st.k,
        st.memory_terms,
        f(i, 0),
        f(st.instructions_per_step_new_dt_every_step, 0),
        f(lb, 0),
        i / lb,
        st.blob_bytes,
        st.stack_peak_bytes
    );
}
