use super::*;
use crate::cdr::{
    parse_compressed_image, parse_image, parse_joint_state, parse_temperature, ImageMsg,
};
use crate::msg::NS_PER_SEC;
use std::collections::HashMap;
use std::io::Cursor;

fn hex(s: &str) -> Vec<u8> {
    assert_eq!(s.len() % 2, 0);
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The frame_id of any of the four types (it is always at byte 12).
fn frame_id_of(buf: &[u8]) -> &str {
    let n = u32::from_le_bytes(buf[12..16].try_into().unwrap()) as usize;
    std::str::from_utf8(&buf[16..16 + n - 1]).unwrap()
}

// ---- reference cases, shared with the Python script ----

/// One reference message (inputs to an encoder).
enum Case {
    Image(ImageFields<'static>, Vec<u8>),
    Compressed(i64, &'static str, &'static str, Vec<u8>),
    Joint(
        i64,
        &'static str,
        Vec<&'static str>,
        Vec<f64>,
        Vec<f64>,
        Vec<f64>,
    ),
    Temp(i64, &'static str, f64, f64),
}

fn img(
    stamp_ns: i64,
    frame_id: &'static str,
    width: u32,
    height: u32,
    encoding: &'static str,
    is_bigendian: bool,
    step: u32,
) -> ImageFields<'static> {
    ImageFields {
        stamp_ns,
        frame_id,
        width,
        height,
        encoding,
        is_bigendian,
        step,
    }
}

/// The cases of `make_reference.py` (mcap-ros2-support 0.6.0,
/// `mcap_ros2._dynamic.serialize_dynamic` on the schema texts of this
/// module), with the bytes it produced.
fn reference_cases() -> Vec<(&'static str, Case, &'static str)> {
    let f32s: Vec<u8> = [21.5f32, -3.25]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    vec![
        (
            "image_mono8",
            Case::Image(
                img(1_700_000_000_123_456_789, "ccd_a", 3, 2, "mono8", false, 3),
                vec![0, 1, 2, 253, 254, 255],
            ),
            "0001000000f1536515cd5b07060000006363645f610000000200000003000000060000006d6f6e6f380000000300000006000000000102fdfeff",
        ),
        (
            "image_mono16_be_padded",
            Case::Image(
                img(1_700_000_001_999_999_999, "cam", 3, 2, "mono16", true, 8),
                (0..16).collect(),
            ),
            "0001000001f15365ffc99a3b0400000063616d000200000003000000070000006d6f6e6f313600010800000010000000000102030405060708090a0b0c0d0e0f",
        ),
        (
            "image_empty_negative",
            Case::Image(img(-1_500_000_000, "", 0, 0, "8UC1", false, 0), vec![]),
            "00010000feffffff0065cd1d010000000000000000000000000000000500000038554331000000000000000000000000",
        ),
        (
            "image_32fc1",
            Case::Image(img(0, "thermal_cam", 2, 1, "32FC1", false, 8), f32s),
            "0001000000000000000000000c000000746865726d616c5f63616d00010000000200000006000000333246433100000008000000080000000000ac41000050c0",
        ),
        (
            "compressed_png",
            Case::Compressed(
                1_700_000_002_000_000_005,
                "ccd_b1",
                "png",
                vec![137, 80, 78, 71, 13, 10, 26, 10, 0, 255, 127],
            ),
            "0001000002f1536505000000070000006363645f6231000004000000706e67000b00000089504e470d0a1a0a00ff7f",
        ),
        (
            "compressed_empty_negative",
            Case::Compressed(-1, "x", "jpeg", vec![]),
            "00010000ffffffffffc99a3b0200000078000000050000006a7065670000000000000000",
        ),
        (
            "joint_six",
            Case::Joint(
                1_700_000_003_250_000_000,
                "robot",
                vec!["joint_1", "j2", "shoulder_pan", "a", "elbow", "wrist_3x"],
                vec![
                    0.0,
                    -std::f64::consts::FRAC_PI_2,
                    std::f64::consts::PI,
                    1e-9,
                    -0.0,
                    2.5,
                ],
                vec![],
                vec![],
            ),
            "0001000003f1536580b2e60e06000000726f626f7400000006000000080000006a6f696e745f3100030000006a3200000d00000073686f756c6465725f70616e00000000020000006100000006000000656c626f770000000900000077726973745f337800000000060000000000000000000000182d4454fb21f9bf182d4454fb21094095d626e80b2e113e000000000000008000000000000004400000000000000000",
        ),
        (
            "joint_empty_negative",
            Case::Joint(-999_999_999_999, "", vec![], vec![], vec![], vec![]),
            "0001000018fcffff01000000010000000000000000000000000000000000000000000000",
        ),
        (
            "joint_odd",
            Case::Joint(7, "abc", vec!["x"], vec![0.25], vec![], vec![]),
            "000100000000000007000000040000006162630001000000020000007800000001000000000000000000d03f0000000000000000",
        ),
        (
            "joint_full",
            Case::Joint(
                -1_999_999_999,
                "base_link",
                vec!["a", "bc"],
                vec![1.0, -2.0],
                vec![0.5, 1e300],
                vec![-0.001, 7.0],
            ),
            "00010000feffffff010000000a000000626173655f6c696e6b000000020000000200000061000000030000006263000002000000000000000000f03f00000000000000c00200000000000000000000000000e03f9c7500883ce4377e0200000000000000fca9f1d24d6250bf0000000000001c40",
        ),
        (
            "temperature",
            Case::Temp(1_700_000_004_000_000_042, "ambient", 21.375, 0.0025),
            "0001000004f153652a00000008000000616d6269656e74000000000000000000006035407b14ae47e17a643f",
        ),
        (
            "temperature_negative",
            Case::Temp(-1, "t", -40.5, 0.0),
            "00010000ffffffffffc99a3b020000007400000000000000004044c00000000000000000",
        ),
        (
            "temperature_empty_frame",
            Case::Temp(5, "", 0.1, 1e-6),
            "00010000000000000500000001000000000000009a9999999999b93f8dedb5a0f7c6b03e",
        ),
    ]
}

/// Encodes a case with this module's encoders.
fn encode_case(case: &Case, out: &mut Vec<u8>) {
    match case {
        Case::Image(m, data) => encode_image(out, m, data),
        Case::Compressed(t, frame, format, data) => {
            encode_compressed_image(out, *t, frame, format, data)
        }
        Case::Joint(t, frame, names, p, v, e) => {
            if v.is_empty() && e.is_empty() {
                encode_joint_state(out, *t, frame, names, p)
            } else {
                encode_joint_state_full(out, *t, frame, names, p, v, e)
            }
        }
        Case::Temp(t, frame, temp, var) => encode_temperature(out, *t, frame, *temp, *var),
    }
}

/// Decodes `buf` with `crate::cdr` and checks every field against `case`.
fn check_decodes(case: &Case, buf: &[u8]) {
    match case {
        Case::Image(m, data) => {
            let d = parse_image(buf).unwrap();
            assert_eq!(
                d,
                ImageMsg {
                    stamp_ns: m.stamp_ns,
                    frame_id: m.frame_id,
                    height: m.height,
                    width: m.width,
                    encoding: m.encoding,
                    is_bigendian: m.is_bigendian,
                    step: m.step,
                    data,
                }
            );
        }
        Case::Compressed(t, frame, format, data) => {
            let d = parse_compressed_image(buf).unwrap();
            assert_eq!(
                (d.stamp_ns, d.frame_id, d.format, d.data),
                (*t, *frame, *format, &data[..])
            );
        }
        Case::Joint(t, frame, names, p, v, e) => {
            let d = parse_joint_state(buf).unwrap();
            assert_eq!((d.stamp_ns, d.frame_id), (*t, *frame));
            assert_eq!(&d.names, names);
            assert_eq!(bits(&d.position), bits(p));
            assert_eq!(bits(&d.velocity), bits(v));
            assert_eq!(bits(&d.effort), bits(e));
        }
        Case::Temp(t, frame, temp, var) => {
            let d = parse_temperature(buf).unwrap();
            assert_eq!(d.stamp_ns, *t);
            assert_eq!(d.temperature.to_bits(), temp.to_bits());
            assert_eq!(d.variance.to_bits(), var.to_bits());
            assert_eq!(frame_id_of(buf), *frame);
        }
    }
}

#[test]
fn encoders_match_python_reference_bytes() {
    let mut out = Vec::new();
    for (name, case, want) in reference_cases() {
        encode_case(&case, &mut out);
        assert_eq!(out, hex(want), "{name}");
    }
}

/// Compares with the JSON that `make_reference.py` writes, when present
/// (so the literals above can be checked against a fresh Python run).
#[test]
fn encoders_match_python_reference_file() {
    let path = std::env::temp_dir()
        .join("dev-record")
        .join("cdr_reference.json");
    let Ok(text) = std::fs::read_to_string(&path) else {
        eprintln!("skipped: {} absent", path.display());
        return;
    };
    // A flat {"name": "hex", ...} object: the quoted strings alternate.
    let quoted: Vec<&str> = text.split('"').skip(1).step_by(2).collect();
    let file: HashMap<&str, &str> = quoted.chunks_exact(2).map(|p| (p[0], p[1])).collect();
    let cases = reference_cases();
    assert_eq!(file.len(), cases.len());
    let mut out = Vec::new();
    for (name, case, _) in cases {
        encode_case(&case, &mut out);
        assert_eq!(out, hex(file[name]), "{name}");
    }
}

#[test]
fn encoders_round_trip_through_cdr_reader() {
    let mut out = Vec::new();
    for (_, case, _) in reference_cases() {
        encode_case(&case, &mut out);
        check_decodes(&case, &out);
    }
    // Odd string lengths 0..9 in every string position, odd data sizes.
    for n in 0..9usize {
        let s: &'static str = &"abcdefghi"[..n];
        let data: Vec<u8> = (0..n as u8 * 3).collect();
        let stamp = -(n as i64) * 333_333_333 - 1;
        let cases = [
            Case::Image(img(stamp, s, 1, 2, s, n % 2 == 1, 7), data.clone()),
            Case::Compressed(stamp, s, s, data.clone()),
            Case::Joint(
                stamp,
                s,
                vec![s; n],
                (0..n).map(|i| i as f64 * -0.1).collect(),
                vec![],
                vec![],
            ),
            Case::Joint(
                stamp,
                s,
                vec![s, "q"],
                vec![1.0, 2.0],
                vec![3.0; n],
                vec![-4.0; n % 3],
            ),
            Case::Temp(stamp, s, n as f64 - 0.5, f64::NAN),
        ];
        for case in &cases {
            encode_case(case, &mut out);
            check_decodes(case, &out); // floats compare by bits: NaN too
        }
    }
}

#[test]
fn stamps_split_like_ros() {
    assert_eq!(split_stamp(0), Some((0, 0)));
    assert_eq!(split_stamp(-1), Some((-1, 999_999_999)));
    assert_eq!(split_stamp(-1_000_000_000), Some((-1, 0)));
    assert_eq!(split_stamp(-1_000_000_001), Some((-2, 999_999_999)));
    assert_eq!(split_stamp(1_999_999_999), Some((1, 999_999_999)));
    let max = i64::from(i32::MAX) * NS_PER_SEC + 999_999_999;
    assert_eq!(split_stamp(max), Some((i32::MAX, 999_999_999)));
    assert_eq!(split_stamp(max + 1), None);
    let min = i64::from(i32::MIN) * NS_PER_SEC;
    assert_eq!(split_stamp(min), Some((i32::MIN, 0)));
    assert_eq!(split_stamp(min - 1), None);
    let mut out = Vec::new();
    for t in [min, max, -1, 0, 1] {
        encode_temperature(&mut out, t, "f", 1.0, 0.0);
        assert_eq!(parse_temperature(&out).unwrap().stamp_ns, t);
    }
}

#[test]
fn image_in_place_variants_agree() {
    let m = img(
        1_700_000_000_000_000_001,
        "ccd_a",
        5,
        3,
        "mono16",
        false,
        11,
    );
    let data: Vec<u8> = (0..33).map(|i| (i * 7) as u8).collect();
    let mut a = Vec::new();
    encode_image(&mut a, &m, &data);
    let mut b = vec![0xaa; 7]; // stale content is cleared
    encode_image_with(&mut b, &m, data.len(), |px| px.copy_from_slice(&data));
    let mut c = Vec::new();
    encode_image_header(&mut c, &m, data.len() as u32);
    c.extend_from_slice(&data);
    assert_eq!(a, b);
    assert_eq!(a, c);
    check_decodes(&Case::Image(m, data), &a);
    // Once warm, encoding a same-sized frame does not reallocate.
    let cap = b.capacity();
    let ptr = b.as_ptr();
    encode_image_with(&mut b, &m, 33, |px| px.fill(1));
    assert_eq!((b.capacity(), b.as_ptr()), (cap, ptr));
}

#[test]
fn schema_texts() {
    for ty in MsgType::ALL {
        let text = ty.schema_text();
        assert!(text.starts_with("std_msgs/Header header\n"), "{ty}");
        let sep = format!("\n{}\n", "=".repeat(80));
        let parts: Vec<&str> = text.split(&sep).collect();
        assert_eq!(parts.len(), 3, "{ty}");
        assert_eq!(
            parts[1],
            "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id"
        );
        assert_eq!(
            parts[2],
            "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
        );
    }
    assert_eq!(
        IMAGE_SCHEMA.lines().take(7).collect::<Vec<_>>(),
        [
            "std_msgs/Header header",
            "uint32 height",
            "uint32 width",
            "string encoding",
            "uint8 is_bigendian",
            "uint32 step",
            "uint8[] data"
        ]
    );
    assert_eq!(
        MsgType::JointState.to_string(),
        "sensor_msgs/msg/JointState"
    );
}

// ---- recordings ----

const JOINTS: [&str; 3] = ["joint_1", "joint_2", "joint_3"];

/// A frame of `w * h` 16-bit pixels whose values depend on `k`.
fn frame16(k: u64, w: usize, h: usize) -> Vec<u8> {
    (0..w * h)
        .flat_map(|i| ((i as u64 * 31 + k * 1009) as u16 & 0x0fff).to_le_bytes())
        .collect()
}

/// The expected messages: (topic, log time, payload) in write order.
type Expected = Vec<(String, u64, Vec<u8>)>;

/// Writes a small recording with every message type; returns the file
/// and what each message should be.
fn write_sample(options: &RecordOptions) -> (Vec<u8>, Expected) {
    let mut w = RecordingWriter::new(Cursor::new(Vec::new()), options).unwrap();
    assert_eq!(w.add_channel("/ccd_a/image", MsgType::Image).unwrap(), 1);
    assert_eq!(w.add_channel("/thermal/image", MsgType::Image).unwrap(), 2);
    assert_eq!(w.add_channel("/joints", MsgType::JointState).unwrap(), 3);
    assert_eq!(w.add_channel("/ambient", MsgType::Temperature).unwrap(), 4);
    assert_eq!(
        w.add_channel("/ccd_a/png", MsgType::CompressedImage)
            .unwrap(),
        5
    );
    assert_eq!(w.add_channel("/joints", MsgType::JointState).unwrap(), 3);
    let mut expected = Vec::new();
    let mut buf = Vec::new();
    let t0: i64 = 1_700_000_000_000_000_000;
    for k in 0..12u64 {
        let stamp = t0 + k as i64 * 100_000_000;
        let log = stamp as u64 + 2_000_000;
        // CCD: odd width, padded step, written in place.
        let (cw, ch) = (75, 58);
        let m = img(stamp, "ccd_a", cw, ch, "mono8", false, 76);
        w.write_image_with("/ccd_a/image", log, &m, 76 * 58, |px| {
            for (i, p) in px.iter_mut().enumerate() {
                *p = (i as u64 + k) as u8;
            }
        })
        .unwrap();
        encode_image_with(&mut buf, &m, 76 * 58, |px| {
            for (i, p) in px.iter_mut().enumerate() {
                *p = (i as u64 + k) as u8;
            }
        });
        expected.push(("/ccd_a/image".to_owned(), log, buf.clone()));
        // Thermal: 16UC1 from a slice.
        let data = frame16(k, 32, 24);
        let m = img(stamp + 1, "thermal", 32, 24, "16UC1", false, 64);
        w.write_image("/thermal/image", log + 1, &m, &data).unwrap();
        encode_image(&mut buf, &m, &data);
        expected.push(("/thermal/image".to_owned(), log + 1, buf.clone()));
        // Joints.
        let pos: Vec<f64> = (0..3).map(|j| (k as f64 * 0.1 + j as f64).sin()).collect();
        w.write_joint_state("/joints", log, stamp, "base", &JOINTS, &pos)
            .unwrap();
        encode_joint_state(&mut buf, stamp, "base", &JOINTS, &pos);
        expected.push(("/joints".to_owned(), log, buf.clone()));
        // Ambient, every third frame; a compressed frame every fourth.
        if k % 3 == 0 {
            let t = 21.0 + k as f64 * 0.125;
            w.write_temperature("/ambient", log, stamp, "room", t, 0.01)
                .unwrap();
            encode_temperature(&mut buf, stamp, "room", t, 0.01);
            expected.push(("/ambient".to_owned(), log, buf.clone()));
        }
        if k % 4 == 1 {
            let png = [137u8, 80, 78, 71, 13, 10, 26, 10, k as u8];
            w.write_compressed_image("/ccd_a/png", log, stamp, "ccd_a", "png", &png)
                .unwrap();
            encode_compressed_image(&mut buf, stamp, "ccd_a", "png", &png);
            expected.push(("/ccd_a/png".to_owned(), log, buf.clone()));
        }
    }
    (w.finish().unwrap().into_inner(), expected)
}

fn all_layouts() -> Vec<RecordOptions> {
    let mut v = Vec::new();
    for compression in [
        RecordCompression::None,
        RecordCompression::Zstd,
        RecordCompression::Lz4,
    ] {
        for summary in [true, false] {
            v.push(RecordOptions {
                compression,
                chunk_size: 16 * 1024,
                summary,
                ..RecordOptions::default()
            });
        }
    }
    v.push(RecordOptions {
        use_chunks: false,
        ..RecordOptions::default()
    });
    v.push(RecordOptions {
        use_chunks: false,
        summary: false,
        ..RecordOptions::default()
    });
    v
}

/// Reads `file` back with `mcap::MessageStream` and checks every message,
/// its channel and schema.
fn check_read_back(file: &[u8], expected: &Expected, options: &RecordOptions) {
    let msgs: Vec<mcap::Message> = mcap::MessageStream::new(file)
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(msgs.len(), expected.len());
    let mut seq: HashMap<&str, u32> = HashMap::new();
    for (m, (topic, log, payload)) in msgs.iter().zip(expected) {
        assert_eq!(&m.channel.topic, topic);
        assert_eq!(m.channel.message_encoding, "cdr");
        let schema = m.channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "ros2msg");
        let ty = MsgType::ALL
            .into_iter()
            .find(|t| t.schema_name() == schema.name)
            .unwrap();
        assert_eq!(&schema.data[..], ty.schema_text().as_bytes());
        assert_eq!((m.log_time, m.publish_time), (*log, *log));
        let s = seq.entry(topic).or_insert(0);
        assert_eq!(m.sequence, *s);
        *s += 1;
        assert_eq!(&m.data[..], &payload[..]);
        // And the payload decodes as its schema says.
        match ty {
            MsgType::Image => {
                let d = parse_image(&m.data).unwrap();
                assert_eq!(d.data.len(), (d.step * d.height) as usize);
                assert_eq!(d.stamp_ns + 2_000_000, *log as i64);
            }
            MsgType::CompressedImage => {
                assert_eq!(parse_compressed_image(&m.data).unwrap().format, "png");
            }
            MsgType::JointState => {
                assert_eq!(parse_joint_state(&m.data).unwrap().names, JOINTS);
            }
            MsgType::Temperature => {
                assert_eq!(parse_temperature(&m.data).unwrap().variance, 0.01);
            }
        }
    }
    // The header and the summary.
    assert_eq!(&file[..8], mcap::MAGIC);
    let summary = mcap::Summary::read(file).unwrap();
    if options.summary {
        let s = summary.expect("summary");
        let st = s.stats.unwrap();
        assert_eq!(st.message_count, expected.len() as u64);
        assert_eq!((st.schema_count, st.channel_count), (4, 5));
        assert_eq!(s.chunk_indexes.is_empty(), !options.use_chunks);
        if options.use_chunks {
            assert!(s.chunk_indexes.len() > 1, "{}", s.chunk_indexes.len());
            let want = match options.compression {
                RecordCompression::None => "",
                c => c.as_str(),
            };
            assert!(s.chunk_indexes.iter().all(|c| c.compression == want));
        }
    } else {
        assert!(summary.is_none());
    }
}

#[test]
fn write_read_round_trip_every_layout() {
    for options in all_layouts() {
        let (file, expected) = write_sample(&options);
        check_read_back(&file, &expected, &options);
    }
}

#[test]
fn deterministic_bytes() {
    for options in all_layouts() {
        let (a, _) = write_sample(&options);
        let (b, _) = write_sample(&options);
        assert!(a == b, "{options:?}");
    }
    // And through a real file.
    let dir = std::env::temp_dir();
    let files: Vec<Vec<u8>> = (0..2)
        .map(|i| {
            let path = dir.join(format!(
                "thermrs-record-det-{}-{i}.mcap",
                std::process::id()
            ));
            let f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
            let mut w = RecordingWriter::new(f, &RecordOptions::default()).unwrap();
            w.add_channel("/t", MsgType::Temperature).unwrap();
            for k in 0..100 {
                w.write_temperature("/t", 10 + k, k as i64, "room", 20.0, 0.0)
                    .unwrap();
            }
            drop(w.finish().unwrap());
            let bytes = std::fs::read(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            bytes
        })
        .collect();
    assert_eq!(files[0], files[1]);
}

/// Writes `thermrs-record-python-check.mcap` to the temp directory for
/// the manual Python-reader check (`check_python_reader.py`).
#[test]
fn file_for_python_reader() {
    let (file, expected) = write_sample(&RecordOptions {
        chunk_size: 16 * 1024,
        ..RecordOptions::default()
    });
    assert_eq!(expected.len(), 12 * 3 + 4 + 3);
    let path = std::env::temp_dir().join("thermrs-record-python-check.mcap");
    std::fs::write(path, file).unwrap();
}

#[test]
fn errors() {
    let mut w = RecordingWriter::new(Cursor::new(Vec::new()), &RecordOptions::default()).unwrap();
    w.add_channel("/t", MsgType::Temperature).unwrap();
    let e = w
        .write_joint_state("/nope", 0, 0, "", &JOINTS, &[0.0; 3])
        .unwrap_err();
    assert!(
        matches!(e, RecordError::UnknownTopic(ref t) if t == "/nope"),
        "{e}"
    );
    let e = w.add_channel("/t", MsgType::Image).unwrap_err();
    assert_eq!(
        e.to_string(),
        "topic \"/t\" carries sensor_msgs/msg/Temperature, not sensor_msgs/msg/Image"
    );
    let m = img(0, "", 1, 1, "mono8", false, 1);
    assert!(matches!(
        w.write_image("/t", 0, &m, &[0]),
        Err(RecordError::WrongType { .. })
    ));
    let e = w
        .write_temperature("/t", 0, i64::MAX, "", 0.0, 0.0)
        .unwrap_err();
    assert!(
        matches!(e, RecordError::StampOutOfRange { stamp_ns, .. } if stamp_ns == i64::MAX),
        "{e}"
    );
    // Nothing bad was written: the file holds no message.
    let file = w.finish().unwrap().into_inner();
    assert_eq!(mcap::MessageStream::new(&file).unwrap().count(), 0);
    assert_eq!(
        "lz4".parse::<RecordCompression>().unwrap(),
        RecordCompression::Lz4
    );
    assert!("gzip".parse::<RecordCompression>().is_err());
    assert_eq!(RecordCompression::Zstd.to_string(), "zstd");
}

#[test]
fn run_marker_is_a_metadata_record_other_readers_see() {
    let mut w = RecordingWriter::new(Cursor::new(Vec::new()), &RecordOptions::default()).unwrap();
    w.write_run_marker(
        "run2",
        1_750_000_000_000_000_000,
        1_750_000_060_000_000_000,
        Some(75.0),
    )
    .unwrap();
    assert!(matches!(
        w.write_run_marker("bad", i64::MAX, i64::MAX, None),
        Err(RecordError::StampOutOfRange { .. })
    ));
    let file = w.finish().unwrap().into_inner();
    // Read back with the mcap crate's own linear reader, record by record.
    let found: Vec<_> = mcap::read::LinearReader::new(&file)
        .unwrap()
        .filter_map(|r| match r {
            Ok(mcap::records::Record::Metadata(m)) => Some(m),
            _ => None,
        })
        .collect();
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].name, RUN_METADATA);
    let v = &found[0].metadata;
    assert_eq!(v["name"], "run2");
    assert_eq!(v["start_ns"], "1750000000000000000");
    assert_eq!(v["end_ns"], "1750000060000000000");
    assert_eq!(v["speed_pct"], "75");
}
