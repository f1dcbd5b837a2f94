use super::*;

// Written by fixtures/cdr/make_cdr_fixtures.py: `*_le` by mcap_ros2's
// serializer, the others by hand (see the script for their layouts).
macro_rules! fixture {
    ($name:literal) => {
        include_bytes!(concat!("../../../../fixtures/cdr/", $name))
    };
}

const IMAGE_MONO8_LE: &[u8] = fixture!("image_mono8_le.cdr");
const IMAGE_MONO8_BE: &[u8] = fixture!("image_mono8_be.cdr");
const IMAGE_MONO8_CDR2: &[u8] = fixture!("image_mono8_cdr2.cdr");
const IMAGE_MONO8_DCDR2: &[u8] = fixture!("image_mono8_dcdr2.cdr");
const IMAGE_MONO16_LE: &[u8] = fixture!("image_mono16_le.cdr");
const COMPRESSED_LE: &[u8] = fixture!("compressed_image_le.cdr");
const JOINT_LE: &[u8] = fixture!("joint_state_le.cdr");
const JOINT_BE: &[u8] = fixture!("joint_state_be.cdr");
const JOINT_CDR2: &[u8] = fixture!("joint_state_cdr2.cdr");
const JOINT_DCDR2: &[u8] = fixture!("joint_state_dcdr2.cdr");
const JOINT_FULL_LE: &[u8] = fixture!("joint_state_full_le.cdr");
const TEMP_LE: &[u8] = fixture!("temperature_le.cdr");
const TEMP_BE: &[u8] = fixture!("temperature_be.cdr");
const TEMP_CDR2: &[u8] = fixture!("temperature_cdr2.cdr");
const TEMP_DCDR2: &[u8] = fixture!("temperature_dcdr2.cdr");

const ALL: &[&[u8]] = &[
    IMAGE_MONO8_LE,
    IMAGE_MONO8_BE,
    IMAGE_MONO8_CDR2,
    IMAGE_MONO8_DCDR2,
    IMAGE_MONO16_LE,
    COMPRESSED_LE,
    JOINT_LE,
    JOINT_BE,
    JOINT_CDR2,
    JOINT_DCDR2,
    JOINT_FULL_LE,
    TEMP_LE,
    TEMP_BE,
    TEMP_CDR2,
    TEMP_DCDR2,
];

// Known truth, from fixtures/cdr/expected.json.
const MONO8_PIXELS: [u8; 24] = [
    1, 2, 3, 4, 5, 238, 238, 238, 11, 12, 13, 14, 15, 238, 238, 238, 21, 22, 23, 24, 25, 238, 238,
    238,
];
const NAMES: [&str; 6] = [
    "joint_a1", "joint_a2", "joint_a3", "joint_a4", "joint_a5", "joint_a6",
];
const POSITIONS: [f64; 6] = [
    0.0,
    // Python's repr of -pi/2 and pi/2 (clippy wants the named constant).
    -std::f64::consts::FRAC_PI_2,
    std::f64::consts::FRAC_PI_2,
    0.1,
    -0.25,
    3.0,
];

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// `data` must point into `buf` (zero copy).
fn borrowed_from(data: &[u8], buf: &[u8]) -> bool {
    let r = buf.as_ptr_range();
    data.is_empty() || (r.contains(&data.as_ptr()) && data.as_ptr_range().end <= r.end)
}

fn check_mono8(buf: &[u8]) {
    let m = parse_image(buf).expect("valid image");
    assert_eq!(m.stamp_ns, 1_700_000_000_123_456_789);
    assert_eq!(m.frame_id, "ccd_a");
    assert_eq!(m.height, 3);
    assert_eq!(m.width, 5);
    assert_eq!(m.encoding, "mono8");
    assert!(!m.is_bigendian);
    assert_eq!(m.step, 8);
    assert_eq!(m.data, &MONO8_PIXELS[..]);
    assert!(borrowed_from(m.data, buf));
    assert_eq!(m.data.as_ptr_range().end, buf.as_ptr_range().end);
}

#[test]
fn image_mono8_all_encodings() {
    assert_eq!(IMAGE_MONO8_LE[..4], [0, 1, 0, 0]);
    assert_eq!(IMAGE_MONO8_BE[..4], [0, 0, 0, 0]);
    assert_eq!(IMAGE_MONO8_CDR2[..4], [0, 7, 0, 0]);
    assert_eq!(IMAGE_MONO8_DCDR2[..4], [0, 9, 0, 0]);
    for buf in [
        IMAGE_MONO8_LE,
        IMAGE_MONO8_BE,
        IMAGE_MONO8_CDR2,
        IMAGE_MONO8_DCDR2,
    ] {
        check_mono8(buf);
    }
    // Reference layout: data count at 48, data from 52.
    let m = parse_image(IMAGE_MONO8_LE).unwrap();
    assert_eq!(m.data.as_ptr(), IMAGE_MONO8_LE[52..].as_ptr());
}

#[test]
fn image_mono16() {
    let m = parse_image(IMAGE_MONO16_LE).unwrap();
    assert_eq!(m.stamp_ns, 1_700_000_001_999_999_999);
    assert_eq!(m.frame_id, "ccd_b");
    assert_eq!((m.height, m.width, m.step), (2, 3, 6));
    assert_eq!(m.encoding, "mono16");
    assert!(!m.is_bigendian);
    assert_eq!(m.data, &[2, 1, 232, 3, 255, 255, 0, 0, 0, 1, 255, 15][..]);
    let px: Vec<u16> = m
        .data
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(px, [0x0102, 1000, 65535, 0, 256, 4095]);
    assert!(borrowed_from(m.data, IMAGE_MONO16_LE));
}

#[test]
fn compressed_image() {
    let m = parse_compressed_image(COMPRESSED_LE).unwrap();
    assert_eq!(m.stamp_ns, 1_700_000_002_000_000_005);
    assert_eq!(m.frame_id, "ccd_a");
    assert_eq!(m.format, "png");
    assert_eq!(m.data, &[137, 80, 78, 71, 13, 10, 26, 10, 0, 255, 127][..]);
    assert!(borrowed_from(m.data, COMPRESSED_LE));
}

#[test]
fn joint_state_all_encodings() {
    assert_eq!(JOINT_LE.len(), 188);
    for buf in [JOINT_LE, JOINT_BE, JOINT_CDR2, JOINT_DCDR2] {
        let m = parse_joint_state(buf).unwrap();
        assert_eq!(m.stamp_ns, 1_700_000_003_250_000_000);
        assert_eq!(m.frame_id, "robot");
        assert_eq!(m.names, NAMES);
        assert_eq!(bits(&m.position), bits(&POSITIONS));
        assert!(m.velocity.is_empty());
        assert!(m.effort.is_empty());
    }
}

#[test]
fn joint_state_with_velocity_and_effort() {
    let m = parse_joint_state(JOINT_FULL_LE).unwrap();
    assert_eq!(m.stamp_ns, -1_999_999_999); // sec -2, nanosec 1
    assert_eq!(m.frame_id, "base_link");
    assert_eq!(m.names, NAMES);
    assert_eq!(bits(&m.position), bits(&POSITIONS));
    assert_eq!(
        bits(&m.velocity),
        bits(&[0.5, -0.5, 1e-300, -0.0, 2.5, 1e300])
    );
    assert_eq!(
        bits(&m.effort),
        bits(&[10.0, 20.0, -30.0, 0.125, 7.0, -0.001])
    );
}

#[test]
fn temperature_all_encodings() {
    assert_eq!(TEMP_LE.len(), 44);
    for buf in [TEMP_LE, TEMP_BE, TEMP_CDR2, TEMP_DCDR2] {
        let m = parse_temperature(buf).unwrap();
        assert_eq!(m.stamp_ns, 1_700_000_004_000_000_042);
        assert_eq!(m.temperature.to_bits(), 21.375f64.to_bits());
        assert_eq!(m.variance.to_bits(), 0.0025f64.to_bits());
    }
}

#[test]
fn xtypes_enc_header_aliases() {
    // 0x11 = PLAIN_CDR2 LE, 0x15 = DELIMIT_CDR2 LE: same body rules.
    let mut b = IMAGE_MONO8_CDR2.to_vec();
    b[1] = 0x11;
    check_mono8(&b);
    let mut b = IMAGE_MONO8_DCDR2.to_vec();
    b[1] = 0x15;
    check_mono8(&b);
    let mut b = JOINT_CDR2.to_vec();
    b[1] = 0x06; // big-endian id on a little-endian body: wrong, but no panic
    assert!(parse_joint_state(&b).is_err());
    let e = encapsulation(&[0, 0x14, 0, 0]).unwrap();
    assert!(!e.little_endian && e.xcdr2 && e.delimited);
    let e = encapsulation(&[0, 0x07, 0, 0]).unwrap();
    assert!(e.little_endian && e.xcdr2 && !e.delimited);
    let e = encapsulation(&[0, 0x00, 0xff, 0xff]).unwrap();
    assert!(!e.little_endian && !e.xcdr2 && !e.delimited);
}

#[test]
fn every_prefix_is_an_error() {
    for buf in ALL {
        for n in 0..buf.len() {
            let p = &buf[..n];
            // The data of an image ends the payload; every parser must
            // reject every strict prefix of a payload of its own type.
            let _ = parse_compressed_image(p);
            let _ = parse_image(p);
            let _ = parse_joint_state(p);
            let _ = parse_temperature(p);
        }
    }
    for (buf, f) in [
        (IMAGE_MONO8_LE, 0),
        (IMAGE_MONO8_BE, 0),
        (IMAGE_MONO8_CDR2, 0),
        (IMAGE_MONO8_DCDR2, 0),
        (IMAGE_MONO16_LE, 0),
        (COMPRESSED_LE, 1),
        (JOINT_LE, 2),
        (JOINT_BE, 2),
        (JOINT_CDR2, 2),
        (JOINT_DCDR2, 2),
        (JOINT_FULL_LE, 2),
        (TEMP_LE, 3),
        (TEMP_BE, 3),
        (TEMP_CDR2, 3),
        (TEMP_DCDR2, 3),
    ] {
        for n in 0..buf.len() {
            let p = &buf[..n];
            let err = match f {
                0 => parse_image(p).err(),
                1 => parse_compressed_image(p).err(),
                2 => parse_joint_state(p).err(),
                _ => parse_temperature(p).err(),
            };
            let err = err.unwrap_or_else(|| panic!("prefix {n} of {} parsed", buf.len()));
            let msg = err.to_string();
            assert!(!msg.contains('\n'), "{msg}");
            assert!(msg.contains("byte"), "{msg}");
        }
    }
}

#[test]
fn truncated_image_data_message() {
    let p = &IMAGE_MONO8_LE[..60];
    let e = parse_image(p).unwrap_err();
    assert_eq!(
        e,
        CdrError::Truncated {
            field: "Image.data",
            offset: 52,
            needed: 24,
            remaining: 8
        }
    );
    assert_eq!(
        e.to_string(),
        "truncated at byte 52 reading Image.data (needs 24 bytes, 8 left)"
    );
    let e = parse_image(&IMAGE_MONO8_LE[..3]).unwrap_err();
    assert_eq!(e, CdrError::MissingHeader { len: 3 });
}

#[test]
fn wrong_encapsulation_id() {
    let mut b = TEMP_LE.to_vec();
    b[1] = 0x03;
    let e = parse_temperature(&b).unwrap_err();
    assert_eq!(e, CdrError::ParameterList { id: 3 });
    assert!(e.to_string().contains("0x0003"));
    for id in [0x02u8, 0x0a, 0x0b, 0x12, 0x13] {
        b[1] = id;
        assert_eq!(
            parse_temperature(&b),
            Err(CdrError::ParameterList { id: id.into() })
        );
    }
    b[1] = 0x05;
    assert_eq!(
        parse_temperature(&b),
        Err(CdrError::UnknownEncapsulation { id: 5 })
    );
    b[0] = 0x01;
    b[1] = 0x01;
    let e = parse_temperature(&b).unwrap_err();
    assert_eq!(e, CdrError::UnknownEncapsulation { id: 0x0101 });
    assert_eq!(
        e.to_string(),
        "unknown CDR encapsulation id 0x0101 at byte 0"
    );
}

fn put_u32_le(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn string_length_past_end() {
    let mut b = IMAGE_MONO8_LE.to_vec();
    put_u32_le(&mut b, 12, 1000); // frame_id length
    let e = parse_image(&b).unwrap_err();
    assert_eq!(
        e,
        CdrError::Truncated {
            field: "Image.header.frame_id",
            offset: 16,
            needed: 1000,
            remaining: 60
        }
    );
    put_u32_le(&mut b, 12, u32::MAX);
    assert!(parse_image(&b).is_err());
}

#[test]
fn string_errors() {
    let mut b = IMAGE_MONO8_LE.to_vec();
    b[37] = 0xff; // inside "mono8"
    let e = parse_image(&b).unwrap_err();
    assert_eq!(
        e,
        CdrError::InvalidUtf8 {
            field: "Image.encoding",
            offset: 37
        }
    );
    assert_eq!(e.to_string(), "invalid UTF-8 at byte 37 in Image.encoding");
    let mut b = IMAGE_MONO8_LE.to_vec();
    b[41] = b'x'; // the NUL after "mono8"
    assert_eq!(
        parse_image(&b),
        Err(CdrError::MissingNul {
            field: "Image.encoding",
            offset: 36
        })
    );
    // Length 0 reads as "" (frame_id of the temperature: 8 bytes -> 0).
    let mut t = Vec::from(&TEMP_LE[..12]);
    t.extend_from_slice(&0u32.to_le_bytes()); // frame_id len 0 at 12, pad to 20
    t.extend_from_slice(&[0; 4]);
    t.extend_from_slice(&TEMP_LE[28..]);
    let m = parse_temperature(&t).unwrap();
    assert_eq!(m.temperature, 21.375);
}

#[test]
fn huge_counts_do_not_allocate() {
    let mut b = JOINT_LE.to_vec();
    put_u32_le(&mut b, 24, u32::MAX); // name count
    let e = parse_joint_state(&b).unwrap_err();
    assert_eq!(
        e,
        CdrError::Truncated {
            field: "JointState.name",
            offset: 28,
            needed: u64::from(u32::MAX) * 4,
            remaining: 160
        }
    );
    let mut b = JOINT_LE.to_vec();
    put_u32_le(&mut b, 124, u32::MAX); // position count
    let e = parse_joint_state(&b).unwrap_err();
    assert!(
        matches!(
            e,
            CdrError::Truncated {
                field: "JointState.position",
                ..
            }
        ),
        "{e}"
    );
    let mut b = IMAGE_MONO8_LE.to_vec();
    put_u32_le(&mut b, 48, u32::MAX); // data count
    let e = parse_image(&b).unwrap_err();
    assert_eq!(
        e.to_string(),
        "truncated at byte 52 reading Image.data (needs 4294967295 bytes, 24 left)"
    );
}

#[test]
fn dheader_rules() {
    // Extra appended bytes declared by the top-level DHEADER are skipped.
    let mut b = TEMP_DCDR2.to_vec();
    let top = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
    assert_eq!(top as usize, b.len() - 8);
    put_u32_le(&mut b, 4, top + 4);
    b.extend_from_slice(&[1, 2, 3, 4]);
    assert_eq!(parse_temperature(&b).unwrap().temperature, 21.375);
    // So are bytes appended to a nested struct (a newer Header version):
    // header body is 12..36, temperature follows at 36.
    let mut b = TEMP_DCDR2.to_vec();
    let hdr = u32::from_le_bytes([b[8], b[9], b[10], b[11]]);
    assert_eq!(hdr, 24);
    put_u32_le(&mut b, 4, top + 4);
    put_u32_le(&mut b, 8, hdr + 4);
    b.splice(36..36, [0xde, 0xad, 0xbe, 0xef]);
    let m = parse_temperature(&b).unwrap();
    assert_eq!(m.stamp_ns, 1_700_000_004_000_000_042);
    assert_eq!(m.temperature, 21.375);
    assert_eq!(m.variance, 0.0025);
    // A DHEADER larger than the payload is a truncation.
    let mut b = TEMP_DCDR2.to_vec();
    put_u32_le(&mut b, 4, top + 4);
    assert!(matches!(
        parse_temperature(&b),
        Err(CdrError::Truncated {
            field: "Temperature",
            offset: 8,
            ..
        })
    ));
    // A header DHEADER too small for its members is an overrun.
    let mut b = TEMP_DCDR2.to_vec();
    let hdr = u32::from_le_bytes([b[8], b[9], b[10], b[11]]);
    put_u32_le(&mut b, 8, hdr - 1);
    let e = parse_temperature(&b).unwrap_err();
    assert_eq!(
        e,
        CdrError::DelimiterOverrun {
            field: "Temperature.header",
            offset: 12,
            declared: hdr - 1,
            used: hdr as usize
        }
    );
    assert!(!e.to_string().contains('\n'));
}

/// xorshift64*: deterministic, no crates.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

#[test]
fn fuzz_mutations_never_panic() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut parsed = 0usize;
    for buf in ALL {
        for _ in 0..3000 {
            let mut b = buf.to_vec();
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(b.len());
                b[i] = match rng.below(4) {
                    0 => 0xff,
                    1 => 0,
                    2 => b[i] ^ (1 << rng.below(8)),
                    _ => rng.next() as u8,
                };
            }
            if rng.below(4) == 0 {
                b.truncate(rng.below(b.len() + 1));
            }
            parsed += usize::from(parse_image(&b).is_ok());
            parsed += usize::from(parse_compressed_image(&b).is_ok());
            parsed += usize::from(parse_joint_state(&b).is_ok());
            parsed += usize::from(parse_temperature(&b).is_ok());
        }
    }
    // Sanity: many single-byte changes (pixel values, stamps) still parse.
    assert!(parsed > 1000, "{parsed}");
}
