//! The CDR decoders of every message type the ingest reads.
#![no_main]

use libfuzzer_sys::fuzz_target;
use thermrs_core::cdr;

fuzz_target!(|data: &[u8]| {
    let _ = cdr::encapsulation(data);
    let _ = cdr::parse_image(data);
    let _ = cdr::parse_compressed_image(data);
    let _ = cdr::parse_joint_state(data);
    let _ = cdr::parse_temperature(data);
});
