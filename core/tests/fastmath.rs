//! Accuracy of the float-only `sin_cos` against `f64` libm.

use flexarm_core::fastmath::sin_cos;

#[test]
fn error_is_about_one_ulp_over_the_working_range() {
    let mut worst: f64 = 0.0;
    let n = 2_000_000;
    for i in 0..=n {
        let x = -100.0 + 200.0 * i as f32 / n as f32;
        let (s, c) = sin_cos(x);
        let (se, ce) = libm::sincos(f64::from(x));
        worst = worst
            .max((f64::from(s) - se).abs())
            .max((f64::from(c) - ce).abs());
    }
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
}
