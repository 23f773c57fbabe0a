//! The engine over many rows at once: `fbg-shared`'s batch path, its second part spread over
//! the cores and run in the processor's widest vector instructions (bit for bit the step).

use fbg_shared::Estimate;

use super::super::host::{HostCompensator, HostPreparedModel};
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

/// Samples begun at a time in the f64 batch: while one piece is ended on the cores, the next
/// is begun.
const PIPE_SAMPLES: usize = 4096;

/// Samples each thread ends at a time in the f64 batch (small enough that the thread that
/// began the next piece takes its share of the ending once it is done).
const PAR_SAMPLES: usize = 512;

/// The f64 batch, in pieces: each begun in order on this thread (the stream state) while the
/// piece before it is ended on every core (no state), each in AVX2 where the processor has it.
fn batch_f64(c: &mut HostCompensator, samples: &[fbg_shared::Sample<f64>], out: &mut [Estimate<f64>]) -> usize {
    PENDING.with_borrow_mut(|scratch| {
        let len = samples.len().min(out.len());
        if scratch.len() < len {
            scratch.resize(len, fbg_shared::Pending::default());
        }
        let (model, state) = c.parts_mut();
        let pieces = samples
            .get(..len)
            .unwrap_or(&[])
            .chunks(PIPE_SAMPLES)
            .zip(scratch.chunks_mut(PIPE_SAMPLES))
            .zip(out.chunks_mut(PIPE_SAMPLES));
        // The piece begun last, waiting for its end.
        let mut begun: Option<Begun> = None;
        let mut done = 0;
        for ((s, p), o) in pieces {
            let (n, ended) = match begun.take() {
                Some(b) => rayon::join(|| model.begin_batch(state, s, p), || end_par(model, b)),
                None => (model.begin_batch(state, s, p), 0),
            };
            done += ended;
            begun = Some((s.get(..n).unwrap_or(&[]), p.get(..n).unwrap_or(&[]), o.get_mut(..n).unwrap_or(&mut [])));
        }
        done + begun.map_or(0, |b| end_par(model, b))
    })
}

/// A piece of the f64 batch begun and not yet ended: the samples begun, what their beginning
/// left, and where their estimates go.
type Begun<'a> = (&'a [fbg_shared::Sample<f64>], &'a [fbg_shared::Pending<f64>], &'a mut [Estimate<f64>]);

/// End a begun piece on every core.
fn end_par(model: &HostPreparedModel, (s, p, o): Begun<'_>) -> usize {
    use rayon::prelude::*;
    s.par_chunks(PAR_SAMPLES)
        .zip(p.par_chunks(PAR_SAMPLES))
        .zip(o.par_chunks_mut(PAR_SAMPLES))
        .map(|((s, p), o)| end_f64(model, s, p, o))
        .sum()
}

std::thread_local! {
    /// What the f64 batch's first part leaves for its second, kept between calls: a caller
    /// feeding a long record block after block fills it once instead of once per block.
    static PENDING: std::cell::RefCell<Vec<fbg_shared::Pending<f64>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// [`fbg_shared::PreparedModel::end_batch`], in AVX2 where the processor has it.
fn end_f64(
    c: &HostPreparedModel,
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

/// [`fbg_shared::PreparedModel::end_batch`] compiled with AVX2 (it is inlined here, so its
/// lanes run as 4-wide vectors). No fused multiply-add is enabled: every operation rounds as in
/// the plain build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn end_f64_avx2(
    c: &HostPreparedModel,
    samples: &[fbg_shared::Sample<f64>],
    pending: &[fbg_shared::Pending<f64>],
    out: &mut [Estimate<f64>],
) -> usize {
    c.end_batch(samples, pending, out)
}

#[cfg(test)]
mod tests {
    use fbg_shared::{Estimate, Sample, StreamClock};
    use fbg_testkit::installation::{samples, synthetic_params};

    use super::super::super::host::{HostParams, HOST_CAP};
    use super::super::{Engine, Precision};

    fn bits(e: &Estimate<f64>) -> (Vec<u64>, Vec<u64>, u8) {
        let b = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        (b(&e.values), b(&e.band95), e.flags.0)
    }

    /// Calls of several lengths around the pipeline's pieces (one sample, a piece less one,
    /// several pieces and a part), one with an output shorter than its samples: every
    /// estimate is the step's, bit for bit, in both arithmetics.
    #[test]
    fn the_pipelined_batch_is_the_step_bit_for_bit() {
        let params: HostParams = synthetic_params(24, 5).unwrap().convert::<f64, HOST_CAP>().unwrap();
        let s: Vec<Sample<f64>> = samples(30_000, 11).iter().map(|x| x.cast()).collect();
        for precision in [Precision::F64, Precision::F32] {
            let mut one = Engine::load(&params, precision, StreamClock::Unknown).unwrap();
            let want: Vec<Estimate<f64>> = s.iter().map(|x| one.step(x)).collect();
            let mut batch = Engine::load(&params, precision, StreamClock::Unknown).unwrap();
            let mut got = vec![Estimate::<f64>::default(); s.len()];
            let mut at = 0;
            for n in [1, super::PIPE_SAMPLES - 1, 3 * super::PIPE_SAMPLES + 17, super::PAR_SAMPLES, usize::MAX] {
                let n = n.min(s.len() - at);
                assert_eq!(batch.step_batch(&s[at..at + n], &mut got[at..at + n]), n);
                at += n;
            }
            assert_eq!(at, s.len());
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(bits(g), bits(w), "sample {i} ({precision:?})");
            }
            // An output shorter than the samples: only the samples it holds move the state.
            let mut short = Engine::load(&params, precision, StreamClock::Unknown).unwrap();
            let cut = 2 * super::PIPE_SAMPLES + 5;
            let mut out = vec![Estimate::<f64>::default(); cut];
            assert_eq!(short.step_batch(&s, &mut out), cut);
            let next = short.step(&s[cut]);
            assert_eq!(bits(&next), bits(&want[cut]), "after a short output ({precision:?})");
        }
    }
}
