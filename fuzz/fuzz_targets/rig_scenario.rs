//! Rig and scenario files (TOML, validated).
#![no_main]

use libfuzzer_sys::fuzz_target;
use thermrs_core::rig::Rig;
use thermrs_core::scenario::Scenario;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = Rig::from_toml(text, "fuzz.toml");
        let _ = Scenario::from_toml(text, "fuzz.toml");
    }
});
