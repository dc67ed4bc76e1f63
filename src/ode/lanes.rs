//! Arithmetic written once for one number or for `W` numbers side by side.
//!
//! [`Real`] is the small set of operations the rig's right-hand side and the Dormand–Prince
//! step need; it is implemented by `f64` (the scalar path) and by [`Lanes<W>`] (the batch path,
//! one sweep point per lane). Code generic over `Real` therefore performs, in every lane, the
//! same IEEE operations in the same order as the scalar code does for that lane's point alone:
//! a point's result cannot depend on the lane or batch it ran in. Branches become
//! [`Real::select`]s, which evaluate both sides (as the scalar instance then does too).
//!
//! The transcendental functions the right-hand side needs, [`exp`], [`cos`], [`sin`], [`ln`],
//! [`ln_1p`] and [`pow`], are written here in the same generic arithmetic (the platform's `libm`
//! has no vector form, and a vector form of another library would not round as the scalar path
//! does). Each is within an ulp or a few of the platform's on the ranges the rig uses (tests
//! below, against `std`).
//!
//! [`Lanes<W>`] holds `[f64; W]` and every operation is an element-wise loop marked
//! `#[inline(always)]`: inside a function compiled for a vector instruction set
//! ([`crate::ode::batch`] dispatches with `pulp`) the compiler emits one vector instruction per
//! operation, and with no such set the same code runs as scalar loops, with the same results.
//! Rust never contracts a multiply and an add into a fused one on its own, so enabling FMA does
//! not change a result either.
// The kernels below step several arrays of one state (stages, weights, tolerances) with one
// index, as the method's equations are written.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A number, or `W` numbers in lanes, with the operations the generic code needs.
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A truth value per lane.
    type Mask: Copy;
    /// `x` in every lane.
    fn splat(x: f64) -> Self;
    /// `|x|`.
    fn abs(self) -> Self;
    /// `√x`.
    fn sqrt(self) -> Self;
    /// `f64::max` lane by lane (the other operand where one is NaN).
    fn max(self, o: Self) -> Self;
    /// `f64::min` lane by lane.
    fn min(self, o: Self) -> Self;
    /// `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// `self < o`.
    fn lt(self, o: Self) -> Self::Mask;
    /// `self == o`.
    fn eq(self, o: Self) -> Self::Mask;
    /// Lane-wise or.
    fn or(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `a` where `m`, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `2^k` for an integer `k` in −1022 ..= 1023, given `k + 1.5·2^52` (whose low mantissa
    /// bits hold `k`: integer operations on the bits, which vector units have for doubles'
    /// width where they lack a conversion to integers).
    fn pow2i(shifted: Self) -> Self;
    /// Bits 0 and 1 of an integer `k` (its quadrant, for [`cos`]), given `k + 1.5·2^52`.
    fn quadrant(shifted: Self) -> (Self::Mask, Self::Mask);
    /// For a positive normal `x`: `(m, e)` with `x = m · 2^e`, `m` in [1, 2) and `e` an
    /// integer, as a double (for [`ln`]).
    fn split_exp(self) -> (Self, Self);
}

impl Real for f64 {
    type Mask = bool;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        f64::min(self, o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn lt(self, o: Self) -> bool {
        self < o
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn or(a: bool, b: bool) -> bool {
        a | b
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m { a } else { b }
    }
    #[inline(always)]
    fn pow2i(shifted: Self) -> Self {
        f64::from_bits(shifted.to_bits().wrapping_add(1023) << 52)
    }
    #[inline(always)]
    fn quadrant(shifted: Self) -> (bool, bool) {
        let b = shifted.to_bits();
        (b & 1 != 0, b & 2 != 0)
    }
    #[inline(always)]
    fn split_exp(self) -> (Self, Self) {
        let b = self.to_bits();
        let e = ((b >> 52) & 0x7ff) as i64 - 1023;
        let m = f64::from_bits((b & ((1u64 << 52) - 1)) | (1023u64 << 52));
        (m, e as f64)
    }
}

/// `W` doubles side by side, one sweep point per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Lanes<const W: usize>(pub [f64; W]);

impl<const W: usize> Default for Lanes<W> {
    fn default() -> Self {
        Lanes([0.0; W])
    }
}

impl<const W: usize> Lanes<W> {
    /// Lane `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> f64 {
        self.0[i]
    }
    /// Sets lane `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, x: f64) {
        self.0[i] = x;
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        let mut o = [0.0; W];
        for i in 0..W {
            o[i] = f(self.0[i]);
        }
        Lanes(o)
    }
    #[inline(always)]
    fn zip(self, b: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut o = [0.0; W];
        for i in 0..W {
            o[i] = f(self.0[i], b.0[i]);
        }
        Lanes(o)
    }
    #[inline(always)]
    fn test(self, b: Self, f: impl Fn(f64, f64) -> bool) -> [u64; W] {
        let mut o = [0; W];
        for i in 0..W {
            o[i] = lane_mask(f(self.0[i], b.0[i]));
        }
        o
    }
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl<const W: usize> $tr for Lanes<W> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, b: Self) -> Self {
                self.zip(b, |x, y| x $op y)
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl<const W: usize> Neg for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|x| -x)
    }
}

/// All bits set where `c`: a lane mask as the vector units make it.
#[inline(always)]
fn lane_mask(c: bool) -> u64 {
    if c { !0 } else { 0 }
}

impl<const W: usize> Real for Lanes<W> {
    /// All bits set in a lane where true: comparisons and selections then compile to the
    /// vector units' own masks and blends.
    type Mask = [u64; W];
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Lanes([x; W])
    }
    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f64::abs)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, f64::max)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.zip(o, f64::min)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> [u64; W] {
        self.test(o, |x, y| x > y)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> [u64; W] {
        self.test(o, |x, y| x < y)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> [u64; W] {
        self.test(o, |x, y| x == y)
    }
    #[inline(always)]
    fn or(a: [u64; W], b: [u64; W]) -> [u64; W] {
        let mut o = [0; W];
        for i in 0..W {
            o[i] = a[i] | b[i];
        }
        o
    }
    #[inline(always)]
    fn select(m: [u64; W], a: Self, b: Self) -> Self {
        let mut o = [0.0; W];
        for i in 0..W {
            o[i] = f64::from_bits((a.0[i].to_bits() & m[i]) | (b.0[i].to_bits() & !m[i]));
        }
        Lanes(o)
    }
    #[inline(always)]
    fn pow2i(shifted: Self) -> Self {
        shifted.map(<f64 as Real>::pow2i)
    }
    #[inline(always)]
    fn quadrant(shifted: Self) -> ([u64; W], [u64; W]) {
        let (mut a, mut b) = ([0; W], [0; W]);
        for i in 0..W {
            let bits = shifted.0[i].to_bits();
            a[i] = 0u64.wrapping_sub(bits & 1);
            b[i] = 0u64.wrapping_sub((bits >> 1) & 1);
        }
        (a, b)
    }
    #[inline(always)]
    fn split_exp(self) -> (Self, Self) {
        let (mut m, mut e) = ([0.0; W], [0.0; W]);
        for i in 0..W {
            (m[i], e[i]) = self.0[i].split_exp();
        }
        (Lanes(m), Lanes(e))
    }
}

/// `1.5 · 2^52`: adding and subtracting it rounds a double below `2^51` in magnitude to the
/// nearest integer (ties to even) in two exact-or-rounded IEEE operations, the same in every
/// lane.
const ROUND_SHIFT: f64 = 6_755_399_441_055_744.0;

/// Nearest integer `k` of `x` (|x| < 2^51), as a double, and `k + 1.5·2^52`, whose bits hold
/// `k` ([`Real::pow2i`], [`Real::quadrant`]).
#[inline(always)]
fn round_int<T: Real>(x: T) -> (T, T) {
    let shifted = x + T::splat(ROUND_SHIFT);
    (shifted - T::splat(ROUND_SHIFT), shifted)
}

/// `Σ c_i x^i` by Estrin's scheme: pairs `c_2i + c_2i+1 x` first, then pairs of those with
/// `x²`, and so on; the dependency chain is `log2 N` levels deep instead of Horner's `N`, which
/// is what one integration's chain of right-hand sides waits on.
#[inline(always)]
fn estrin<T: Real, const N: usize>(x: T, c: &[f64; N]) -> T {
    let mut v: [T; N] = std::array::from_fn(|i| T::splat(c[i]));
    let (mut len, mut p) = (N, x);
    while len > 1 {
        let half = len.div_ceil(2);
        for i in 0..half {
            v[i] = if 2 * i + 1 < len {
                v[2 * i] + p * v[2 * i + 1]
            } else {
                v[2 * i]
            };
        }
        len = half;
        p = p * p;
    }
    v[0]
}

/// `1/ln 2`.
const INV_LN2: f64 = std::f64::consts::LOG2_E;
/// `ln 2` in two parts: 32 significant bits (so `k · LN2_HI` is exact for |k| < 2^21) and the
/// rest.
const LN2_HI: f64 = 0.693_147_180_601_954_5;
const LN2_LO: f64 = -4.200_915_072_681_084_6e-11;

/// `eˣ`, for `x` clamped to −708 ..= 709 (normal results only; the rig asks for `e^(−q²)` with
/// `q² ≤ 50`).
///
/// Range reduction `x = k ln 2 + r`, `|r| ≤ ln 2 / 2`, in Cody and Waite's two parts; `e^r` by
/// its Taylor series to `r¹³` (the first terms by Horner's rule, the rest by Estrin's scheme; truncation below
/// 5e-18 relative), scaled by `2^k`.
/// Within 1 ulp of `std`'s `exp` on −50 ..= 0 (test `exp_matches_std`).
#[inline(always)]
pub fn exp<T: Real>(x: T) -> T {
    let x = x.max(T::splat(-708.0)).min(T::splat(709.0));
    let (k, shifted) = round_int(x * T::splat(INV_LN2));
    let r = (x - k * T::splat(LN2_HI)) - k * T::splat(LN2_LO);
    // 1/n! for n = 3 to 13.
    const C: [f64; 11] = [
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5_040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    // The leading terms in Horner form, which rounds them best; the tail by Estrin's scheme.
    let e = T::splat(1.0) + r * (T::splat(1.0) + r * (T::splat(0.5) + r * estrin(r, &C)));
    e * T::pow2i(shifted)
}

/// `2/π`.
const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;
/// `π/2` in three parts: two of 26 significant bits (so `k · P` is exact for |k| < 2^27, phases
/// up to 2·10⁸ rad) and the rest.
const PIO2_1: f64 = 1.570_796_340_703_964_2;
const PIO2_2: f64 = -1.390_906_767_539_945_6e-8;
const PIO2_3: f64 = 6.123_233_995_736_766e-17;

/// `x = k π/2 + r`, `|r| ≤ π/4`, in three parts (Cody and Waite); `cos r` and `sin r` by their
/// Taylor series to `r¹⁶` and `r¹⁷` (truncation below 3e-18); and bits 0 and 1 of `k`.
#[inline(always)]
fn reduce_quadrant<T: Real>(x: T) -> (T, T, T::Mask, T::Mask) {
    let (k, shifted) = round_int(x * T::splat(TWO_OVER_PI));
    let r = ((x - k * T::splat(PIO2_1)) - k * T::splat(PIO2_2)) - k * T::splat(PIO2_3);
    let z = r * r;
    // cos: (−1)^n / (2n)! for n = 2 to 8; sin: (−1)^n / (2n+1)! for n = 1 to 8.
    const CC: [f64; 7] = [
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
    ];
    const CS: [f64; 8] = [
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5_040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
    ];
    let c = T::splat(1.0) + z * (T::splat(-0.5) + z * estrin(z, &CC));
    let s = r + r * (z * estrin(z, &CS));
    let (odd, second) = T::quadrant(shifted);
    (c, s, odd, second)
}

/// `−v` where `neg` (a mask given as a double: 1 or 0), else `v`.
#[inline(always)]
fn negate_where<T: Real>(neg: T, v: T) -> T {
    T::select(T::gt(neg, T::splat(0.5)), -v, v)
}

/// `cos x` for |x| below 2·10⁸.
///
/// Range reduction `x = k π/2 + r` and its series (`reduce_quadrant`), the quadrant
/// `k mod 4` choosing `cos r`, `−sin r`, `−cos r` or `sin r`. Within 1 ulp of `std`'s `cos` on
/// 0 ..= 10⁶ away from its zeros, and within 2.3e-16 (an ulp of 1) absolute everywhere (test
/// `cos_matches_std`).
#[inline(always)]
pub fn cos<T: Real>(x: T) -> T {
    let (c, s, odd, second) = reduce_quadrant(x);
    // Quadrants 0..3: cos r, −sin r, −cos r, sin r.
    let v = T::select(odd, s, c);
    let flip = T::select(odd, T::splat(1.0), T::splat(0.0));
    // Negate in quadrants 1 and 2: where bit 0 and bit 1 differ.
    let neg = T::select(second, T::splat(1.0) - flip, flip);
    negate_where(neg, v)
}

/// `sin x` for |x| below 2·10⁸: as [`cos`], the quadrant choosing `sin r`, `cos r`, `−sin r`
/// or `−cos r`. Within 1 ulp of `std`'s `sin` away from its zeros, and within an ulp of 1
/// absolute everywhere (test `sin_matches_std`).
#[inline(always)]
pub fn sin<T: Real>(x: T) -> T {
    let (c, s, odd, second) = reduce_quadrant(x);
    let v = T::select(odd, c, s);
    // Negate in quadrants 2 and 3.
    negate_where(T::select(second, T::splat(1.0), T::splat(0.0)), v)
}

/// `2^54`: scales a subnormal into the normal range for [`ln`].
const TWO_54: f64 = 18_014_398_509_481_984.0;

/// `ln x`: −∞ at 0, NaN below 0 or at NaN, +∞ at +∞.
///
/// `x = 2^k m`, `m` in [√½, √2); with `f = m − 1` and `s = f / (2 + f)`,
/// `ln m = 2 atanh s = f − (f²/2 − s (f²/2 + R))`, `R = Σ 2 s²ⁿ / (2n + 1)` for n = 1 to 11
/// (`s² ≤ 0.0295`: truncation below 2e-17 relative), summed as fdlibm's `e_log.c` does, and
/// `k ln 2` added in the two parts of [`exp`]. Within 1 ulp of `std`'s `ln` (test
/// `ln_matches_std`).
#[inline(always)]
pub fn ln<T: Real>(x: T) -> T {
    let one = T::splat(1.0);
    let tiny = x.lt(T::splat(f64::MIN_POSITIVE));
    let (m, e) = T::select(tiny, x * T::splat(TWO_54), x).split_exp();
    let big = m.gt(T::splat(std::f64::consts::SQRT_2));
    let m = T::select(big, m * T::splat(0.5), m);
    let k = e + T::select(big, one, T::splat(0.0)) - T::select(tiny, T::splat(54.0), T::splat(0.0));
    // Exact: m lies within a factor of two of 1 (Sterbenz).
    let f = m - one;
    let s = f / (T::splat(2.0) + f);
    let z = s * s;
    // 2 / (2n + 1) for n = 1 to 11.
    const C: [f64; 11] = [
        2.0 / 3.0,
        2.0 / 5.0,
        2.0 / 7.0,
        2.0 / 9.0,
        2.0 / 11.0,
        2.0 / 13.0,
        2.0 / 15.0,
        2.0 / 17.0,
        2.0 / 19.0,
        2.0 / 21.0,
        2.0 / 23.0,
    ];
    let r = z * estrin(z, &C);
    let hfsq = T::splat(0.5) * f * f;
    let v = k * T::splat(LN2_HI) - ((hfsq - (s * (hfsq + r) + k * T::splat(LN2_LO))) - f);
    // The ends: 0, the negative numbers and NaN, +∞.
    let v = T::select(x.eq(T::splat(0.0)), T::splat(f64::NEG_INFINITY), v);
    let v = T::select(x.gt(T::splat(f64::MAX)), x, v);
    let defined = T::or(x.gt(T::splat(0.0)), x.eq(T::splat(0.0)));
    T::select(defined, v, T::splat(f64::NAN))
}

/// `ln(1 + x)` for `x > −1`, accurate for small `x`: `ln u · x / (u − 1)` with `u = 1 + x`
/// rounded (the quotient corrects the rounding of `u`; Goldberg 1991, Theorem 4), and `x`
/// itself where `u` rounds to 1. Within 2 ulp of `std`'s `ln_1p` (test `ln_1p_matches_std`).
#[inline(always)]
pub fn ln_1p<T: Real>(x: T) -> T {
    let one = T::splat(1.0);
    let u = one + x;
    let d = u - one;
    let same = d.eq(T::splat(0.0));
    // The quotient where u differs from 1; 1 elsewhere (its value there is not used).
    let q = x / T::select(same, one, d);
    T::select(same, x, ln(u) * q)
}

/// `x^y` for `x ≥ 0`: `e^(y ln x)` ([`exp`] and [`ln`]), exactly 0 at `x = 0` for `y > 0`, 1
/// for `y = 0`, and +∞ for `y < 0`. The relative error grows with `|y ln x|` (the rounding of
/// the product `y ln x`, which `e^·` turns into a relative error): within
/// `2e-15 (1 + |y ln x|)` of `std`'s `powf` (test `pow_matches_std`). A result above `e^709`
/// is capped there, as [`exp`]'s is.
#[inline(always)]
pub fn pow<T: Real>(x: T, y: T) -> T {
    let zero = T::splat(0.0);
    let v = exp(y * ln(x));
    let at_zero = T::select(
        y.gt(zero),
        zero,
        T::select(y.eq(zero), T::splat(1.0), T::splat(f64::INFINITY)),
    );
    T::select(x.eq(zero), at_zero, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite doubles of one sign.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    /// A deterministic spread of points (a linear congruential sequence), in [0, 1).
    fn points(n: usize) -> impl Iterator<Item = f64> {
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        (0..n).map(move |_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        })
    }

    #[test]
    fn exp_matches_std() {
        let mut worst = 0;
        for u in points(200_000) {
            let x = -50.0 * u;
            worst = worst.max(ulps(exp(x), x.exp()));
        }
        assert!(worst <= 1, "exp is {worst} ulp from std");
        assert_eq!(exp(0.0), 1.0);
        // Clamped, never NaN or infinite.
        assert!(exp(-1e6) > 0.0 && exp(-1e6) < 1e-300);
        assert!(exp(1e6).is_finite());
    }

    /// The largest distance of `ours` from `theirs` in ulp (where `theirs` is not near a zero)
    /// and absolute, over phases densely in `lo .. lo + width`, then up to 10^6 rad (a run of
    /// several minutes at 500 Hz).
    fn trig_worst(ours: fn(f64) -> f64, theirs: fn(f64) -> f64, lo: f64, width: f64) -> (u64, f64) {
        let (mut worst, mut worst_abs) = (0, 0.0f64);
        for u in points(200_000) {
            let x = if u < 0.5 {
                lo + 2.0 * width * u
            } else {
                1e6 * u
            };
            let (a, b) = (ours(x), theirs(x));
            worst_abs = worst_abs.max((a - b).abs());
            if b.abs() > 1e-3 {
                worst = worst.max(ulps(a, b));
            }
        }
        (worst, worst_abs)
    }

    #[test]
    fn cos_matches_std() {
        let (worst, worst_abs) = trig_worst(cos, f64::cos, 0.0, 10.0);
        assert!(worst <= 1, "cos is {worst} ulp from std");
        assert!(worst_abs <= f64::EPSILON, "cos is {worst_abs} from std");
        assert_eq!(cos(0.0), 1.0);
    }

    #[test]
    fn sin_matches_std() {
        let (worst, worst_abs) = trig_worst(sin, f64::sin, -10.0, 20.0);
        assert!(worst <= 1, "sin is {worst} ulp from std");
        assert!(worst_abs <= f64::EPSILON, "sin is {worst_abs} from std");
        assert_eq!(sin(0.0), 0.0);
        // Odd: the quadrants of negative phases.
        assert_eq!(sin(-1.0), -sin(1.0));
    }

    #[test]
    fn ln_matches_std() {
        let mut worst = 0;
        for u in points(200_000) {
            // From 1e-300 to 1e300, and densely about 1 (where ln is small and cancels).
            for x in [(690.0 * (2.0 * u - 1.0)).exp(), 0.5 + u] {
                let (a, b) = (ln(x), x.ln());
                if b != 0.0 {
                    worst = worst.max(ulps(a, b));
                }
            }
        }
        assert!(worst <= 1, "ln is {worst} ulp from std");
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(ln(0.0), f64::NEG_INFINITY);
        assert!(ln(-1.0).is_nan() && ln(f64::NAN).is_nan());
        assert_eq!(ln(f64::INFINITY), f64::INFINITY);
        // Subnormal.
        let d = 1e-310;
        assert!(ulps(ln(d), d.ln()) <= 1);
    }

    #[test]
    fn ln_1p_matches_std() {
        let mut worst = 0;
        for u in points(200_000) {
            for x in [(60.0 * u - 50.0).exp(), 0.999 * (2.0 * u - 1.0)] {
                let (a, b) = (ln_1p(x), x.ln_1p());
                if b != 0.0 {
                    worst = worst.max(ulps(a.abs(), b.abs()));
                }
            }
        }
        assert!(worst <= 2, "ln_1p is {worst} ulp from std");
        assert_eq!(ln_1p(0.0), 0.0);
        assert_eq!(ln_1p(1e-20), 1e-20);
    }

    #[test]
    fn pow_matches_std() {
        let mut worst = 0.0f64;
        for (u, w) in points(100_000).zip(points(100_001).skip(1)) {
            // Bases from 1e-4 to 1e4, exponents from 0.25 to 4 and −1 to 1: |y ln x| ≤ 37.
            let x = (9.2 * (2.0 * u - 1.0)).exp();
            for y in [0.25 + 3.75 * w, 2.0 * w - 1.0] {
                let (a, b) = (pow(x, y), x.powf(y));
                let rel = ((a - b) / b).abs() / (1.0 + (y * x.ln()).abs());
                worst = worst.max(rel);
            }
        }
        assert!(worst <= 2e-15, "pow is {worst:e} (1 + |y ln x|) from std");
        assert_eq!(pow(0.0, 1.5), 0.0);
        assert_eq!(pow(0.0, 0.0), 1.0);
        assert_eq!(pow(0.0, -0.5), f64::INFINITY);
        assert_eq!(pow(2.0, 0.0), 1.0);
    }

    #[test]
    fn lanes_round_as_the_scalar_path() {
        let xs: Vec<f64> = points(4096).map(|u| 3e5 * u - 60.0).collect();
        for c in xs.chunks_exact(4) {
            let l = Lanes([c[0], c[1], c[2], c[3]]);
            let (e, k, s) = (exp(-l.abs()), cos(l), sin(l));
            let (g, p) = (ln(l.abs()), pow(l.abs(), l * Lanes([1e-5; 4])));
            let g1 = ln_1p(l.abs());
            for i in 0..4 {
                assert_eq!(e.get(i).to_bits(), exp(-c[i].abs()).to_bits());
                assert_eq!(k.get(i).to_bits(), cos(c[i]).to_bits());
                assert_eq!(s.get(i).to_bits(), sin(c[i]).to_bits());
                assert_eq!(g.get(i).to_bits(), ln(c[i].abs()).to_bits());
                assert_eq!(g1.get(i).to_bits(), ln_1p(c[i].abs()).to_bits());
                assert_eq!(p.get(i).to_bits(), pow(c[i].abs(), c[i] * 1e-5).to_bits());
            }
        }
    }
}
