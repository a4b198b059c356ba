//! The global vertex ids of a patch, stored apart from what the GPU reads.
//!
//! Only the CPU needs them (crack checks compare edges by global id; tools map a patch vertex
//! back to the input), so they live in their own blob after the patch blob and are compressed:
//! each id is the zigzag-encoded difference from the previous id of the same patch (the first
//! from 0), written as an unsigned LEB128 varint (7 bits per byte, low groups first, high bit =
//! "more bytes follow"). Vertices come in first-use order of a vertex-cache-optimised strip, so
//! neighbouring ids are close: ~1.7 bytes per id on the Stanford dragon instead of 4.
//!
//! The encoding is canonical (no trailing zero groups), so a stream decodes to exactly one id
//! list and every id list encodes to exactly one stream.

/// Longest varint a delta between two u32 ids can need: zigzag(±2^32) < 2^34 → 5 groups.
pub const MAX_VARINT_BYTES: usize = 5;

/// Appends the encoding of `ids` to `out` and returns the number of bytes written
/// (at most `ids.len() × MAX_VARINT_BYTES`).
pub fn encode_global_ids(ids: &[u32], out: &mut Vec<u8>) -> usize {
    let start = out.len();
    let mut previous = 0i64;
    for &id in ids {
        let delta = id as i64 - previous;
        previous = id as i64;
        let mut zigzag = ((delta << 1) ^ (delta >> 63)) as u64;
        while zigzag >= 0x80 {
            out.push(zigzag as u8 | 0x80);
            zigzag >>= 7;
        }
        out.push(zigzag as u8);
    }
    out.len() - start
}

/// An iterator over the ids of a stream that `check_global_ids` accepted.
#[derive(Clone, Debug)]
pub struct GlobalIds<'a> {
    stream: &'a [u8],
    at: usize,
    previous: i64,
    remaining: usize,
}

impl<'a> GlobalIds<'a> {
    /// Iterates over `count` ids of `stream`. The stream must have passed `check_global_ids`
    /// with the same count; anything else may yield garbage (never undefined behaviour).
    pub fn new(stream: &'a [u8], count: usize) -> Self {
        GlobalIds {
            stream,
            at: 0,
            previous: 0,
            remaining: count,
        }
    }
}

/// Reads one varint at `stream[*at..]`, or says why it cannot (truncated, longer than
/// `MAX_VARINT_BYTES`, or not canonical).
fn read_varint(stream: &[u8], at: &mut usize) -> Result<u64, String> {
    let start = *at;
    let mut value = 0u64;
    for group in 0..MAX_VARINT_BYTES {
        let Some(&byte) = stream.get(*at) else {
            return Err(format!("id stream ends inside the varint at byte {start}"));
        };
        *at += 1;
        value |= ((byte & 0x7F) as u64) << (7 * group);
        if byte & 0x80 == 0 {
            if byte == 0 && group > 0 {
                return Err(format!("varint at byte {start} is not canonical"));
            }
            return Ok(value);
        }
    }
    Err(format!(
        "varint at byte {start} is longer than {MAX_VARINT_BYTES} bytes"
    ))
}

fn unzigzag(z: u64) -> i64 {
    (z >> 1) as i64 ^ -((z & 1) as i64)
}

impl Iterator for GlobalIds<'_> {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        if self.remaining == 0 {
            return None;
        }
        self.remaining -= 1;
        let z = read_varint(self.stream, &mut self.at).unwrap_or(0);
        self.previous = self.previous.wrapping_add(unzigzag(z));
        Some(self.previous as u32)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.remaining, Some(self.remaining))
    }
}

impl ExactSizeIterator for GlobalIds<'_> {}

/// Checks that `stream` holds exactly `count` canonical varints whose running sums are ids
/// below `id_limit` (the input's vertex count). Cost: one pass over the stream. The error is a
/// message without the tet's name.
pub fn check_global_ids(stream: &[u8], count: u64, id_limit: u64) -> Result<(), String> {
    if count > stream.len() as u64 {
        return Err(format!(
            "{count} ids cannot fit in an id stream of {} bytes",
            stream.len()
        ));
    }
    let (mut at, mut previous) = (0usize, 0i64);
    for k in 0..count {
        let delta = unzigzag(read_varint(stream, &mut at)?);
        // |delta| < 2^35 and 0 ≤ previous < 2^32: no overflow.
        let id = previous + delta;
        if !(0..id_limit as i128).contains(&(id as i128)) {
            return Err(format!(
                "global id {k} is {id}, not a vertex of the {id_limit}-vertex input"
            ));
        }
        previous = id;
    }
    if at != stream.len() {
        return Err(format!(
            "id stream is {} bytes but its {count} ids take {at}",
            stream.len()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(ids: &[u32]) -> Vec<u8> {
        let mut out = vec![0xAA]; // appends after what is there
        let written = encode_global_ids(ids, &mut out);
        assert_eq!(written, out.len() - 1);
        assert!(written <= ids.len() * MAX_VARINT_BYTES);
        let stream = &out[1..];
        check_global_ids(stream, ids.len() as u64, u32::MAX as u64 + 1).unwrap();
        let decoded: Vec<u32> = GlobalIds::new(stream, ids.len()).collect();
        assert_eq!(decoded, ids);
        stream.to_vec()
    }

    #[test]
    fn round_trips_and_sizes() {
        assert_eq!(round_trip(&[]), Vec::<u8>::new());
        assert_eq!(round_trip(&[0]), [0]);
        assert_eq!(round_trip(&[1]), [2]); // zigzag(+1) = 2
        assert_eq!(round_trip(&[5, 4]), [10, 1]); // zigzag(−1) = 1
        assert_eq!(round_trip(&[64]), [0x80, 0x01]); // zigzag(64) = 128
        assert_eq!(round_trip(&[u32::MAX]).len(), 5);
        assert_eq!(round_trip(&[u32::MAX, 0]).len(), 10); // delta −(2^32 − 1)
        round_trip(&[7, 7, 7, 1_000_000, 3, u32::MAX, 0, u32::MAX - 1]);
        let near: Vec<u32> = (0..1000).map(|i| 500_000 + (i * 37) % 101).collect();
        assert!(round_trip(&near).len() <= 2 * near.len());
    }

    #[test]
    fn bad_streams_are_errors() {
        let limit = 1000;
        let check = |stream: &[u8], count: u64, expected: &str| {
            let message = check_global_ids(stream, count, limit).unwrap_err();
            assert!(message.contains(expected), "{message:?} vs {expected:?}");
        };
        check(&[0x80], 1, "ends inside the varint");
        check(&[2, 2], 3, "3 ids cannot fit");
        check(&[2, 2, 2], 2, "its 2 ids take 2");
        check(&[0x80, 0x00], 1, "not canonical");
        check(&[0xFF; 6], 1, "longer than 5 bytes");
        check(&[1], 1, "global id 0 is -1"); // zigzag 1 = −1
                                             // 1000 is past the 1000-vertex input.
        let mut stream = Vec::new();
        encode_global_ids(&[999, 1000], &mut stream);
        check(&stream, 2, "global id 1 is 1000");
        check_global_ids(&stream[..2], 1, limit).unwrap();
        // u64::MAX-sized counts are refused before any work.
        check(&[], u64::MAX, "cannot fit");
    }
}
