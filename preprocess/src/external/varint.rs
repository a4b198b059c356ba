//! LEB128 varints and zigzag signs: how the out-of-core build's temporary files delta-code
//! sorted or neighbouring integers (triangle locations, leaf lists) in a byte or two.

/// Appends `v`, seven bits a byte, low first.
pub fn put(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// The varint at `*at` of `bytes`, moving past it; `None` when it runs past the end or over
/// 64 bits.
pub fn get(bytes: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let &b = bytes.get(*at)?;
        *at += 1;
        // The tenth byte holds bit 63 alone.
        if shift == 63 && b > 1 {
            return None;
        }
        v |= ((b & 0x7f) as u64) << shift;
        if b < 0x80 {
            return Some(v);
        }
    }
    None
}

/// A signed difference as an unsigned varint value: 0, -1, 1, -2, … → 0, 1, 2, 3, …
pub fn zigzag(d: i64) -> u64 {
    ((d << 1) ^ (d >> 63)) as u64
}

pub fn unzigzag(z: u64) -> i64 {
    ((z >> 1) as i64) ^ -((z & 1) as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_and_signs_come_back() {
        let values = [0, 1, 127, 128, 300, u32::MAX as u64, u64::MAX - 1, u64::MAX];
        let mut bytes = Vec::new();
        for v in values {
            put(&mut bytes, v);
        }
        let mut at = 0;
        for v in values {
            assert_eq!(get(&bytes, &mut at), Some(v));
        }
        assert_eq!(at, bytes.len());
        assert_eq!(get(&bytes, &mut at), None);
        // Eleven continuation bytes, or a tenth byte over 1: over 64 bits.
        assert_eq!(get(&[0xff; 11], &mut 0), None);
        let mut over = vec![0xff; 9];
        over.push(0x7f);
        assert_eq!(get(&over, &mut 0), None);
        over[9] = 1;
        assert_eq!(get(&over, &mut 0), Some(u64::MAX));
        for d in [0, 1, -1, 63, -64, i64::MAX, i64::MIN] {
            assert_eq!(unzigzag(zigzag(d)), d);
        }
        assert_eq!([0, -1, 1, -2].map(zigzag), [0, 1, 2, 3]);
    }
}
