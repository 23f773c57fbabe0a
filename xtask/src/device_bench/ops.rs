//! The arithmetic lower bound of one device step: the operations of one f32
//! `Compensator::step`, counted from the code (a multiply-add counts as one), which the device
//! bench sets beside its instruction counts.

use anyhow::Result;
use fbg_shared::layout::{Dims, VAR_RANK};
use fbg_shared::{MemoryGroup, MemorySpec};

/// Arithmetic operations of the memory bank and of Γm in one f32 `Compensator::step` on a
/// sample whose Δt equals the previous one (smoothing factors cached), counted from the code
/// (`shared/src/memory/bank.rs`: `MemoryBank::accumulate`, which moves every operator and adds
/// Γm into the outputs; a multiply-add counts as one), for
/// the terms `spec` uses (every slot when `full`): Δt and the cache test 2; per high-pass of a
/// grating or of T_amb 3 (x − s, the multiply-add s + α(x − s), x − s'); per stop term 5
/// (x − r, x + r, 2 compares, x − p); the drift observer 9 (T_g: 4 multiply-adds over
/// [Δλ_1..N, T_amb, 1]; lag 2; − T_amb 1; smoothing 2); Γm one multiply-add per output and
/// used term. 0 without memory terms. A step with a new Δt adds one smoothing factor per used
/// low-pass (a degree-5 series, or `exp` and a subtraction).
pub fn memory_ops(dims: &Dims, spec: &MemorySpec<f32>, full: bool) -> usize {
    let mut ops = 0;
    let mut used = 0;
    for k in 0..dims.memory_len() {
        let Some(t) = spec.term(dims, k) else { continue };
        if !(full || t.parameter > 0.0) {
            continue;
        }
        used += 1;
        ops += match t.group {
            MemoryGroup::GratingHighPass | MemoryGroup::AmbientHighPass => 3,
            MemoryGroup::Stop => 5,
            MemoryGroup::DriftObserver => 5 + dims.stage1_len() - 1,
        };
    }
    if used == 0 {
        return 0;
    }
    2 + ops + dims.n_outputs() * used
}

/// Arithmetic operations of one f32 `Compensator::step` with `k` centres and `memory` operations
/// of the memory bank ([`memory_ops`]), counted from the current code (the table in the
/// `fbg-shared` crate docs): a multiply-add counts as one.
pub fn step_ops(k: usize, memory: usize) -> usize {
    step_ops_dims(&Dims::PAPER, k, memory)
}

/// [`step_ops`] for a model of `dims` (N gratings, ambient, M outputs): the same terms with
/// the dims' lengths (for the paper dims, the table of the crate docs).
pub fn step_ops_dims(dims: &Dims, k: usize, memory: usize) -> usize {
    let (n, m) = (dims.gratings(), dims.n_outputs());
    let (n_s1, n_poly, n_env, n_z) = (dims.stage1_len(), dims.poly_len(), dims.envelope_len(), dims.z_len());
    let exp_neg = 14; // compare, 9 multiply-adds, subtract, negate, 2 exponent-field ops
                      // Distance over the inputs the default (hysteresis-aware) set uses: all but time.
    let per_centre = (1 + n_z - 1) + exp_neg + (m + VAR_RANK + 1);
    let fixed = (n + 2) // finiteness
        + n * 10 // direction latches
        + 2 * n_env // envelope
        + m * (n_s1 - 1) // stage 1
        + (n_poly - 1 - m) + m * n_poly // φ (squares and cross products) and B
        + 2 * n_z // z and ‖z‖²
        + 4 + 1 + VAR_RANK // weak support from ‖ψ‖² (2 compares, 2 products), leverage
        + m + 2 + 5 * m; // finiteness of y, lead time, bands
    fixed + per_centre * k + memory
}

/// [`step_ops_dims`] of a model blob (its dims, centres and memory terms).
pub fn step_ops_of(blob_bytes: &[u8]) -> Result<usize> {
    let p = crate::fixtures::decode(blob_bytes)?;
    Ok(step_ops_dims(&p.dims, p.centres.len(), memory_ops(&p.dims, &p.memory, false)))
}
