//! ROS 1 message serialization (a ROS 1 bag's messages): little-endian, packed, no
//! encapsulation; strings and arrays prefixed by their `u32` length; `std_msgs/Header` is
//! `seq: u32`, `stamp: {secs: u32, nsecs: u32}`, `frame_id: string`. The four message types
//! a rig maps are read into the same views as their CDR forms ([`crate::msg`]); every length
//! is checked against what remains.

use crate::msg::{CompressedImageMsg, ImageMsg, JointStateMsg, TemperatureMsg};

struct Reader<'a> {
    buf: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.buf.len());
        let Some(end) = end else {
            return Err(format!(
                "{field} at byte {} needs {n} bytes, {} remain",
                self.at,
                self.buf.len() - self.at
            ));
        };
        let s = &self.buf[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self, field: &str) -> Result<u32, String> {
        let b = self.take(4, field)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn f64(&mut self, field: &str) -> Result<f64, String> {
        let b = self.take(8, field)?;
        Ok(f64::from_le_bytes(b.try_into().expect("8 bytes")))
    }

    fn bytes(&mut self, field: &str) -> Result<&'a [u8], String> {
        let n = self.u32(field)? as usize;
        self.take(n, field)
    }

    fn string(&mut self, field: &str) -> Result<&'a str, String> {
        let b = self.bytes(field)?;
        std::str::from_utf8(b).map_err(|_| format!("{field} is not UTF-8"))
    }

    fn f64_seq(&mut self, field: &str) -> Result<Vec<f64>, String> {
        let n = self.u32(field)? as usize;
        let b = self.take(n.checked_mul(8).ok_or(format!("{field}: too long"))?, field)?;
        Ok(b.chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect())
    }

    /// `std_msgs/Header`: the stamp (ns) and frame id.
    fn header(&mut self) -> Result<(i64, &'a str), String> {
        self.u32("header.seq")?;
        let secs = self.u32("header.stamp.secs")?;
        let nsecs = self.u32("header.stamp.nsecs")?;
        let frame_id = self.string("header.frame_id")?;
        Ok((i64::from(secs) * 1_000_000_000 + i64::from(nsecs), frame_id))
    }
}

/// A `sensor_msgs/Image`.
///
/// # Errors
/// A field that overruns the message, or a string that is not UTF-8.
pub fn parse_image(buf: &[u8]) -> Result<ImageMsg<'_>, String> {
    let mut r = Reader { buf, at: 0 };
    let (stamp_ns, frame_id) = r.header()?;
    Ok(ImageMsg {
        stamp_ns,
        frame_id,
        height: r.u32("height")?,
        width: r.u32("width")?,
        encoding: r.string("encoding")?,
        is_bigendian: r.take(1, "is_bigendian")?[0] != 0,
        step: r.u32("step")?,
        data: r.bytes("data")?,
    })
}

/// A `sensor_msgs/CompressedImage`.
///
/// # Errors
/// As [`parse_image`].
pub fn parse_compressed_image(buf: &[u8]) -> Result<CompressedImageMsg<'_>, String> {
    let mut r = Reader { buf, at: 0 };
    let (stamp_ns, frame_id) = r.header()?;
    Ok(CompressedImageMsg {
        stamp_ns,
        frame_id,
        format: r.string("format")?,
        data: r.bytes("data")?,
    })
}

/// A `sensor_msgs/JointState`.
///
/// # Errors
/// As [`parse_image`].
pub fn parse_joint_state(buf: &[u8]) -> Result<JointStateMsg<'_>, String> {
    let mut r = Reader { buf, at: 0 };
    let (stamp_ns, frame_id) = r.header()?;
    let n = r.u32("name")? as usize;
    let mut names = Vec::with_capacity(n.min(64));
    for _ in 0..n {
        names.push(r.string("name")?);
    }
    Ok(JointStateMsg {
        stamp_ns,
        frame_id,
        names,
        position: r.f64_seq("position")?,
        velocity: r.f64_seq("velocity")?,
        effort: r.f64_seq("effort")?,
    })
}

/// A `sensor_msgs/Temperature`.
///
/// # Errors
/// As [`parse_image`].
pub fn parse_temperature(buf: &[u8]) -> Result<TemperatureMsg, String> {
    let mut r = Reader { buf, at: 0 };
    let (stamp_ns, _) = r.header()?;
    Ok(TemperatureMsg {
        stamp_ns,
        temperature: r.f64("temperature")?,
        variance: r.f64("variance")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `sensor_msgs/Temperature` as ROS 1 writes it (header seq, stamp, frame id; two
    /// float64), and every cut of it an error naming the field, never a panic.
    #[test]
    fn a_message_reads_and_every_cut_of_it_is_an_error() {
        let mut b = Vec::new();
        b.extend_from_slice(&7u32.to_le_bytes()); // seq
        b.extend_from_slice(&1_750_000_000u32.to_le_bytes());
        b.extend_from_slice(&250u32.to_le_bytes());
        b.extend_from_slice(&4u32.to_le_bytes());
        b.extend_from_slice(b"room");
        b.extend_from_slice(&22.5f64.to_le_bytes());
        b.extend_from_slice(&0.01f64.to_le_bytes());
        let t = parse_temperature(&b).unwrap();
        assert_eq!(t.stamp_ns, 1_750_000_000 * 1_000_000_000 + 250);
        assert_eq!((t.temperature, t.variance), (22.5, 0.01));
        for n in 0..b.len() {
            let e = parse_temperature(&b[..n]).unwrap_err();
            assert!(e.contains("needs") && e.contains("remain"), "{e}");
        }
        // A length beyond the message (a string claiming 4 GB) is an error too.
        let mut bad = b.clone();
        bad[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(parse_image(&bad).is_err() && parse_joint_state(&bad).is_err());
    }
}
