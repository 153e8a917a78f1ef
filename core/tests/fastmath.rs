//! Accuracy of the float-only `sin_cos` and `exp` against `f64` libm.

use flexarm_core::fastmath::{exp, sin_cos};

/// The largest `err(x)` over `n + 1` evenly spaced `f32` arguments in `[lo, hi]`.
fn worst(lo: f32, hi: f32, n: u32, err: impl Fn(f32) -> f64) -> f64 {
    (0..=n)
        .map(|i| err(lo + (hi - lo) * i as f32 / n as f32))
        .fold(0.0, f64::max)
}

#[test]
fn error_is_about_one_ulp_over_the_working_range() {
    let worst = worst(-100.0, 100.0, 2_000_000, |x| {
        let (s, c) = sin_cos(x);
        let (se, ce) = libm::sincos(f64::from(x));
        (f64::from(s) - se).abs().max((f64::from(c) - ce).abs())
    });
    println!("max |error| over [-100, 100] rad: {worst:.3e}");
    assert!(worst < 1.5e-7, "{worst}");
}

#[test]
fn special_values() {
    assert_eq!(sin_cos(0.0), (0.0, 1.0));
    let (s, c) = sin_cos(f32::NAN);
    assert!(s.is_nan() && c.is_nan());
    // Folded by whole turns beyond 1e4 rad: finite, on the unit circle, and close (the fold of
    // an f32 argument near 1e6 costs about 1e6·2⁻²⁴ = 0.06 rad at worst).
    let (s, c) = sin_cos(1.0e6);
    let (se, ce) = libm::sincos(1.0e6);
    assert!((s * s + c * c - 1.0).abs() < 1e-6);
    assert!((f64::from(s) - se).abs() < 0.1 && (f64::from(c) - ce).abs() < 0.1);
    let (s, c) = sin_cos(f32::INFINITY);
    assert!(s.is_nan() && c.is_nan());
    // Far beyond 2²⁴ turns one fold is not enough; every finite argument still ends on the
    // unit circle.
    for x in [3.0e10_f32, -7.7e20, 1.0e30, f32::MAX, -f32::MAX] {
        let (s, c) = sin_cos(x);
        assert!((s * s + c * c - 1.0).abs() < 1e-6, "{x}: ({s}, {c})");
    }
}

#[test]
fn the_whole_fast_range_stays_accurate_up_to_its_bound() {
    // |x| ≤ 2¹³ is reduced without folding: the three-part split keeps the error near one ulp
    // of 1.0 out to the bound; the first folded arguments beyond it lose what the fold's
    // rounding costs.
    let err = |x: f32| {
        let (s, c) = sin_cos(x);
        let (se, ce) = libm::sincos(f64::from(x));
        (f64::from(s) - se).abs().max((f64::from(c) - ce).abs())
    };
    let near_bound = worst(8000.0, 8192.0, 200_000, err).max(worst(-8192.0, -8000.0, 200_000, err));
    let above = (1..=1000)
        .map(|i| f32::from_bits(8192.0_f32.to_bits() + i))
        .flat_map(|x| [x, -x])
        .map(err)
        .fold(0.0, f64::max);
    println!("max |error| near ±8192 rad: {near_bound:.3e}, just beyond (folded): {above:.3e}");
    assert!(near_bound < 2e-7, "{near_bound}");
    // Folding subtracts turns·2π rounded to f32 (an ulp of 8192 is 9.8e-4 rad).
    assert!(above < 1e-3, "{above}");
}

#[test]
fn exp_relative_error_is_a_few_ulp_over_its_range() {
    let worst = worst(-87.0, 88.0, 2_000_000, |x| {
        let e = libm::exp(f64::from(x));
        (f64::from(exp(x)) - e).abs() / e
    });
    println!("max relative error of exp over [-87, 88]: {worst:.3e}");
    assert!(worst < 3e-7, "{worst}");
}

#[test]
fn exp_special_values() {
    assert_eq!(exp(0.0), 1.0);
    assert!(exp(f32::NAN).is_nan());
    assert_eq!(exp(f32::NEG_INFINITY), 0.0);
    assert_eq!(exp(-100.0), 0.0);
    assert_eq!(exp(f32::INFINITY), f32::INFINITY);
    assert_eq!(exp(89.0), f32::INFINITY);
    // Monotone across the reduction's breakpoints (k changes at odd multiples of ln 2 / 2).
    let mut prev = 0.0;
    for i in 0..=20_000 {
        let y = exp(-10.0 + i as f32 * 1e-3);
        assert!(y >= prev, "exp not monotone at {}", -10.0 + i as f32 * 1e-3);
        prev = y;
    }
}
