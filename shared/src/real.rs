//! The scalar type of the inference: `f32` on the device, `f64` on the host.
//!
//! The same generic code runs in both precisions, so the trainer's f64 evaluation and the
//! device's f32 answers come from one implementation and can only differ by rounding.

use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// Floating-point operations the compensator needs, implemented for `f32` and `f64`.
pub trait Real:
    Copy
    + Default
    + PartialOrd
    + core::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + nalgebra::Scalar
    + nalgebra::ClosedAddAssign
    + nalgebra::ClosedMulAssign
    + num_traits::Zero
    + num_traits::One
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Positive infinity.
    const INFINITY: Self;
    /// Quiet NaN.
    const NAN: Self;
    /// √2.
    const SQRT_2: Self;
    /// Conversion from f64 (rounds to nearest for f32).
    fn from_f64(v: f64) -> Self;
    /// Widening conversion to f64.
    fn to_f64(self) -> f64;
    /// Conversion to f32 (identity for f32).
    fn to_f32(self) -> f32;
    /// Conversion from another precision without passing through f64 when the target is f32
    /// (so an f32 device never links software double arithmetic).
    fn from_real<G: Real>(g: G) -> Self;
    /// `self * a + b` with the product rounded (`vmla.f32` on a Cortex-M4F), identical on host
    /// and device.
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// Square root (IEEE-exact in both precisions).
    fn sqrt(self) -> Self;
    /// `e^(-x)` for `x >= 0`; returns 0 for `x` beyond the underflow point and for NaN.
    fn exp_neg(self) -> Self;
    /// Natural logarithm (libm's `log`/`logf`; NaN below 0, −∞ at 0). Used by the spectrum's
    /// log-parabola fits, never by the compensator's step.
    fn ln(self) -> Self;
    /// True for values other than NaN and ±∞.
    fn is_finite(self) -> bool;
    /// |self| (the sign bit cleared: `vabs.f32` on a Cortex-M4F).
    fn abs(self) -> Self;
    /// `round(self · scale)` as i32, saturating; NaN gives 0.
    fn round_to_i32_scaled(self, scale: f64) -> i32;
    /// Larger of two values (NaN-free inputs assumed).
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        if other > self {
            other
        } else {
            self
        }
    }
}

/// Every entry of `a` in another precision ([`Real::from_real`]: exact from f32 to f64, rounded
/// to nearest from f64 to f32).
pub fn cast_array<F: Real, G: Real, const N: usize>(a: &[F; N]) -> [G; N] {
    let mut out = [G::ZERO; N];
    for (o, &v) in out.iter_mut().zip(a.iter()) {
        *o = G::from_real(v);
    }
    out
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const INFINITY: Self = f64::INFINITY;
    const NAN: Self = f64::NAN;
    const SQRT_2: Self = core::f64::consts::SQRT_2;
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn from_real<G: Real>(g: G) -> Self {
        g.to_f64()
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self * a + b
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        sqrt_f64(self)
    }
    #[inline(always)]
    fn exp_neg(self) -> Self {
        exp_neg_f64(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        libm::log(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn round_to_i32_scaled(self, scale: f64) -> i32 {
        // `libm::round(v) as i32` without the libm call (the latches round three times per
        // sample): truncate, then look at the exact remainder (v − trunc(v) is exact in f64),
        // saturating like `as`; NaN gives 0.
        // Branch-free: which way a remainder goes is data, not a pattern a predictor learns.
        let v = self * scale;
        let t = v as i64;
        let frac = v - t as f64;
        let r = t.saturating_add((frac >= 0.5) as i64).saturating_sub((frac <= -0.5) as i64);
        r.clamp(i32::MIN as i64, i32::MAX as i64) as i32
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const INFINITY: Self = f32::INFINITY;
    const NAN: Self = f32::NAN;
    const SQRT_2: Self = core::f32::consts::SQRT_2;
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn from_real<G: Real>(g: G) -> Self {
        g.to_f32()
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self * a + b
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        sqrt_f32(self)
    }
    #[inline(always)]
    fn exp_neg(self) -> Self {
        exp_neg_f32(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        libm::logf(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn round_to_i32_scaled(self, scale: f64) -> i32 {
        // Round half away from zero without libm: truncate, then look at the exact remainder
        // (v − trunc(v) is exact in f32). Power-of-two scales are exact too, so an f32 input
        // gives the same count as `libm::round` in f64. `as` saturates and maps NaN to 0.
        let v = self * scale as f32;
        let t = v as i32;
        let frac = v - t as f32;
        if frac >= 0.5 {
            t.saturating_add(1)
        } else if frac <= -0.5 {
            t.saturating_sub(1)
        } else {
            t
        }
    }
}

/// IEEE square root: the FPU's `vsqrt.f32` on a hard-float Arm target (one instruction; stable
/// Rust has no `f32::sqrt` in `core` and libm's `sqrtf` is a software routine there), SSE's on
/// x86-64 (see [`sqrt_f64`]), libm elsewhere. Each is correctly rounded, so the results are
/// identical.
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let r: u32;
        // SAFETY: register-only FPU arithmetic; s0 is declared clobbered.
        unsafe {
            core::arch::asm!(
                "vmov s0, {x}",
                "vsqrt.f32 s0, s0",
                "vmov {r}, s0",
                x = in(reg) x.to_bits(),
                r = lateout(reg) r,
                out("s0") _,
                options(pure, nomem, nostack, preserves_flags)
            );
        }
        f32::from_bits(r)
    }
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_mm_cvtss_f32, _mm_set_ss, _mm_sqrt_ss};
        // SAFETY: SSE is part of the x86-64 baseline; register-only arithmetic.
        unsafe { _mm_cvtss_f32(_mm_sqrt_ss(_mm_set_ss(x))) }
    }
    #[cfg(not(any(all(target_arch = "arm", target_abi = "eabihf"), target_arch = "x86_64")))]
    {
        libm::sqrtf(x)
    }
}

/// IEEE square root in f64: the SSE2 instruction on x86-64 (baseline there; in a function
/// compiled with AVX, its VEX form), which the compiler schedules and keeps in the vector
/// unit's encoding, where libm's is an opaque `asm!` block of the legacy encoding that a host's
/// batch path stalls on; libm elsewhere. Both are correctly rounded, so the results are
/// identical.
#[inline(always)]
fn sqrt_f64(x: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_mm_cvtsd_f64, _mm_set_sd, _mm_sqrt_pd};
        // SAFETY: SSE2 is part of the x86-64 baseline; register-only arithmetic.
        unsafe { _mm_cvtsd_f64(_mm_sqrt_pd(_mm_set_sd(x))) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        libm::sqrt(x)
    }
}

/// Multiply-add in f32 as plain code (LLVM emits one `vmla.f32` on a Cortex-M4F).
#[inline(always)]
fn fma_f32(x: f32, a: f32, b: f32) -> f32 {
    x * a + b
}

/// `e^(-x)` in single precision for `x >= -0.3`, relative error below 5e-7; 0 from `x >= 80`
/// (where `e^-x < 2e-35`) and for NaN. (The RBF distance can come out a rounding error below
/// zero; that gives a value a rounding error above 1, as `exp` would.)
///
/// A branch-light replacement for `expf`: a rounded integer power of two placed in the exponent
/// bits times a near-minimax degree-5 polynomial for the remainder: the operations are counted
/// in the crate docs' cost table, far fewer than a general `expf` needs; the RBF layer calls it
/// once per centre per sample.
#[inline(always)]
pub fn exp_neg_f32(x: f32) -> f32 {
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(x < 80.0) {
        return 0.0;
    }
    // n = round(x·log2 e) by the magic-number trick: adding 1.5·2^23 leaves n in the low
    // mantissa bits of t (x·log2 e is in [-0.5, 115.5] here), and t − MAGIC is n exactly.
    const MAGIC: f32 = 12_582_912.0;
    const LN2_HI: f32 = 0.693_145_75; // 0x3F31_7200, 16 significant bits
    const LN2_LO: f32 = 1.428_606_8e-6;
    let t = fma_f32(x, core::f32::consts::LOG2_E, MAGIC);
    let nf = t - MAGIC;
    let u = fma_f32(nf, LN2_LO, fma_f32(nf, LN2_HI, -x));
    // e^u = 1 + u + u²·q(u), q a near-minimax cubic on |u| <= 0.347 (relative error < 5e-7
    // in f32 evaluation).
    let mut p = 0.008_357_204;
    p = fma_f32(p, u, 0.041_833_83);
    p = fma_f32(p, u, 0.166_666_31);
    p = fma_f32(p, u, 0.499_997_5);
    p = fma_f32(p, u, 1.0);
    p = fma_f32(p, u, 1.0);
    // Scale by 2^-n through the exponent field: t's bits are MAGIC's plus n, and MAGIC's bits
    // shifted left by 23 vanish (its low 9 bits are zero), so `t_bits << 23` is `n << 23`.
    f32::from_bits(p.to_bits().wrapping_sub(t.to_bits() << 23))
}

/// `e^(-x)` in double precision for `x >= -0.3`, within 2 ulp of the correctly rounded value;
/// 0 from `x >= 708` (where `e^-x < 3.3e-308`) and for NaN.
///
/// The host's f64 reference path calls it once per centre per sample, millions of times in a
/// fit, where a general `exp` (libm) costs several times more. Same scheme as
/// [`exp_neg_f32`]: n = round(x·log2 e) by the magic-number trick, a Cody–Waite reduction
/// u = n·ln 2 − x (|u| <= 0.347), e^u by its Taylor polynomial to degree 12 (truncation
/// below 2e-16 relative), scaled by 2^-n through the exponent field. Plain multiplies and adds,
/// so every platform rounds it identically.
#[inline(always)]
pub fn exp_neg_f64(x: f64) -> f64 {
    // 1.5·2^52: t − MAGIC is round(x·log2 e) exactly, for |x·log2 e| < 2^51.
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    const LN2_HI: f64 = 6.931_471_803_691_238e-1; // 0x3FE62E42FEE00000: n·LN2_HI is exact
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let t = x * core::f64::consts::LOG2_E + MAGIC;
    let nf = t - MAGIC;
    let u = (nf * LN2_HI - x) + nf * LN2_LO;
    // Taylor coefficients 1/k!, k = 12 down to 2, in an Estrin-like split (two chains of
    // Horner in u², then one step) to shorten the dependency chain.
    let u2 = u * u;
    let mut even = 2.087_675_698_786_81e-9; // 1/12!
    even = even * u2 + 2.755_731_922_398_589e-7; // 1/10!
    even = even * u2 + 2.480_158_730_158_73e-5; // 1/8!
    even = even * u2 + 1.388_888_888_888_889e-3; // 1/6!
    even = even * u2 + 4.166_666_666_666_666_4e-2; // 1/4!
    even = even * u2 + 0.5; // 1/2!
    let mut odd = 2.505_210_838_544_172e-8; // 1/11!
    odd = odd * u2 + 2.755_731_922_398_589_3e-6; // 1/9!
    odd = odd * u2 + 1.984_126_984_126_984e-4; // 1/7!
    odd = odd * u2 + 8.333_333_333_333_333e-3; // 1/5!
    odd = odd * u2 + 1.666_666_666_666_666_6e-1; // 1/3!
                                                 // e^u = 1 + u + u²·(even + u·odd)
    let p = 1.0 + (u + u2 * (even + u * odd));
    // Scale by 2^-n: t's bits are MAGIC's plus n (two's complement for n < 0), and MAGIC's low
    // 12 bits are zero, so `t_bits << 52` is `n << 52` (wrapping).
    let e = f64::from_bits(p.to_bits().wrapping_sub(t.to_bits() << 52));
    // Chosen at the end rather than returned early: no branch, so a batch of samples' RBF pass
    // ([`crate::PreparedModel::step_batch`]) runs as vectors. Beyond the range (and for NaN)
    // the value computed above is discarded.
    if x < 708.0 {
        e
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_f64_is_within_two_ulp_over_its_range() {
        let ulp = |v: f64| f64::from_bits(v.to_bits() + 1) - v;
        let mut worst = 0.0f64;
        let mut x = -0.3f64;
        while x < 707.9 {
            let got = exp_neg_f64(x);
            let want = libm::exp(-x);
            worst = worst.max(((got - want) / ulp(want)).abs());
            x += 0.000_731;
        }
        assert!(worst <= 2.0, "worst error {worst} ulp");
    }

    #[test]
    fn f64_tick_rounding_is_libm_round_saturated() {
        let cases = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            1e-300,
            123.456,
            -987.654_321,
            2_097_151.999_5,
            4.5e15,
            1e18,
            -1e18,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MAX,
            f64::MIN,
        ];
        for v in cases {
            for scale in [1.0, 1024.0] {
                let want = libm::round(v * scale) as i32;
                assert_eq!(v.round_to_i32_scaled(scale), want, "{v} × {scale}");
            }
        }
        let mut x = -3000.0f64;
        while x < 3000.0 {
            assert_eq!(x.round_to_i32_scaled(1024.0), libm::round(x * 1024.0) as i32, "{x}");
            x += 0.000_488_281_25 * 0.37;
        }
    }

    #[test]
    fn exp_neg_f64_edges() {
        assert_eq!(exp_neg_f64(0.0), 1.0);
        assert_eq!(exp_neg_f64(708.0), 0.0);
        assert_eq!(exp_neg_f64(f64::NAN), 0.0);
        assert_eq!(exp_neg_f64(f64::INFINITY), 0.0);
        assert!(exp_neg_f64(707.9) > 0.0 && exp_neg_f64(707.9).is_normal());
        assert_eq!(exp_neg_f64(1.0), libm::exp(-1.0));
    }

    #[test]
    fn exp_neg_f32_is_accurate_over_its_range() {
        let mut worst = 0.0f64;
        let mut x = 0.0f32;
        while x < 79.9 {
            let got = exp_neg_f32(x) as f64;
            let want = libm::exp(-(x as f64));
            let rel = ((got - want) / want).abs();
            worst = worst.max(rel);
            x += 0.001_3;
        }
        assert!(worst < 5e-7, "worst relative error {worst}");
    }

    #[test]
    fn exp_neg_f32_edges() {
        assert_eq!(exp_neg_f32(0.0), 1.0);
        assert!((exp_neg_f32(-1e-6) - 1.000_001).abs() < 1e-7, "a rounding-size negative distance");
        assert_eq!(exp_neg_f32(80.0), 0.0);
        assert_eq!(exp_neg_f32(f32::NAN), 0.0);
        assert_eq!(exp_neg_f32(f32::INFINITY), 0.0);
        assert!(exp_neg_f32(79.9) > 0.0);
    }
}
