//! Arbitrary text as a scenario file: the parser must return a scenario or a one-line error,
//! never panic. `cargo fuzz run -s none scenario`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        match flexarm_host::scenario::parse(text) {
            Ok(s) => assert!(s.config.duration > 0.0 && s.config.rates.divisors().is_ok()),
            Err(e) => assert!(!e.0.contains('\n'), "error must be one line: {e}"),
        }
    }
});
