//! How the out-of-core hierarchy's files store triangle locations (the barycentre spool and
//! the buckets): each record against the one before it in the same stream.
//!
//! A location is normally a multiple of 1/`LOCATION_STEPS` of a lattice unit
//! (`LatticeFrame::location`), so each axis is an integer number of steps, and its difference
//! from the previous record's, zigzagged, is what is stored. A record is a header byte, two
//! bits for the index and two for each axis, then the bytes those bits say:
//!
//! - index (where the stream carries it: buckets): 0 the previous index plus one (no bytes;
//!   nearly every record of a bucket), 1 and 2 the zigzagged difference in one or two bytes,
//!   3 a LEB128 varint of it; a stream without indices has 0 there;
//! - each axis: 0 no change (no bytes; a height field's third axis), 1 and 2 the zigzagged
//!   difference in one or two bytes (little-endian), 3 a varint of the difference shifted left
//!   by one, or the tag 1 and the eight bytes of any other f64 (the tests' sources hand in
//!   arbitrary ones), so the coding is lossless for every value, bit for bit.
//!
//! Neighbouring triangles follow each other in scans and in `gen mesh` output, so a record
//! takes about seven bytes where LEB128 varints alone took about ten (a bucket record of a
//! 2 M-triangle input: 7.0 against 9.6; the buckets beside the staged mesh are the
//! hierarchy stage's temporary peak).
//!
//! A stream of records starts from a zero state; the buckets start one at each run, so that a
//! run decodes on its own.

use std::io;

use crate::external::varint::{self, put as put_varint, unzigzag, zigzag};
use crate::frame::LOCATION_STEPS;

/// The most bytes one record takes: the header, an index (10) and three axes (1 + 8 each).
pub(super) const MAX_RECORD_BYTES: usize = 1 + 10 + 3 * 9;

/// The state a record is coded against: the previous record's index and steps.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Delta {
    index: u64,
    steps: [i64; 3],
}

/// The steps of `x` if it is a whole number of them that converts back bit for bit.
fn steps_of(x: f64) -> Option<i64> {
    let s = x * LOCATION_STEPS;
    // NaN and infinities fail the first test.
    if s.is_nan() || s.abs() >= (1u64 << 52) as f64 || s.fract() != 0.0 {
        return None;
    }
    let steps = s as i64;
    ((steps as f64 / LOCATION_STEPS).to_bits() == x.to_bits()).then_some(steps)
}

fn corrupt() -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        "hierarchy: a temporary file of triangle locations is corrupt",
    )
}

fn get_varint(bytes: &[u8], at: &mut usize) -> io::Result<u64> {
    varint::get(bytes, at).ok_or_else(corrupt)
}

/// Appends `z` in one or two bytes (code 1, 2) when it fits, and says which; else nothing.
fn put_short(out: &mut Vec<u8>, z: u64) -> Option<u8> {
    if z < 1 << 8 {
        out.push(z as u8);
        Some(1)
    } else if z < 1 << 16 {
        out.extend_from_slice(&(z as u16).to_le_bytes());
        Some(2)
    } else {
        None
    }
}

/// The one or two bytes (code 1, 2) at `*at`.
fn get_short(bytes: &[u8], at: &mut usize, code: u8) -> io::Result<u64> {
    let n = code as usize;
    let raw = bytes.get(*at..*at + n).ok_or_else(corrupt)?;
    *at += n;
    Ok(raw.iter().rev().fold(0, |v, &b| v << 8 | b as u64))
}

impl Delta {
    /// Appends the record of `q` (and of `index` when `with_index`).
    pub(super) fn encode(&mut self, out: &mut Vec<u8>, index: u32, q: [f64; 3], with_index: bool) {
        let header_at = out.len();
        out.push(0);
        let mut header = 0u8;
        if with_index {
            let d = index as i64 - self.index as i64;
            if d != 1 {
                let z = zigzag(d);
                header |= put_short(out, z).unwrap_or_else(|| {
                    put_varint(out, z);
                    3
                });
            }
            self.index = index as u64;
        }
        for (axis, &x) in q.iter().enumerate() {
            let code = match steps_of(x) {
                Some(steps) => {
                    let z = zigzag(steps.wrapping_sub(self.steps[axis]));
                    self.steps[axis] = steps;
                    if z == 0 {
                        0
                    } else {
                        put_short(out, z).unwrap_or_else(|| {
                            put_varint(out, z << 1);
                            3
                        })
                    }
                }
                None => {
                    out.push(1);
                    out.extend_from_slice(&x.to_le_bytes());
                    3
                }
            };
            header |= code << (2 + 2 * axis);
        }
        out[header_at] = header;
    }

    /// Decodes the record at `*at` of `bytes` (an index of 0 when not `with_index`).
    pub(super) fn decode(
        &mut self,
        bytes: &[u8],
        at: &mut usize,
        with_index: bool,
    ) -> io::Result<(u32, [f64; 3])> {
        let &header = bytes.get(*at).ok_or_else(corrupt)?;
        *at += 1;
        let mut index = 0;
        let index_code = header & 3;
        if with_index {
            let d = match index_code {
                0 => 1,
                1 | 2 => unzigzag(get_short(bytes, at, index_code)?),
                _ => unzigzag(get_varint(bytes, at)?),
            };
            let i = (self.index as i64).checked_add(d).ok_or_else(corrupt)?;
            index = u32::try_from(i).map_err(|_| corrupt())?;
            self.index = index as u64;
        } else if index_code != 0 {
            return Err(corrupt());
        }
        let mut q = [0.0; 3];
        for (axis, x) in q.iter_mut().enumerate() {
            let code = header >> (2 + 2 * axis) & 3;
            let z = match code {
                0 => 0,
                1 | 2 => get_short(bytes, at, code)?,
                _ => {
                    let v = get_varint(bytes, at)?;
                    if v == 1 {
                        let raw = bytes.get(*at..*at + 8).ok_or_else(corrupt)?;
                        *at += 8;
                        *x = f64::from_le_bytes(raw.try_into().unwrap());
                        continue;
                    } else if v & 1 != 0 {
                        return Err(corrupt());
                    }
                    v >> 1
                }
            };
            let steps = self.steps[axis].wrapping_add(unzigzag(z));
            self.steps[axis] = steps;
            *x = steps as f64 / LOCATION_STEPS;
        }
        Ok((index, q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(records: &[(u32, [f64; 3])], with_index: bool) -> usize {
        let mut bytes = Vec::new();
        let mut encoder = Delta::default();
        for &(t, q) in records {
            let before = bytes.len();
            encoder.encode(&mut bytes, t, q, with_index);
            assert!(bytes.len() - before <= MAX_RECORD_BYTES);
        }
        let mut decoder = Delta::default();
        let mut at = 0;
        for &(t, q) in records {
            let (dt, dq) = decoder.decode(&bytes, &mut at, with_index).unwrap();
            assert_eq!(dt, if with_index { t } else { 0 });
            assert_eq!(dq.map(f64::to_bits), q.map(f64::to_bits), "{q:?}");
        }
        assert_eq!(at, bytes.len());
        bytes.len()
    }

    #[test]
    fn any_f64_comes_back_bit_for_bit() {
        let odd = [
            0.0,
            -0.0,
            1.0 / 7.0,
            -3.25,
            1e-300,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            (1u64 << 52) as f64,
            (1u64 << 60) as f64 / LOCATION_STEPS,
            1.0 / LOCATION_STEPS,
            -1.0 / LOCATION_STEPS,
        ];
        let records: Vec<(u32, [f64; 3])> = odd
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                (
                    (i * 977) as u32 ^ 0xdead_beef,
                    [x, odd[(i + 5) % odd.len()], x],
                )
            })
            .chain([(u32::MAX, [0.5; 3]), (0, [2e9; 3]), (7, [-2e9; 3])])
            .collect();
        round_trip(&records, true);
        round_trip(&records, false);
    }

    #[test]
    fn neighbouring_locations_take_a_few_bytes() {
        // A strip of triangles a few lattice units apart, indices rising: the common case.
        let records: Vec<(u32, [f64; 3])> = (0..10_000u32)
            .map(|i| {
                let x = 500_000.0 + (i as f64 * 3.0).round() + 1.0 / 16.0;
                (2 * i, [x, 700_000.5 - i as f64, 12_345.062_5])
            })
            .collect();
        let bytes = round_trip(&records, true);
        assert!(bytes <= 10_000 * 5, "{bytes} bytes");
    }

    #[test]
    fn every_length_of_difference_comes_back() {
        // Differences at each code's edges (a byte, two bytes, a varint), both signs, on every
        // axis and in the index, with unchanged axes between them.
        let edges: [i64; 12] = [
            0,
            1,
            -1,
            127,
            -128,
            128,
            32_767,
            -32_768,
            32_768,
            1 << 40,
            -(1 << 40),
            1 << 50,
        ];
        let mut records = Vec::new();
        let (mut index, mut steps) = (0i64, [0i64; 3]);
        for (i, &d) in edges.iter().enumerate() {
            for axis in 0..4 {
                if axis == 3 {
                    index = (index + d.clamp(-index, 1 << 20)).max(0);
                } else {
                    steps[axis] += d;
                }
                let q = steps.map(|s| s as f64 / LOCATION_STEPS);
                records.push((index as u32 + i as u32, q));
            }
        }
        round_trip(&records, true);
        round_trip(&records, false);
    }

    #[test]
    fn a_truncated_or_garbled_stream_is_an_error() {
        let mut bytes = Vec::new();
        let mut encoder = Delta::default();
        encoder.encode(&mut bytes, 5, [1.0 / 3.0, 2.0, 3.0], true);
        for end in 0..bytes.len() {
            let mut at = 0;
            assert!(Delta::default()
                .decode(&bytes[..end], &mut at, true)
                .is_err());
        }
        // A long axis whose varint is odd but not the raw tag 1.
        let mut at = 0;
        assert!(Delta::default()
            .decode(&[0b1100, 3], &mut at, true)
            .is_err());
        // An index below 0 (a difference of -1 from 0).
        let mut at = 0;
        assert!(Delta::default().decode(&[1, 1], &mut at, true).is_err());
        // An index code in a stream without indices.
        let mut at = 0;
        assert!(Delta::default().decode(&[1, 2], &mut at, false).is_err());
        // An index difference that overflows i64 (after index 1): an error, not a panic.
        let mut bytes = vec![0, 3];
        varint::put(&mut bytes, u64::MAX - 1);
        let (mut decoder, mut at) = (Delta::default(), 0);
        assert_eq!(decoder.decode(&bytes, &mut at, true).unwrap().0, 1);
        assert!(decoder.decode(&bytes, &mut at, true).is_err());
    }
}
