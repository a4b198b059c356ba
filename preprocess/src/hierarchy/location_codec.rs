//! How the out-of-core hierarchy's files store triangle locations (the barycentre spool and
//! the buckets): each record against the one before it in the same stream, as LEB128 varints.
//!
//! A location is normally a multiple of 1/`LOCATION_STEPS` of a lattice unit
//! (`LatticeFrame::location`), so each axis is an integer number of steps: its difference from
//! the previous record's, zigzagged and shifted left by one, is written (a byte or two where
//! neighbouring triangles follow each other, as they do in scans and in `gen mesh` output).
//! Any other f64 (the tests' sources hand in arbitrary ones) is written as the tag 1 and its
//! eight bytes, so the coding is lossless for every value, bit for bit. A triangle's index,
//! where the stream carries it (buckets), is coded as its difference from the previous index.
//!
//! A stream of records starts from a zero state; the buckets start one at each run, so that a
//! run decodes on its own.

use std::io;

use crate::external::varint::{self, put as put_varint, unzigzag, zigzag};
use crate::frame::LOCATION_STEPS;

/// The most bytes one record takes: an index (10) and three axes (1 + 8 each).
pub(super) const MAX_RECORD_BYTES: usize = 10 + 3 * 9;

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

impl Delta {
    /// Appends the record of `q` (and of `index` when `with_index`).
    pub(super) fn encode(&mut self, out: &mut Vec<u8>, index: u32, q: [f64; 3], with_index: bool) {
        if with_index {
            put_varint(out, zigzag(index as i64 - self.index as i64));
            self.index = index as u64;
        }
        for (axis, &x) in q.iter().enumerate() {
            match steps_of(x) {
                Some(steps) => {
                    put_varint(out, zigzag(steps.wrapping_sub(self.steps[axis])) << 1);
                    self.steps[axis] = steps;
                }
                None => {
                    out.push(1);
                    out.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
    }

    /// Decodes the record at `*at` of `bytes` (an index of 0 when not `with_index`).
    pub(super) fn decode(
        &mut self,
        bytes: &[u8],
        at: &mut usize,
        with_index: bool,
    ) -> io::Result<(u32, [f64; 3])> {
        let mut index = 0;
        if with_index {
            let i = (self.index as i64)
                .checked_add(unzigzag(get_varint(bytes, at)?))
                .ok_or_else(corrupt)?;
            index = u32::try_from(i).map_err(|_| corrupt())?;
            self.index = index as u64;
        }
        let mut q = [0.0; 3];
        for (axis, x) in q.iter_mut().enumerate() {
            let v = get_varint(bytes, at)?;
            if v & 1 == 0 {
                let steps = self.steps[axis].wrapping_add(unzigzag(v >> 1));
                self.steps[axis] = steps;
                *x = steps as f64 / LOCATION_STEPS;
            } else if v == 1 {
                let raw = bytes.get(*at..*at + 8).ok_or_else(corrupt)?;
                *at += 8;
                *x = f64::from_le_bytes(raw.try_into().unwrap());
            } else {
                return Err(corrupt());
            }
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
        assert!(bytes <= 10_000 * 7, "{bytes} bytes");
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
        // Tag 3 is neither a delta nor a raw value.
        let mut at = 0;
        assert!(Delta::default()
            .decode(&[0, 3, 0, 0], &mut at, true)
            .is_err());
        // An index below 0.
        let mut at = 0;
        assert!(Delta::default()
            .decode(&[1, 0, 0, 0], &mut at, true)
            .is_err());
        // An index difference that overflows i64 (after index 1): an error, not a panic.
        let mut bytes = vec![2, 0, 0, 0];
        varint::put(&mut bytes, u64::MAX - 1);
        bytes.extend([0, 0, 0]);
        let (mut decoder, mut at) = (Delta::default(), 0);
        assert_eq!(decoder.decode(&bytes, &mut at, true).unwrap().0, 1);
        assert!(decoder.decode(&bytes, &mut at, true).is_err());
    }
}
