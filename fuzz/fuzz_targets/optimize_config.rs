//! Arbitrary text as an optimization config and as a `[piezo]` fragment: a value or a readable
//! error, never a panic. `cargo fuzz run -s none optimize_config`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(cfg) = flexarm_beam::config::Config::from_toml(text) {
            assert!(cfg.validate().is_ok());
        }
        if let Ok(choice) = flexarm_beam::fragment::read_piezo(text, 0.7) {
            assert!(choice.patch.x_a >= 0.0 && choice.patch.x_a + choice.patch.l_a <= 0.7 + 1e-9);
        }
    }
});
