//! A patch's strip as stored (u16 or u32 indices with their restart value), walked as
//! triangles with the strip's alternating winding, and the check that every segment starts
//! at an even position.

use super::patch::{RESTART_U16, RESTART_U32};

/// The strip indices of a patch, as stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StripIndices<'a> {
    /// Restart `RESTART_U16`; patches of ≤ 65,535 vertices.
    U16(&'a [u16]),
    /// Restart `RESTART_U32`; larger patches.
    U32(&'a [u32]),
}

impl StripIndices<'_> {
    /// Number of indices, restarts included.
    pub fn len(&self) -> usize {
        match self {
            StripIndices::U16(s) => s.len(),
            StripIndices::U32(s) => s.len(),
        }
    }

    /// True when there are no indices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index `i` widened to u32, `None` for a restart. Panics if `i ≥ len()`.
    pub fn get(&self, i: usize) -> Option<u32> {
        match self {
            StripIndices::U16(s) => (s[i] != RESTART_U16).then_some(s[i] as u32),
            StripIndices::U32(s) => (s[i] != RESTART_U32).then_some(s[i]),
        }
    }

    /// The raw little-endian bytes (for an index buffer upload).
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            StripIndices::U16(s) => bytemuck::cast_slice(s),
            StripIndices::U32(s) => bytemuck::cast_slice(s),
        }
    }
}

/// The first position where a segment of three or more indices starts at an odd position, if
/// any (see the module comment: such a strip cannot be drawn as independent strip slots).
pub fn odd_segment_start(strip: StripIndices<'_>) -> Option<usize> {
    let mut start = 0;
    for k in 0..strip.len() {
        match strip.get(k) {
            None => start = k + 1,
            Some(_) if k == start + 2 && start % 2 == 1 => return Some(start),
            Some(_) => {}
        }
    }
    None
}

/// Decodes a strip into triangles (meshoptimizer's `unstripify`).
pub(super) struct StripTriangles<'a> {
    strip: StripIndices<'a>,
    next: usize,
    /// Indices seen since the last restart; its parity is the triangle's.
    run: usize,
    prev: [u32; 2],
}

impl<'a> StripTriangles<'a> {
    pub(super) fn new(strip: StripIndices<'a>) -> Self {
        StripTriangles {
            strip,
            next: 0,
            run: 0,
            prev: [0; 2],
        }
    }
}

impl Iterator for StripTriangles<'_> {
    type Item = [u32; 3];

    fn next(&mut self) -> Option<[u32; 3]> {
        while self.next < self.strip.len() {
            let index = self.strip.get(self.next);
            self.next += 1;
            let Some(c) = index else {
                self.run = 0;
                continue;
            };
            let [mut a, mut b] = self.prev;
            let complete = self.run >= 2;
            if self.run & 1 == 1 {
                std::mem::swap(&mut a, &mut b);
            }
            self.prev = [self.prev[1], c];
            self.run += 1;
            if complete && a != b && b != c && a != c {
                return Some([a, b, c]);
            }
        }
        None
    }
}
