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
    /// True for values other than NaN and ±∞.
    fn is_finite(self) -> bool;
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
        libm::sqrt(self)
    }
    #[inline(always)]
    fn exp_neg(self) -> Self {
        if self.is_nan() {
            0.0
        } else {
            libm::exp(-self)
        }
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline(always)]
    fn round_to_i32_scaled(self, scale: f64) -> i32 {
        libm::round(self * scale) as i32
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
    fn is_finite(self) -> bool {
        f32::is_finite(self)
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
/// Rust has no `f32::sqrt` in `core` and libm's `sqrtf` is a software routine there), libm
/// elsewhere. Both are correctly rounded, so the results are identical.
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
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
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
/// bits times a near-minimax degree-5 polynomial for the remainder. About 24 instructions on a
/// Cortex-M4F against roughly 40 for a general `expf`; the RBF layer calls it once per centre
/// per sample.
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

#[cfg(test)]
mod tests {
    use super::*;

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
