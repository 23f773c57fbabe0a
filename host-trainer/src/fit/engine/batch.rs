//! The engine over many rows at once: `fbg-shared`'s batch path, its second part spread over
//! the cores and run in the processor's widest vector instructions (bit for bit the step).

use fbg_shared::Estimate;

use super::super::host::HostCompensator;
use super::Engine;

impl Engine {
    /// Compensate `samples` in order into `out`: bit for bit what [`Engine::step`] gives sample
    /// after sample, through `fbg-shared`'s batch path ([`fbg_shared::Compensator::step_batch`]: the stream
    /// state moved sample after sample, the RBF pass over several samples at once). In f64 the
    /// batch is begun in order and ended on every core ([`fbg_shared::Compensator::begin_batch`],
    /// [`fbg_shared::Compensator::end_batch`]), in the host's wider vector instructions where the
    /// processor has them (AVX2: the same IEEE operations, so the same bits). Returns how many
    /// were compensated (the shorter slice's length).
    pub fn step_batch(&mut self, samples: &[fbg_shared::Sample<f64>], out: &mut [Estimate<f64>]) -> usize {
        match self {
            Engine::F64(c) => batch_f64(c, samples, out),
            Engine::F32(c) => {
                let mut done = 0;
                let mut s32 = [fbg_shared::Sample::<f32>::default(); BATCH_F32];
                let mut e32 = [Estimate::<f32>::default(); BATCH_F32];
                for (ss, os) in samples.chunks(BATCH_F32).zip(out.chunks_mut(BATCH_F32)) {
                    // No sample moves the state without its estimate written.
                    let k = ss.len().min(os.len());
                    for (d, s) in s32.iter_mut().zip(ss) {
                        *d = s.cast::<f32>();
                    }
                    let n = c.step_batch(s32.get(..k).unwrap_or(&[]), &mut e32);
                    for (o, e) in os.iter_mut().zip(e32.iter()).take(n) {
                        *o = e.cast();
                    }
                    done += n;
                }
                done
            }
        }
    }
}

/// Samples the f32 engine converts at a time.
const BATCH_F32: usize = 256;

/// Samples each thread ends at a time in the f64 batch.
const PAR_SAMPLES: usize = 2048;

/// The f64 batch: begun in order on this thread (the stream state), ended on every core in
/// pieces (no state), each piece in AVX2 where the processor has it.
fn batch_f64(c: &mut HostCompensator, samples: &[fbg_shared::Sample<f64>], out: &mut [Estimate<f64>]) -> usize {
    use rayon::prelude::*;
    let mut pending = vec![fbg_shared::Pending::<f64>::default(); samples.len().min(out.len())];
    let n = c.begin_batch(samples, &mut pending);
    let c: &HostCompensator = c;
    let samples = samples.get(..n).unwrap_or(&[]);
    let out = out.get_mut(..n).unwrap_or(&mut []);
    samples
        .par_chunks(PAR_SAMPLES)
        .zip(pending.par_chunks(PAR_SAMPLES))
        .zip(out.par_chunks_mut(PAR_SAMPLES))
        .map(|((s, p), o)| end_f64(c, s, p, o))
        .sum()
}

/// [`HostCompensator::end_batch`], in AVX2 where the processor has it.
fn end_f64(
    c: &HostCompensator,
    samples: &[fbg_shared::Sample<f64>],
    pending: &[fbg_shared::Pending<f64>],
    out: &mut [Estimate<f64>],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (checked just above), the one requirement of a
        // function compiled with it enabled.
        return unsafe { end_f64_avx2(c, samples, pending, out) };
    }
    c.end_batch(samples, pending, out)
}

/// [`HostCompensator::end_batch`] compiled with AVX2 (it is inlined here, so its lanes run as
/// 4-wide vectors). No fused multiply-add is enabled: every operation rounds as in the plain
/// build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn end_f64_avx2(
    c: &HostCompensator,
    samples: &[fbg_shared::Sample<f64>],
    pending: &[fbg_shared::Pending<f64>],
    out: &mut [Estimate<f64>],
) -> usize {
    c.end_batch(samples, pending, out)
}
