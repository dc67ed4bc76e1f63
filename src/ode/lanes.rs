//! Arithmetic written once for one number or for `W` numbers side by side.
//!
//! [`Real`] is the small set of operations the rig's right-hand side and the Dormand–Prince
//! step need; it is implemented by `f64` (the scalar path) and by [`Lanes<W>`] (the batch path,
//! one sweep point per lane). Code generic over `Real` therefore performs, in every lane, the
//! same IEEE operations in the same order as the scalar code does for that lane's point alone:
//! a point's result cannot depend on the lane or batch it ran in. Branches become
//! [`Real::select`]s, which evaluate both sides (as the scalar instance then does too).
//!
//! The transcendental functions the right-hand side needs, [`exp`] and [`cos`], are written here
//! in the same generic arithmetic (the platform's `libm` has no vector form, and a vector form of
//! another library would not round as the scalar path does). Both are within 1 ulp of the
//! correctly rounded result on the ranges the rig uses (tests below, against `std`).
//!
//! [`Lanes<W>`] holds `[f64; W]` and every operation is an element-wise loop marked
//! `#[inline(always)]`: inside a function compiled for a vector instruction set
//! ([`crate::ode::batch`] dispatches with `pulp`) the compiler emits one vector instruction per
//! operation, and with no such set the same code runs as scalar loops, with the same results.
//! Rust never contracts a multiply and an add into a fused one on its own, so enabling FMA does
//! not change a result either.

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
    /// `f` applied lane by lane: for the platform's own functions (`ln`, `sin`, `powf`) where a
    /// right-hand side must round as the scalar path does and no generic form is written here.
    fn each(self, f: impl Fn(f64) -> f64) -> Self;
    /// `f` applied lane by lane to two operands.
    fn each2(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self;
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
    fn each(self, f: impl Fn(f64) -> f64) -> Self {
        f(self)
    }
    #[inline(always)]
    fn each2(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        f(self, o)
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
    fn each(self, f: impl Fn(f64) -> f64) -> Self {
        self.map(f)
    }
    #[inline(always)]
    fn each2(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        self.zip(o, f)
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

/// `cos x` for |x| below 2·10⁸.
///
/// Range reduction `x = k π/2 + r`, `|r| ≤ π/4`, in three parts (Cody and Waite); `cos r` and
/// `sin r` by their Taylor series to `r¹⁶` and `r¹⁷` (truncation below 3e-18), the quadrant
/// `k mod 4` choosing `cos r`, `−sin r`, `−cos r` or `sin r`. Within 1 ulp of `std`'s `cos` on
/// 0 ..= 10⁶ away from its zeros, and within 2.3e-16 (an ulp of 1) absolute everywhere (test
/// `cos_matches_std`).
#[inline(always)]
pub fn cos<T: Real>(x: T) -> T {
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
    // Quadrants 0..3: cos r, −sin r, −cos r, sin r.
    let v = T::select(odd, s, c);
    let flip = T::select(odd, T::splat(1.0), T::splat(0.0));
    // Negate in quadrants 1 and 2: where bit 0 and bit 1 differ.
    let neg = T::select(second, T::splat(1.0) - flip, flip);
    T::select(T::gt(neg, T::splat(0.5)), -v, v)
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

    #[test]
    fn cos_matches_std() {
        let (mut worst, mut worst_abs) = (0, 0.0f64);
        for u in points(200_000) {
            // Small phases densely, then up to 10^6 rad (a run of several minutes at 500 Hz).
            let x = if u < 0.5 { 20.0 * u } else { 1e6 * u };
            let (a, b) = (cos(x), x.cos());
            worst_abs = worst_abs.max((a - b).abs());
            if b.abs() > 1e-3 {
                worst = worst.max(ulps(a, b));
            }
        }
        assert!(worst <= 1, "cos is {worst} ulp from std");
        assert!(worst_abs <= f64::EPSILON, "cos is {worst_abs} from std");
        assert_eq!(cos(0.0), 1.0);
    }

    #[test]
    fn lanes_round_as_the_scalar_path() {
        let xs: Vec<f64> = points(4096).map(|u| 3e5 * u - 60.0).collect();
        for c in xs.chunks_exact(4) {
            let l = Lanes([c[0], c[1], c[2], c[3]]);
            let (e, k) = (exp(-l.abs()), cos(l));
            for i in 0..4 {
                assert_eq!(e.get(i).to_bits(), exp(-c[i].abs()).to_bits());
                assert_eq!(k.get(i).to_bits(), cos(c[i]).to_bits());
            }
        }
    }
}
