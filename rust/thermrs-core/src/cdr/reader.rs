//! The bounded reader of one CDR payload: alignment from [`ORIGIN`], XCDR1/XCDR2 rules,
//! DHEADERs, strings and sequences, every read checked against the payload's end.

use super::{encapsulation, CdrError};
use crate::msg::{join_stamp, ORIGIN};

/// Field names of a `std_msgs/Header` inside one message type.
pub(super) struct HeaderFields {
    pub(super) header: &'static str,
    pub(super) stamp: &'static str,
    pub(super) sec: &'static str,
    pub(super) nanosec: &'static str,
    pub(super) frame_id: &'static str,
}

/// A DHEADER-delimited region: body start and end (exclusive).
#[derive(Clone, Copy)]
pub(super) struct Delimited {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) declared: u32,
}

/// Cursor over one payload. Invariant: `ORIGIN <= pos <= buf.len()`.
pub(super) struct Reader<'a> {
    pub(super) buf: &'a [u8],
    pub(super) pos: usize,
    pub(super) little_endian: bool,
    /// Largest alignment: 8 in XCDR1, 4 in XCDR2.
    pub(super) max_align: usize,
    pub(super) delimited: bool,
}

impl<'a> Reader<'a> {
    pub(super) fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        let enc = encapsulation(buf)?;
        Ok(Reader {
            buf,
            pos: ORIGIN,
            little_endian: enc.little_endian,
            max_align: if enc.xcdr2 { 4 } else { 8 },
            delimited: enc.delimited,
        })
    }

    /// Position of the next item of `size` bytes after alignment padding
    /// (may lie past the end; the caller's bounds check catches that).
    #[inline]
    pub(super) fn aligned(&self, size: usize) -> usize {
        let a = size.min(self.max_align); // 1, 2, 4 or 8
        let rel = self.pos - ORIGIN;
        self.pos + ((a - (rel & (a - 1))) & (a - 1))
    }

    #[inline]
    pub(super) fn truncated(&self, field: &'static str, offset: usize, needed: u64) -> CdrError {
        CdrError::Truncated {
            field,
            offset,
            needed,
            remaining: self.buf.len().saturating_sub(offset),
        }
    }

    /// Reads one primitive of `N` bytes, aligned to `N`.
    #[inline]
    pub(super) fn array<const N: usize>(
        &mut self,
        field: &'static str,
    ) -> Result<[u8; N], CdrError> {
        let start = self.aligned(N);
        match self.buf.get(start..).and_then(<[u8]>::first_chunk::<N>) {
            Some(bytes) => {
                self.pos = start + N;
                Ok(*bytes)
            }
            None => Err(self.truncated(field, start, N as u64)),
        }
    }

    #[inline]
    pub(super) fn u8(&mut self, field: &'static str) -> Result<u8, CdrError> {
        let [b] = self.array::<1>(field)?;
        Ok(b)
    }

    #[inline]
    pub(super) fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        let b = self.array::<4>(field)?;
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    #[inline]
    pub(super) fn i32(&mut self, field: &'static str) -> Result<i32, CdrError> {
        let b = self.array::<4>(field)?;
        Ok(if self.little_endian {
            i32::from_le_bytes(b)
        } else {
            i32::from_be_bytes(b)
        })
    }

    #[inline]
    pub(super) fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        let b = self.array::<8>(field)?;
        Ok(self.decode_f64(b))
    }

    #[inline]
    pub(super) fn decode_f64(&self, b: [u8; 8]) -> f64 {
        if self.little_endian {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        }
    }

    /// Borrows `n` bytes starting at the current position (no alignment).
    #[inline]
    pub(super) fn bytes(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], CdrError> {
        let start = self.pos;
        match start
            .checked_add(n)
            .and_then(|end| self.buf.get(start..end))
        {
            Some(s) => {
                self.pos = start + n;
                Ok(s)
            }
            None => Err(self.truncated(field, start, n as u64)),
        }
    }

    /// A CDR string, borrowed and UTF-8 checked.
    pub(super) fn string(&mut self, field: &'static str) -> Result<&'a str, CdrError> {
        let len = self.u32(field)? as usize;
        if len == 0 {
            return Ok("");
        }
        let start = self.pos;
        let raw = self.bytes(len, field)?;
        let Some((&0, text)) = raw.split_last() else {
            return Err(CdrError::MissingNul {
                field,
                offset: start,
            });
        };
        std::str::from_utf8(text).map_err(|e| CdrError::InvalidUtf8 {
            field,
            offset: start + e.valid_up_to(),
        })
    }

    /// A sequence count, checked so that `count * min_elem_size` bytes fit
    /// in what is left (so no allocation can exceed the payload).
    pub(super) fn count(
        &mut self,
        field: &'static str,
        min_elem_size: usize,
    ) -> Result<usize, CdrError> {
        let count = self.u32(field)?;
        let needed = u64::from(count) * min_elem_size as u64;
        let remaining = self.buf.len() - self.pos;
        if needed > remaining as u64 {
            return Err(self.truncated(field, self.pos, needed));
        }
        Ok(count as usize)
    }

    /// A `uint8[]`, borrowed.
    #[inline]
    pub(super) fn byte_seq(&mut self, field: &'static str) -> Result<&'a [u8], CdrError> {
        let n = self.u32(field)? as usize;
        self.bytes(n, field)
    }

    /// A `float64[]`.
    pub(super) fn f64_seq(&mut self, field: &'static str) -> Result<Vec<f64>, CdrError> {
        let n = self.count(field, 8)?;
        if n == 0 {
            return Ok(Vec::new());
        }
        self.pos = self.aligned(8);
        let raw = self.bytes(n * 8, field)?; // n * 8 <= remaining: no overflow
        Ok(raw
            .chunks_exact(8)
            .filter_map(|c| c.first_chunk::<8>())
            .map(|b| self.decode_f64(*b))
            .collect())
    }

    /// A `string[]` (DHEADER first in delimited XCDR2).
    pub(super) fn string_seq(&mut self, field: &'static str) -> Result<Vec<&'a str>, CdrError> {
        let d = self.begin(field)?;
        let n = self.count(field, 4)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            out.push(self.string(field)?);
        }
        self.end(d, field)?;
        Ok(out)
    }

    /// Reads the DHEADER of a struct or non-primitive sequence, if this
    /// encoding has them.
    pub(super) fn begin(&mut self, field: &'static str) -> Result<Option<Delimited>, CdrError> {
        if !self.delimited {
            return Ok(None);
        }
        let declared = self.u32(field)?;
        let start = self.pos;
        if u64::from(declared) > (self.buf.len() - start) as u64 {
            return Err(self.truncated(field, start, u64::from(declared)));
        }
        Ok(Some(Delimited {
            start,
            end: start + declared as usize,
            declared,
        }))
    }

    /// Closes a region opened by [`Reader::begin`]: checks the members fit
    /// and skips any appended members this reader does not know.
    pub(super) fn end(
        &mut self,
        d: Option<Delimited>,
        field: &'static str,
    ) -> Result<(), CdrError> {
        if let Some(d) = d {
            if self.pos > d.end {
                return Err(CdrError::DelimiterOverrun {
                    field,
                    offset: d.start,
                    declared: d.declared,
                    used: self.pos - d.start,
                });
            }
            self.pos = d.end;
        }
        Ok(())
    }

    /// A `std_msgs/Header`: returns (`stamp_ns`, `frame_id`).
    pub(super) fn header(&mut self, f: &HeaderFields) -> Result<(i64, &'a str), CdrError> {
        let h = self.begin(f.header)?;
        let t = self.begin(f.stamp)?;
        let sec = self.i32(f.sec)?;
        let nanosec = self.u32(f.nanosec)?;
        self.end(t, f.stamp)?;
        let frame_id = self.string(f.frame_id)?;
        self.end(h, f.header)?;
        // |sec| * 1e9 + nanosec < 2.2e18 < i64::MAX: cannot overflow.
        Ok((join_stamp(sec, nanosec), frame_id))
    }
}
