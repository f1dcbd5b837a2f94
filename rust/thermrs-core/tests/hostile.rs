//! Hostile and damaged input (issue 12): a bounded mutation test on stable Rust, and the
//! recovery the ingest promises, checked against the `mcap` crate's own reading of the clean
//! file.
//!
//! Seeds: small recordings written here with the core's writer (zstd with summary, lz4
//! without, uncompressed, unchunked) and the real recordings in `fixtures/hostile/seeds`;
//! mutations: byte flips, random words, truncations, edited record and chunk lengths and
//! sizes, inserted and deleted garbage, one to three at a time. Every input goes through the
//! MCAP walk (`extract_bytes`), and pieces of it through the CDR decoders and the PNG decoder;
//! rig and scenario texts are mutated likewise. A panic anywhere fails the test and leaves the
//! input in the target directory to be added to `fixtures/hostile/crashes`, whose every file is
//! replayed first.
//!
//! Budget: `THERMRS_FUZZ_ITERS` inputs per target (default 300) and at most
//! `THERMRS_FUZZ_SECS` seconds per target (default 20). Each target prints how many inputs ran.
//! `THERMRS_FUZZ_SEED_DIR` adds the `.mcap` files of a folder to the recording seeds.

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use thermrs_core::cdr;
use thermrs_core::ingest::{self, ExtractOptions};
use thermrs_core::record::{
    ImageFields, MsgType, RecordCompression, RecordOptions, RecordingWriter,
};
use thermrs_core::rig::Rig;
use thermrs_core::scenario::Scenario;

const W: usize = 64;
const H: usize = 48;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn rig_text() -> String {
    std::fs::read_to_string(repo().join("python/thermrs/data/kr15-paper.toml")).unwrap()
}

/// The paper rig with small CCD frames, so that seeds stay small.
fn small_rig() -> Rig {
    let mut rig = Rig::from_toml(&rig_text(), "kr15-paper.toml").unwrap();
    for c in &mut rig.camera {
        c.size_px = [W as i64, H as i64];
    }
    rig
}

fn png(px: &[u8], w: usize, h: usize, color: image::ExtendedColorType) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(px, w as u32, h as u32, color)
        .unwrap();
    out
}

/// A small recording of the rig at work: CCD frames (raw and PNG, some with a spot), joint
/// states, ambient readings and a PNG thermal frame.
fn seed(rig: &Rig, opts: &RecordOptions, frames: usize) -> Vec<u8> {
    let mut wr = RecordingWriter::new(std::io::Cursor::new(Vec::new()), opts).unwrap();
    let th = rig.thermal.as_ref().unwrap();
    let (tw, thh) = (th.size_px[0] as usize, th.size_px[1] as usize);
    let thermal = png(
        &vec![0x73u8; tw * thh * 2],
        tw,
        thh,
        image::ExtendedColorType::L16,
    );
    let joints = &rig.robot.joint_names;
    // Camera 0 sends raw Images, the others PNGs.
    for (k, c) in rig.camera.iter().enumerate() {
        let ty = if k == 0 {
            MsgType::Image
        } else {
            MsgType::CompressedImage
        };
        wr.add_channel(&c.topic, ty).unwrap();
    }
    wr.add_channel(&th.topic, MsgType::CompressedImage).unwrap();
    wr.add_channel(&rig.robot.joint_states_topic, MsgType::JointState)
        .unwrap();
    if let Some(a) = &rig.ambient {
        wr.add_channel(&a.topic, MsgType::Temperature).unwrap();
    }
    for i in 0..frames {
        let t = 1_000_000_000 + i as i64 * 40_000_000;
        let cam = &rig.camera[i % rig.camera.len()];
        let (cx, cy) = (20.0 + (i % 7) as f64 * 3.1, 15.0 + (i % 5) as f64 * 2.3);
        let px: Vec<u8> = (0..W * H)
            .map(|j| {
                let (x, y) = ((j % W) as f64, (j / W) as f64);
                let r2 = (x - cx).powi(2) + (y - cy).powi(2);
                (9.0 + ((j * 7919 + i) % 4) as f64 + 150.0 * (-r2 / 8.0).exp()) as u8
            })
            .collect();
        if i % rig.camera.len() != 0 {
            let p = png(&px, W, H, image::ExtendedColorType::L8);
            wr.write_compressed_image(&cam.topic, t as u64, t, "ccd", "png", &p)
                .unwrap();
        } else {
            let f = ImageFields {
                stamp_ns: t,
                frame_id: "ccd",
                width: W as u32,
                height: H as u32,
                encoding: "mono8",
                is_bigendian: false,
                step: W as u32,
            };
            wr.write_image(&cam.topic, t as u64, &f, &px).unwrap();
        }
        if i % 3 == 0 {
            let q: Vec<f64> = (0..joints.len()).map(|k| 0.1 * k as f64).collect();
            wr.write_joint_state(
                &rig.robot.joint_states_topic,
                t as u64,
                t,
                "base",
                joints,
                &q,
            )
            .unwrap();
        }
        if i % 5 == 0 {
            if let Some(a) = &rig.ambient {
                wr.write_temperature(&a.topic, t as u64, t, "amb", 22.5, 0.0)
                    .unwrap();
            }
        }
        if i % 10 == 0 {
            wr.write_compressed_image(&th.topic, t as u64, t, "ir", "png", &thermal)
                .unwrap();
        }
    }
    wr.finish().unwrap().into_inner()
}

fn layouts() -> Vec<(&'static str, RecordOptions)> {
    let o = |compression, use_chunks, summary| RecordOptions {
        compression,
        chunk_size: 12_000,
        use_chunks,
        summary,
        ..RecordOptions::default()
    };
    vec![
        ("zstd+summary", o(RecordCompression::Zstd, true, true)),
        ("lz4-no-summary", o(RecordCompression::Lz4, true, false)),
        ("none+summary", o(RecordCompression::None, true, true)),
        ("unchunked", o(RecordCompression::None, false, false)),
    ]
}

fn extract(rig: &Rig, buf: &[u8]) -> thermrs_core::Result<(ingest::Tables, ingest::Report)> {
    ingest::extract_bytes(
        buf,
        None,
        "fuzz.mcap",
        rig,
        &ExtractOptions::default(),
        &|_, _, _| true,
    )
}

/// Top-level records of an MCAP file: (offset, opcode, body range).
fn records(buf: &[u8]) -> Vec<(usize, u8, std::ops::Range<usize>)> {
    let mut out = Vec::new();
    let mut pos = 8;
    while pos + 9 <= buf.len() {
        let len = u64::from_le_bytes(buf[pos + 1..pos + 9].try_into().unwrap());
        let Some(len) = usize::try_from(len)
            .ok()
            .filter(|&l| l <= buf.len() - pos - 9)
        else {
            break;
        };
        out.push((pos, buf[pos], pos + 9..pos + 9 + len));
        pos += 9 + len;
    }
    out
}

/// One random mutation of the kinds a damaged or hostile file shows.
fn mutate(rng: &mut StdRng, buf: &mut Vec<u8>) {
    let n = buf.len().max(1);
    let recs = records(buf);
    let interesting: [u64; 9] = [
        0,
        1,
        8,
        u32::MAX as u64,
        1 << 40,
        1 << 63,
        u64::MAX,
        u64::MAX - 8,
        (ingest::MAX_CHUNK_BYTES) + 1,
    ];
    match rng.random_range(0..9) {
        0 => {
            // byte flips
            for _ in 0..rng.random_range(1..8) {
                let p = rng.random_range(0..n);
                if let Some(b) = buf.get_mut(p) {
                    *b ^= 1 << rng.random_range(0..8);
                }
            }
        }
        1 => {
            // truncation
            let keep = rng.random_range(0..n);
            buf.truncate(keep);
        }
        2 | 3 if !recs.is_empty() => {
            // a record's length field
            let (pos, _, ref body) = recs[rng.random_range(0..recs.len())];
            let len = body.len() as u64;
            let v = if rng.random_range(0..2) == 0 {
                interesting[rng.random_range(0..interesting.len())]
            } else {
                len.wrapping_add(rng.random_range(0..64u64))
                    .wrapping_sub(32)
            };
            buf[pos + 1..pos + 9].copy_from_slice(&v.to_le_bytes());
        }
        4 => {
            // a chunk header's sizes: uncompressed size (+16), CRC (+24), compressed size
            let chunks: Vec<_> = recs.iter().filter(|r| r.1 == 0x06).collect();
            if let Some((_, _, body)) = chunks.get(rng.random_range(0..chunks.len().max(1))) {
                let field = [16usize, 24, 28][rng.random_range(0..3)];
                let v = interesting[rng.random_range(0..interesting.len())];
                let at = body.start + field;
                let bytes = v.to_le_bytes();
                let w = if field == 16 { 8 } else { 4 };
                if at + w <= buf.len() {
                    buf[at..at + w].copy_from_slice(&bytes[..w]);
                }
            }
        }
        5 => {
            // inserted garbage
            let p = rng.random_range(0..n);
            let g: Vec<u8> = (0..rng.random_range(1..300))
                .map(|_| rng.random_range(0..=255u8))
                .collect();
            let p = p.min(buf.len());
            buf.splice(p..p, g);
        }
        6 => {
            // deleted range
            let p = rng.random_range(0..n);
            let q = (p + rng.random_range(1..2000)).min(buf.len());
            if p < q {
                buf.drain(p..q);
            }
        }
        7 => {
            // a random word (lengths inside chunks, CDR counts, PNG sizes)
            let p = rng.random_range(0..n);
            let v = interesting[rng.random_range(0..interesting.len())];
            let w = [2usize, 4, 8][rng.random_range(0..3)];
            if p + w <= buf.len() {
                buf[p..p + w].copy_from_slice(&v.to_le_bytes()[..w]);
            }
        }
        _ => {
            // overwrite a range with zeros or copies of another part
            let p = rng.random_range(0..n);
            let len = rng.random_range(1..512).min(buf.len().saturating_sub(p));
            if rng.random_range(0..2) == 0 {
                buf[p..p + len].fill(0);
            } else {
                let s = rng.random_range(0..n);
                let len = len.min(buf.len().saturating_sub(s));
                let piece = buf[s..s + len].to_vec();
                buf[p..p + len].copy_from_slice(&piece);
            }
        }
    }
}

fn budget() -> (usize, Duration) {
    let iters = std::env::var("THERMRS_FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300);
    let secs = std::env::var("THERMRS_FUZZ_SECS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20.0);
    (iters, Duration::from_secs_f64(secs))
}

/// Run `f` on mutations of `seeds` within the budget; a panic saves the input and fails.
fn fuzz(name: &str, seeds: &[Vec<u8>], seed: u64, mut f: impl FnMut(&[u8])) -> usize {
    let (iters, limit) = budget();
    let mut rng = StdRng::seed_from_u64(seed);
    let started = Instant::now();
    let mut ran = 0;
    while ran < iters && started.elapsed() < limit {
        let mut input = seeds[ran % seeds.len()].clone();
        for _ in 0..rng.random_range(1..=3) {
            mutate(&mut rng, &mut input);
        }
        if catch_unwind(AssertUnwindSafe(|| f(&input))).is_err() {
            let dir = repo().join("target/hostile-crashes");
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join(format!("{name}-{ran}.bin"));
            std::fs::write(&path, &input).unwrap();
            panic!("{name}: input {ran} panicked; saved to {}", path.display());
        }
        ran += 1;
    }
    eprintln!(
        "fuzz {name}: {ran} inputs in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    ran
}

fn files_in(dir: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out: Vec<_> = std::fs::read_dir(repo().join(dir))
        .map(|d| {
            d.flatten()
                .map(|e| e.path())
                .filter(|p| p.is_file() && p.extension().is_some_and(|x| x != "md"))
                .map(|p| {
                    let b = std::fs::read(&p).unwrap();
                    (p, b)
                })
                .collect()
        })
        .unwrap_or_default();
    out.sort();
    out
}

/// Feed `data` to every decoder a recording's bytes reach.
fn decoders(rig: &Rig, data: &[u8]) {
    let _ = cdr::parse_image(data);
    let _ = cdr::parse_compressed_image(data);
    let _ = cdr::parse_joint_state(data);
    let _ = cdr::parse_temperature(data);
    let _ = ingest::decode_png("png", data, (W, H));
    let th = rig.thermal.as_ref().unwrap();
    let _ = ingest::decode_png(
        "png",
        data,
        (th.size_px[0] as usize, th.size_px[1] as usize),
    );
}

#[test]
fn crash_corpus_replays_without_panic() {
    let rig = small_rig();
    for (path, data) in files_in("fixtures/hostile/crashes") {
        let r = catch_unwind(AssertUnwindSafe(|| {
            let _ = extract(&rig, &data);
            decoders(&rig, &data);
            if let Ok(text) = std::str::from_utf8(&data) {
                let _ = Rig::from_toml(text, "crash.toml");
                let _ = Scenario::from_toml(text, "crash.toml");
            }
        }));
        assert!(r.is_ok(), "{} panics", path.display());
    }
}

#[test]
fn mutated_recordings_never_panic() {
    let rig = small_rig();
    let mut seeds: Vec<Vec<u8>> = layouts().iter().map(|(_, o)| seed(&rig, o, 40)).collect();
    for (_, d) in files_in("fixtures/hostile/seeds") {
        seeds.push(d);
    }
    // More seeds (e.g. real recordings too large for the repository) from a folder.
    if let Ok(dir) = std::env::var("THERMRS_FUZZ_SEED_DIR") {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            if e.path().extension().is_some_and(|x| x == "mcap") {
                seeds.push(std::fs::read(e.path()).unwrap());
            }
        }
    }
    let paper = Rig::from_toml(&rig_text(), "kr15-paper.toml").unwrap();
    fuzz("mcap", &seeds, 12, |b| {
        let _ = extract(&rig, b);
        let _ = extract(&paper, b);
    });
}

#[test]
fn mutated_messages_never_panic() {
    let rig = small_rig();
    // Every message payload of the seeds, and the CDR fixtures.
    let mut seeds = Vec::new();
    for (_, o) in &layouts()[..1] {
        let file = seed(&rig, o, 12);
        for m in mcap::MessageStream::new(&file).unwrap() {
            seeds.push(m.unwrap().data.into_owned());
        }
    }
    for (_, d) in files_in("fixtures/cdr") {
        seeds.push(d);
    }
    seeds.push(png(&vec![7u8; W * H], W, H, image::ExtendedColorType::L8));
    fuzz("cdr+png", &seeds, 13, |b| decoders(&rig, b));
}

#[test]
fn mutated_rig_and_scenario_texts_never_panic() {
    let seeds = vec![
        rig_text().into_bytes(),
        std::fs::read(repo().join("fixtures/rigs/ur5-two-cameras.toml")).unwrap(),
        std::fs::read(repo().join("fixtures/scenarios/paper-runs.toml")).unwrap(),
    ];
    fuzz("rig+scenario", &seeds, 14, |b| {
        let text = String::from_utf8_lossy(b);
        let _ = Rig::from_toml(&text, "fuzz.toml");
        let _ = Scenario::from_toml(&text, "fuzz.toml");
    });
}

/// Messages per channel of each top-level chunk, by the `mcap` crate's own reader.
fn chunk_messages(file: &[u8]) -> Vec<(usize, usize, BTreeMap<u16, u64>)> {
    let mut out = Vec::new();
    for (pos, op, body) in records(file) {
        if op != 0x06 {
            continue;
        }
        let mut per = BTreeMap::new();
        if let Ok(mcap::records::Record::Chunk { header, data }) =
            mcap::read::parse_record(op, &file[body.clone()])
        {
            for r in mcap::read::ChunkReader::new(header, &data).unwrap() {
                if let mcap::records::Record::Message { header, .. } = r.unwrap() {
                    *per.entry(header.channel_id).or_insert(0) += 1;
                }
            }
        }
        out.push((pos, body.end, per));
    }
    out
}

type Damage = Box<dyn Fn(&mut Vec<u8>)>;

/// One chunk in the middle damaged four ways, with and without a summary: every message
/// outside it is read, the loss names its byte range and (where the file tells) the
/// messages per channel it held.
#[test]
fn one_bad_chunk_in_the_middle_loses_only_itself() {
    let rig = small_rig();
    for (name, opts) in &layouts()[..3] {
        let clean = seed(&rig, opts, 60);
        let (_, clean_rep) = extract(&rig, &clean).unwrap();
        assert!(
            clean_rep.losses.is_empty(),
            "{name}: {:?}",
            clean_rep.losses
        );
        let total: u64 = clean_rep.messages.values().sum();
        let chunks = chunk_messages(&clean);
        assert!(chunks.len() >= 5, "{name}: {} chunks", chunks.len());
        let (pos, end, ref held) = chunks[chunks.len() / 2];
        let in_chunk: u64 = held.values().sum();
        let damages: [(&str, Damage); 4] = [
            (
                "length 2^63",
                Box::new(move |b: &mut Vec<u8>| {
                    b[pos + 1..pos + 9].copy_from_slice(&(1u64 << 63).to_le_bytes())
                }),
            ),
            (
                "length short",
                Box::new(move |b: &mut Vec<u8>| {
                    let l = (end - pos - 9 - 100) as u64;
                    b[pos + 1..pos + 9].copy_from_slice(&l.to_le_bytes())
                }),
            ),
            (
                "uncompressed size 2^40",
                Box::new(move |b: &mut Vec<u8>| {
                    b[pos + 9 + 16..pos + 9 + 24].copy_from_slice(&(1u64 << 40).to_le_bytes())
                }),
            ),
            (
                "bit flip in the records",
                Box::new(move |b: &mut Vec<u8>| b[end - 40] ^= 0x10),
            ),
        ];
        for (what, damage) in &damages {
            let mut bad = clean.clone();
            damage(&mut bad);
            let (_, rep) = extract(&rig, &bad).unwrap();
            let got: u64 = rep.messages.values().sum();
            if what.starts_with("uncompressed") && opts.compression == RecordCompression::None {
                // Records read in place, checked by their CRC: the size field is not needed.
                assert_eq!((got, rep.losses.len()), (total, 0), "{name}, {what}");
                continue;
            }
            assert_eq!(got, total - in_chunk, "{name}, {what}: {:?}", rep.losses);
            assert_eq!(rep.losses.len(), 1, "{name}, {what}: {:?}", rep.losses);
            let loss = &rep.losses[0];
            assert_eq!(loss.offset, pos as u64, "{name}, {what}");
            assert!(loss.offset + loss.bytes >= end as u64, "{name}, {what}");
            assert!(
                loss.detail.contains(&format!("{pos}..")),
                "{name}, {what}: {}",
                loss.detail
            );
            // What the chunk held, by topic, wherever the file tells it.
            let lost: u64 = loss.messages_lost.values().sum();
            if lost > 0 {
                assert_eq!(lost, in_chunk, "{name}, {what}: {:?}", loss.messages_lost);
            }
            if *what == "bit flip in the records" && opts.compression == RecordCompression::None {
                assert_eq!(rep.crc_failures, 1, "{name}: the flip is caught by the CRC");
            }
        }
    }
}

/// A pool of one thread runs each window on the calling thread, a larger pool runs its units
/// in parallel; the tables and the report must not depend on which, on clean recordings and on
/// damaged ones (whose windows retry units that met a channel defined by another unit).
#[test]
fn one_thread_and_a_pool_give_the_same_extraction() {
    let rig = small_rig();
    let pool = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let (one, three) = (pool(1), pool(3));
    let mut rng = StdRng::seed_from_u64(2026);
    let mut compared = 0;
    for (name, opts) in layouts() {
        let clean = seed(&rig, &opts, 60);
        let mut cases = vec![clean.clone()];
        for _ in 0..12 {
            let mut b = clean.clone();
            mutate(&mut rng, &mut b);
            cases.push(b);
        }
        for (k, buf) in cases.iter().enumerate() {
            let show = |r: thermrs_core::Result<(ingest::Tables, ingest::Report)>| match r {
                Ok((t, rep)) => format!("{t:?}\n{}", serde_json::to_string(&rep).unwrap()),
                Err(e) => format!("error: {e}"),
            };
            let a = show(one.install(|| extract(&rig, buf)));
            let b = show(three.install(|| extract(&rig, buf)));
            assert!(a == b, "{name} case {k}: one thread and three differ");
            compared += 1;
        }
    }
    assert_eq!(compared, 4 * 13);
}
