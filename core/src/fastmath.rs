//! `sin`/`cos` and `exp` in single precision without `f64` arithmetic.
//!
//! The Cortex-M4F's FPU is single precision only, and `libm`'s `sincosf` reduces its argument
//! in `f64`, which is software arithmetic there. [`sin_cos`] reduces in `f32` with a three-part
//! Cody–Waite split of π/2 (the products `k·P1` and `k·P2` are exact for `|k| < 2¹⁵`), then
//! evaluates minimax polynomials on `|r| ≤ π/4`: degree 7 for `sin` (relative approximation
//! error 3.6e-9) and degree 8 for `cos` with the exact `1 − r²/2` (absolute error 9.5e-11).
//! Both sit far below `f32` rounding (an ulp of 1.0 is 1.2e-7).
//!
//! Error bound, checked by `core/tests/fastmath.rs` against `f64` `libm` over a dense grid:
//! at most 1.5e-7 absolute for `|x| ≤ 100 rad` (about one ulp of 1.0), and up to the bound of
//! the fast range, `|x| ≤ 2¹³ = 8192 rad`. Beyond it (no joint gets there: the supervisor trips
//! at ±π) the argument is first folded by whole turns in `f32`, which costs accuracy in
//! proportion to `|x|` (3e-4 rad just past the bound).
//!
//! [`exp`] splits `x = k ln 2 + r` (two-part `ln 2`, `k·LN2_HI` exact for `|k| < 2⁸`), evaluates
//! a minimax polynomial of degree 5 with `p(0) = 1` on `|r| ≤ ln 2 / 2` (relative
//! approximation error 9.1e-8) and scales by `2ᵏ` through the exponent bits. Checked against
//! `f64` `libm`: at most 3e-7 relative over `[−87, 88]`. Results below the smallest normal float
//! (`x < −87`) are flushed to 0, and `x > 88` gives `+∞` (the true value there is within a
//! factor 2 of `f32::MAX`).
//!
//! The coefficients and their approximation errors come from `scripts/minimax.py` (Remez
//! exchange in 40-digit arithmetic, weighted for the relative error of `sin` and `exp` and the
//! absolute error of `cos`).
//!
//! Rounding to the nearest integer uses the `1.5·2²³` shift: for `|y| < 2²²`, `y + S` is
//! `S + round(y)` exactly, so `S − (y + S)` is `−round(y)` (`y` rounded to nearest even) and the
//! low bits of `y + S` hold `round(y)` in two's complement (offset by `2²²`). Two additions and a
//! move instead of a call to `rintf` and a conversion. The reductions add `(−k)·P` where the
//! textbook subtracts `k·P`: the same roundings (negation is exact), and the subtraction from
//! `S` reuses the register that holds `S`, where `(y + S) − S` makes LLVM load `−S` as a
//! second constant.

/// `2¹³` rad: beyond it the argument is folded by whole turns first ([`sin_cos`]).
const FAST_RANGE: f32 = 8192.0;

/// `1.5·2²³`: adding it to an `f32` below `2²²` in magnitude rounds it to the nearest integer.
const ROUND_SHIFT: f32 = 12_582_912.0;

/// `(y + S, −round(y))` for `|y| < 2²²`: the shifted value, whose low bits hold `round(y)`
/// (offset by `2²²`), and the rounded value negated (module docs).
#[inline(always)]
fn round_small_neg(y: f32) -> (f32, f32) {
    let shifted = y + ROUND_SHIFT;
    (shifted, ROUND_SHIFT - shifted)
}

/// `(sin x, cos x)` for `f32`, float-only for `|x| ≤ 2¹³`. Inlined: no call, and (the
/// fold being a loop in place) none on its rare path either, so a caller keeps no values in
/// callee-saved registers for it.
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let y = if in_fast_range(x) { x } else { fold_turns(x) };
    sin_cos_reduced(y)
}

/// `|x| ≤ 2¹³` (false for NaN and ±∞), as one integer comparison: the bits shifted left by one
/// drop the sign and order the magnitudes, and `2¹³` shifted so (`0x8C00_0000`) is an immediate
/// operand of `CMP`. Three integer instructions where `|x| ≤ 10⁴` in floating point loads its
/// bound from the literal pool (2 cycles) and moves the FPU's flags (`VMRS`).
#[inline(always)]
fn in_fast_range(x: f32) -> bool {
    x.to_bits() << 1 <= FAST_RANGE.to_bits() << 1
}

/// `x` less whole turns, for `|x| > 2¹³`: far outside any joint range. The fold loses about
/// `|x|·2⁻²⁴` rad of accuracy but stays finite and in range, and keeps the software-`f64`
/// reduction of `libm::sincosf` (7 KiB of flash) out of the firmware. NaN and ±∞ give NaN
/// (`∞ − ∞`), which ends the loop.
#[inline(always)]
fn fold_turns(x: f32) -> f32 {
    const TAU: f32 = core::f32::consts::TAU;
    // Each fold leaves less than 2π plus the rounding of `turns·2π` (about |y|·2⁻²³): a few
    // folds reach the fast range.
    crate::hint::cold();
    let mut y = x;
    while y.abs() > FAST_RANGE {
        let n = y / TAU;
        // Whole turns: `n` truncated through an integer below 2²³ (exact there), `n` itself
        // above, where every `f32` is an integer.
        let turns = if n.abs() < 8_388_608.0 {
            n as i32 as f32
        } else {
            n
        };
        y -= turns * TAU;
    }
    y
}

/// The float-only evaluation for `|x| ≤ 2¹³`.
#[inline(always)]
fn sin_cos_reduced(x: f32) -> (f32, f32) {
    const TWO_OVER_PI: f32 = core::f32::consts::FRAC_2_PI;
    // π/2 = P1 + P2 + P3; P1 and P2 carry few significant bits so k·P1, k·P2 are exact.
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_513e-4;
    const P3: f32 = 7.549_79e-8;
    // Minimax coefficients (`scripts/minimax.py`).
    const S3: f32 = -0.16666655;
    const S5: f32 = 0.008332178;
    const S7: f32 = -0.000195173;
    const C4: f32 = 0.041666646;
    const C6: f32 = -0.0013887368;
    const C8: f32 = 2.4438452e-5;
    // r = x − k·π/2, as x + (−k)·P1 + (−k)·P2 + (−k)·P3 (module docs).
    let (shifted, neg_k) = round_small_neg(x * TWO_OVER_PI);
    let r = ((x + neg_k * P1) + neg_k * P2) + neg_k * P3;
    let r2 = r * r;
    let s = r + r * r2 * (S3 + r2 * (S5 + r2 * S7));
    let c = 1.0 + r2 * (-0.5 + r2 * (C4 + r2 * (C6 + r2 * C8)));
    // Quadrant: k mod 4, from the low bits of the shifted value (2²² ≡ 0 mod 4).
    match shifted.to_bits() & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `eˣ` for `f32`, float-only (module docs: error bound, range). Inlined into its one caller on
/// the hot path, the robust term's boundary layer.
#[inline(always)]
pub fn exp(x: f32) -> f32 {
    // One comparison sends NaN and the underflow and overflow ranges to the slow path.
    if !(-87.0..=88.0).contains(&x) {
        crate::hint::cold();
        return if x.is_nan() {
            x
        } else if x > 0.0 {
            f32::INFINITY
        } else {
            0.0
        };
    }
    const LOG2_E: f32 = core::f32::consts::LOG2_E;
    // ln 2 = LN2_HI + LN2_LO; LN2_HI has 16 significant bits, so k·LN2_HI is exact.
    const LN2_HI: f32 = 0.693_145_75; // = 45425 / 2¹⁶
    const LN2_LO: f32 = 1.428_606_8e-6;
    // Minimax coefficients (`scripts/minimax.py`).
    const E1: f32 = 0.9999997;
    const E2: f32 = 0.4999915;
    const E3: f32 = 0.16667636;
    const E4: f32 = 0.04189793;
    const E5: f32 = 0.008290315;
    // r = x − k·ln 2, as x + (−k)·LN2_HI + (−k)·LN2_LO (module docs).
    let (shifted, neg_k) = round_small_neg(x * LOG2_E);
    let r = (x + neg_k * LN2_HI) + neg_k * LN2_LO;
    let p = 1.0 + r * (E1 + r * (E2 + r * (E3 + r * (E4 + r * E5))));
    // 2ᵏ from its exponent bits, k + 127 = bits(y + S) − bits(S) + 127; −126 ≤ k ≤ 127 in
    // this range, a normal float.
    let biased = shifted
        .to_bits()
        .wrapping_sub(ROUND_SHIFT.to_bits())
        .wrapping_add(127);
    f32::from_bits(biased << 23) * p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integer comparison is `|x| ≤ 2¹³` on every class of `f32`: signed zeros,
    /// subnormals, the bound and its neighbours, infinities, NaNs of either sign, and a
    /// spread of bit patterns.
    #[test]
    fn the_fast_range_test_is_the_float_comparison() {
        let special = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            FAST_RANGE,
            -FAST_RANGE,
            f32::from_bits(FAST_RANGE.to_bits() + 1),
            -f32::from_bits(FAST_RANGE.to_bits() + 1),
            f32::from_bits(FAST_RANGE.to_bits() - 1),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            f32::MAX,
            -f32::MAX,
        ];
        let mut bits = 0x2545_f491_u32;
        let spread = (0..200_000).map(|_| {
            bits = bits.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            f32::from_bits(bits)
        });
        for x in special.into_iter().chain(spread) {
            assert_eq!(
                in_fast_range(x),
                x.abs() <= FAST_RANGE,
                "{x:e} ({:#010x})",
                x.to_bits()
            );
        }
    }

    /// Adding `(−k)·P` rounds as subtracting `k·P` does: the reduction gives the textbook's bits
    /// (the bench's C twin computes the textbook form and must agree to the bit).
    #[test]
    fn the_negated_reduction_is_the_textbook_one() {
        const P: [f32; 3] = [1.570_312_5, 4.837_513e-4, 7.549_79e-8];
        for i in -400_000..=400_000 {
            let x = i as f32 * (FAST_RANGE / 400_000.0) + 1.0e-3;
            let y = x * core::f32::consts::FRAC_2_PI;
            let (shifted, neg_k) = round_small_neg(y);
            let k = shifted - ROUND_SHIFT;
            // −k as a value (k = 0 gives +0 where −k is −0; only x = −0 could tell, and its
            // r = +0 still gives sin = +0, as the textbook's −0 does).
            assert_eq!(neg_k, -k, "{x}");
            let textbook = ((x - k * P[0]) - k * P[1]) - k * P[2];
            let negated = ((x + neg_k * P[0]) + neg_k * P[1]) + neg_k * P[2];
            assert_eq!(negated.to_bits(), textbook.to_bits(), "{x}");
        }
    }
}
