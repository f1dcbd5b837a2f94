//! The whole MCAP walk of `extract`: records, chunks (zstd, lz4, none), recovery, messages.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;
use thermrs_core::ingest::{extract_bytes, ExtractOptions};
use thermrs_core::rig::Rig;

fn rig() -> &'static Rig {
    static RIG: OnceLock<Rig> = OnceLock::new();
    RIG.get_or_init(|| {
        let text = include_str!("../../python/thermrs/data/kr15-paper.toml");
        let mut rig = Rig::from_toml(text, "kr15-paper.toml").expect("paper rig");
        // Small frames, as in the mutation test's seeds.
        for c in &mut rig.camera {
            c.size_px = [64, 48];
        }
        rig
    })
}

fuzz_target!(|data: &[u8]| {
    let _ = extract_bytes(
        data,
        None,
        "fuzz.mcap",
        rig(),
        &ExtractOptions::default(),
        &|_, _, _| true,
    );
});
