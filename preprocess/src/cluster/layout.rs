//! The fixed-size records of the clusterer's files: a vertex as u32 words (position as f32,
//! as the output stores it, so a kept vertex is written as read; then the attributes the input has), and a triangle
//! of the soup as its sort key, its three vertex ids and its three corners' vertex words.
//! Two layouts: `Plain` (positions only, 56 bytes a triangle) and `Rich` (room for normals,
//! colour and texture coordinates, 128 bytes), chosen once from what the input carries.

use bytemuck::{Pod, Zeroable};

/// u32 words a record starts with before its corners: key (2, high word first so the
/// array's order is the key's), vertex ids (3).
pub const HEAD: usize = 5;

/// A record layout: `VW` u32 words a vertex, a triangle record of `HEAD + 3 VW` words.
pub trait Layout: Send + Sync + 'static {
    const VW: usize;
    type Vert: Pod + Send + Sync;
    type Rec: Pod + Ord + Send + Sync;
}

/// Positions only.
pub struct Plain;
impl Layout for Plain {
    const VW: usize = 3;
    type Vert = [u32; 3];
    type Rec = [u32; 14];
}

/// Position, normal (3), RGBA8 colour (1 word), texture coordinates (2).
pub struct Rich;
impl Layout for Rich {
    const VW: usize = 9;
    type Vert = [u32; 9];
    type Rec = [u32; 32];
}

/// Which attributes the input's vertices carry (all or none of each).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Attributes {
    pub normals: bool,
    pub colors: bool,
    pub uvs: bool,
}

impl Attributes {
    pub fn any(self) -> bool {
        self.normals || self.colors || self.uvs
    }

    /// Dimensions of the generalised quadric's space: position, then each attribute.
    pub fn dims(self) -> usize {
        3 + 3 * self.normals as usize + 4 * self.colors as usize + 2 * self.uvs as usize
    }
}

/// Word offsets within a `Rich` vertex.
pub const NORMAL_AT: usize = 3;
pub const COLOR_AT: usize = 6;
pub const UV_AT: usize = 7;

/// A record's words.
pub fn words<L: Layout>(r: &L::Rec) -> &[u32] {
    bytemuck::cast_slice(std::slice::from_ref(r))
}

pub fn words_mut<L: Layout>(r: &mut L::Rec) -> &mut [u32] {
    bytemuck::cast_slice_mut(std::slice::from_mut(r))
}

pub fn key<L: Layout>(r: &L::Rec) -> u64 {
    let w = words::<L>(r);
    ((w[0] as u64) << 32) | w[1] as u64
}

pub fn set_key<L: Layout>(r: &mut L::Rec, key: u64) {
    let w = words_mut::<L>(r);
    w[0] = (key >> 32) as u32;
    w[1] = key as u32;
}

pub fn ids<L: Layout>(r: &L::Rec) -> [u32; 3] {
    let w = words::<L>(r);
    [w[2], w[3], w[4]]
}

/// Corner `k`'s vertex words.
pub fn corner<L: Layout>(r: &L::Rec, k: usize) -> &[u32] {
    &words::<L>(r)[HEAD + k * L::VW..HEAD + (k + 1) * L::VW]
}

/// A triangle record from its key, ids and corners' words (each `VW` long).
pub fn record<L: Layout>(key: u64, ids: [u32; 3], corners: [&[u32]; 3]) -> L::Rec {
    let mut r = L::Rec::zeroed();
    set_key::<L>(&mut r, key);
    let w = words_mut::<L>(&mut r);
    w[2..5].copy_from_slice(&ids);
    for (k, c) in corners.iter().enumerate() {
        w[HEAD + k * L::VW..HEAD + (k + 1) * L::VW].copy_from_slice(c);
    }
    r
}

/// A vertex's position.
pub fn position(v: &[u32]) -> [f32; 3] {
    [
        f32::from_bits(v[0]),
        f32::from_bits(v[1]),
        f32::from_bits(v[2]),
    ]
}

/// A vertex as a point of the quadric's space: the position less the box's minimum, divided
/// by the model's extent (so the model spans [0, 1] and its attributes weigh as much as its shape: normals in
/// [-1, 1], colours in [0, 1], texture coordinates as stored); `out[..dims]` is written.
pub fn vector(v: &[u32], attributes: Attributes, min: [f64; 3], inv_extent: f64, out: &mut [f64]) {
    let p = position(v);
    let mut n = 0;
    for (k, &x) in p.iter().enumerate() {
        out[n] = (x as f64 - min[k]) * inv_extent;
        n += 1;
    }
    if attributes.normals {
        for k in 0..3 {
            out[n] = f32::from_bits(v[NORMAL_AT + k]) as f64;
            n += 1;
        }
    }
    if attributes.colors {
        for b in v[COLOR_AT].to_le_bytes() {
            out[n] = b as f64 / 255.0;
            n += 1;
        }
    }
    if attributes.uvs {
        for k in 0..2 {
            out[n] = f32::from_bits(v[UV_AT + k]) as f64;
            n += 1;
        }
    }
}

/// The vertex words of a point of the quadric's space (`vector`'s inverse; a normal is
/// renormalised, a colour rounded and clamped).
pub fn from_vector(x: &[f64], attributes: Attributes, min: [f64; 3], extent: f64, out: &mut [u32]) {
    let mut n = 0;
    for o in out.iter_mut().take(3) {
        *o = ((min[n] + x[n] * extent) as f32).to_bits();
        n += 1;
    }
    if attributes.normals {
        let v = [x[n], x[n + 1], x[n + 2]];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        for k in 0..3 {
            let c = if len > 0.0 { v[k] / len } else { 0.0 };
            out[NORMAL_AT + k] = (c as f32).to_bits();
        }
        n += 3;
    }
    if attributes.colors {
        let mut rgba = [0u8; 4];
        for (k, c) in rgba.iter_mut().enumerate() {
            *c = (x[n + k] * 255.0).round().clamp(0.0, 255.0) as u8;
        }
        out[COLOR_AT] = u32::from_le_bytes(rgba);
        n += 4;
    }
    if attributes.uvs {
        for k in 0..2 {
            out[UV_AT + k] = (x[n + k] as f32).to_bits();
        }
    }
}

/// The Morton code of a point of the 2^21 grid: x's bit in the lowest of each triple.
pub fn morton(q: [u32; 3]) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut x = (v & 0x1f_ffff) as u64;
        x = (x | (x << 32)) & 0x1f00000000ffff;
        x = (x | (x << 16)) & 0x1f0000ff0000ff;
        x = (x | (x << 8)) & 0x100f00f00f00f00f;
        x = (x | (x << 4)) & 0x10c30c30c30c30c3;
        x = (x | (x << 2)) & 0x1249249249249249;
        x
    }
    spread(q[0]) | (spread(q[1]) << 1) | (spread(q[2]) << 2)
}

/// `morton`'s inverse.
pub fn unmorton(code: u64) -> [u32; 3] {
    fn compact(mut x: u64) -> u32 {
        x &= 0x1249249249249249;
        x = (x | (x >> 2)) & 0x10c30c30c30c30c3;
        x = (x | (x >> 4)) & 0x100f00f00f00f00f;
        x = (x | (x >> 8)) & 0x1f0000ff0000ff;
        x = (x | (x >> 16)) & 0x1f00000000ffff;
        x = (x | (x >> 32)) & 0x1f_ffff;
        x as u32
    }
    [compact(code), compact(code >> 1), compact(code >> 2)]
}

/// Bits per axis of the key grid: the octree is at most this deep.
pub const KEY_BITS: u32 = 21;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_round_trips_and_orders_octants() {
        for q in [
            [0, 0, 0],
            [1, 2, 3],
            [0x1f_ffff, 5, 0x10_0000],
            [7, 0x1f_ffff, 9],
        ] {
            assert_eq!(unmorton(morton(q)), q);
        }
        // The top three bits are the octant of the whole cube.
        assert_eq!(morton([1 << 20, 0, 0]) >> 60, 1);
        assert_eq!(morton([0, 1 << 20, 0]) >> 60, 2);
        assert_eq!(morton([0, 0, 1 << 20]) >> 60, 4);
    }

    #[test]
    fn vectors_round_trip_with_attributes() {
        let a = Attributes {
            normals: true,
            colors: true,
            uvs: true,
        };
        let mut v = [0u32; 9];
        v[0] = 2.0f32.to_bits();
        v[1] = 1.0f32.to_bits();
        v[NORMAL_AT + 2] = 1.0f32.to_bits();
        v[COLOR_AT] = u32::from_le_bytes([10, 20, 30, 255]);
        v[UV_AT] = 0.25f32.to_bits();
        let mut x = [0.0; 12];
        vector(&v, a, [1.0, 0.0, 0.0], 0.5, &mut x);
        assert_eq!(x[..3], [0.5, 0.5, 0.0]);
        let mut back = [0u32; 9];
        from_vector(&x, a, [1.0, 0.0, 0.0], 2.0, &mut back);
        assert_eq!(back, v);
    }
}
