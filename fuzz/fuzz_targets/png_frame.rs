//! PNG frames, decoded with the limits of a rig's CCD and thermal frame sizes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use thermrs_core::ingest::decode_png;

fuzz_target!(|data: &[u8]| {
    let _ = decode_png("png", data, (64, 48));
    let _ = decode_png("png", data, (752, 582));
    let _ = decode_png("png", data, (320, 240));
});
