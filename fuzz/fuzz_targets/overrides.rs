//! Arbitrary command-line overrides (`--duration`, `--plant-dt`, `--motor-hz`, `--piezo-hz`) on
//! a shipped scenario: the one validation must refuse them with a one-line error or accept a run
//! whose work and memory are within the stated bounds. `cargo fuzz run -s none overrides`.
#![no_main]

use flexarm_host::sim::{MAX_PLANT_STEPS, MAX_RECORDED_SAMPLES};
use libfuzzer_sys::fuzz_target;

const SCENARIO: &str = include_str!("../../host-sim/scenarios/trapezoid_observer.toml");

fuzz_target!(|data: &[u8]| {
    let mut words = data.chunks_exact(8).map(|c| {
        let mut b = [0u8; 8];
        b.copy_from_slice(c);
        f64::from_le_bytes(b)
    });
    let Ok(mut sc) = flexarm_host::scenario::parse(SCENARIO) else {
        panic!("the shipped scenario must parse");
    };
    let c = &mut sc.config;
    for (slot, w) in [
        &mut c.duration,
        &mut c.rates.plant_dt,
        &mut c.rates.motor_hz,
        &mut c.rates.piezo_hz,
    ]
    .into_iter()
    .zip(&mut words)
    {
        *slot = w;
    }
    match c.validate(&sc.trajectory) {
        Err(e) => assert!(!e.to_string().contains('\n'), "one line: {e}"),
        Ok(()) => {
            let (motor_div, _) = c.rates.divisors().expect("validated rates");
            assert!(c.duration / c.rates.plant_dt <= MAX_PLANT_STEPS * (1.0 + 1e-9));
            let samples = c.duration / (c.rates.plant_dt * motor_div as f64);
            assert!(samples <= MAX_RECORDED_SAMPLES * (1.0 + 1e-9));
            assert!(c.duration.is_finite() && c.duration > 0.0);
        }
    }
});
