//! Packed patches: the compressed form a repository stores by default (`SECTION_PACKED_STRIPS`),
//! decoded on the loader's thread into exactly the bytes `patch::encode_patch` writes (seed 001:
//! "stored externally in a compressed representation from which a version optimized for
//! efficient rendering can be rapidly extracted").
//!
//! A packed patch of a tet with n = `vertex_count` and m = `strip_index_count` holds:
//!
//! ```text
//! stream sizes      u32 × s, s = 2 + the attribute bits set (positions, normals?, colours?,
//!                   uvs?, strip: the order of the decoded patch)
//! positions         meshopt vertex codec (version 1) over n × [u32; 3]: the quantised
//!                   positions unpacked (`format::unpack_position`), so each axis is its own
//!                   channel and consecutive vertices (first-use order) give small deltas
//! normals           vertex codec over n × [i16; 2]          if ATTR_NORMALS
//! colours           vertex codec over n × [u8; 4]           if ATTR_COLORS
//! uvs               vertex codec over n × [f32; 2]          if ATTR_UVS
//! strip             `strip_codec.rs` over the m stored indices (`StripCoding::Nibbles`, the
//!                   default), or meshopt's index-sequence codec over them (u16 values with
//!                   restart 0xFFFF when n ≤ 65,535, u32 with 0xFFFF_FFFF otherwise;
//!                   `StripCoding::IndexSequence`, repositories packed before commit
//!                   4fa9fc2 of 2026-12-03): both keep their order, strips and restarts as they are
//! zero padding      to a multiple of 8
//! ```
//!
//! A patch with no vertex and no strip index packs to 0 bytes. Every attribute is kept
//! exactly: packing is lossless, so a packed repository draws the same pixels as an unpacked
//! one and its stored errors need no margin. The codecs' formats are pinned (vertex codec
//! version 1, the index codec's version 1, both decodable by every later meshoptimizer).
//!
//! Decoding trusts nothing: each stream's size is checked against the patch, meshoptimizer's
//! decoders are safe on any input, and the decoded positions and strip indices are checked
//! (every coordinate ≤ `POSITION_MAX`, every index < n or a restart), so a crafted patch whose
//! checksum matches still cannot make a renderer read outside the patch.

use super::format::PatchCodec;
use super::format::{
    align8, unpack_position, ATTR_ALL, ATTR_COLORS, ATTR_NORMALS, ATTR_UVS, POSITION_BITS,
    POSITION_MAX,
};
use super::patch::{patch_bytes_checked, MAX_U16_PATCH_VERTICES};
use super::strip_codec::{decode_strip as decode_nibbles, encode_strip};

/// The vertex codec's format version this writer pins.
const VERTEX_CODEC_VERSION: i32 = 1;
/// The vertex codec's compression level (meshoptimizer's default; 3 gains < 0.1 % here).
const VERTEX_CODEC_LEVEL: i32 = 2;

/// How a packed patch stores its strip (the rest is the same either way), or that the whole
/// patch is entropy-coded instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StripCoding {
    /// meshoptimizer's index-sequence codec (`PatchCodec::PackedV1`).
    IndexSequence,
    /// `strip_codec.rs`: 4-bit symbols for first-use order (`PatchCodec::Packed`).
    Nibbles,
    /// Not packed here: the whole patch coded by `coded.rs` (`PatchCodec::Coded`).
    Coded,
}

impl StripCoding {
    /// The strip coding of a packed codec (`None` for `Raw`).
    pub fn of(codec: PatchCodec) -> Option<StripCoding> {
        match codec {
            PatchCodec::Raw => None,
            PatchCodec::Packed => Some(StripCoding::Nibbles),
            PatchCodec::PackedV1 => Some(StripCoding::IndexSequence),
            PatchCodec::Coded => Some(StripCoding::Coded),
        }
    }
}

/// Why a packed patch cannot be decoded (the reader adds the tet).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("packed patch: {0}")]
pub struct UnpackError(pub String);

fn fail<T>(message: String) -> Result<T, UnpackError> {
    Err(UnpackError(message))
}

/// The streams of a patch with the `attributes` mask, in stored order, with their vertex size
/// (0 for the strip).
fn streams(attributes: u32) -> impl Iterator<Item = (&'static str, usize)> {
    let optional = [
        (ATTR_NORMALS, "normals", 4),
        (ATTR_COLORS, "colours", 4),
        (ATTR_UVS, "uvs", 8),
    ];
    std::iter::once(("positions", 12))
        .chain(
            optional
                .into_iter()
                .filter(move |&(bit, _, _)| attributes & bit != 0)
                .map(|(_, name, size)| (name, size)),
        )
        .chain(std::iter::once(("strip", 0)))
}

/// Appends the packed form of `raw` (one patch as `encode_patch` wrote it, padding included,
/// for `vertex_count` vertices, `strip_index_count` strip indices and the `attributes` mask)
/// to `out`, whose length must be a multiple of 8, its strip coded by `strips`; returns the
/// packed size (a multiple of 8). Panics if `raw` is not such a patch (the build made it: a
/// bug, not an input).
pub fn pack_patch(
    raw: &[u8],
    vertex_count: usize,
    strip_index_count: usize,
    attributes: u32,
    strips: StripCoding,
    out: &mut Vec<u8>,
) -> usize {
    if strips == StripCoding::Coded {
        return super::coded::code_patch(raw, vertex_count, strip_index_count, attributes, out);
    }
    assert!(
        attributes & !ATTR_ALL == 0,
        "attribute bits {attributes:#x}"
    );
    assert!(
        out.len().is_multiple_of(8),
        "packed patch would start unaligned"
    );
    let expected = patch_bytes_checked(vertex_count as u64, strip_index_count as u64, attributes);
    assert_eq!(Some(raw.len() as u64), expected, "raw patch size");
    let start = out.len();
    if vertex_count == 0 && strip_index_count == 0 {
        return 0;
    }
    let n = vertex_count;
    let mut encoded: Vec<Vec<u8>> = Vec::new();
    let mut at = 0;
    for (name, size) in streams(attributes) {
        let stream = match name {
            "positions" => {
                let unpacked: Vec<[u32; 3]> = raw[..8 * n]
                    .chunks_exact(8)
                    .map(|w| unpack_position([le_u32(&w[..4]), le_u32(&w[4..])]))
                    .collect();
                at = 8 * n;
                vertex_codec(&unpacked)
            }
            "strip" => {
                let wide = n > MAX_U16_PATCH_VERTICES;
                let bytes = &raw[at..at + strip_index_count * if wide { 4 } else { 2 }];
                let indices: Vec<u32> = if wide {
                    bytes.chunks_exact(4).map(le_u32).collect()
                } else {
                    bytes
                        .chunks_exact(2)
                        .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
                        .collect()
                };
                match strips {
                    StripCoding::Nibbles => {
                        let restart = if wide { u32::MAX } else { u16::MAX as u32 };
                        let mut stream = Vec::new();
                        encode_strip(&indices, restart, &mut stream);
                        stream
                    }
                    StripCoding::Coded => unreachable!("coded patches are coded apart"),
                    StripCoding::IndexSequence => {
                        // The bound grows with the largest value, and restarts are the largest.
                        let largest = indices.iter().max().map_or(0, |&i| i as usize + 1);
                        let stream = meshopt::encoding::encode_index_sequence(&indices, largest)
                            .expect("index sequence encoding");
                        assert!(
                            !stream.is_empty(),
                            "index sequence encoding ran out of room"
                        );
                        stream
                    }
                }
            }
            _ => {
                let bytes = &raw[at..at + size * n];
                at += size * n;
                match size {
                    4 => vertex_codec(bytemuck::cast_slice::<u8, [u8; 4]>(bytes)),
                    _ => vertex_codec(bytemuck::cast_slice::<u8, [u8; 8]>(bytes)),
                }
            }
        };
        encoded.push(stream);
    }
    for stream in &encoded {
        out.extend_from_slice(&(stream.len() as u32).to_le_bytes());
    }
    for stream in &encoded {
        out.extend_from_slice(stream);
    }
    out.resize(
        start + align8((out.len() - start) as u64).expect("small") as usize,
        0,
    );
    out.len() - start
}

fn le_u32(bytes: &[u8]) -> u32 {
    u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])
}

fn vertex_codec<T>(vertices: &[T]) -> Vec<u8> {
    meshopt::encoding::encode_vertex_buffer_level(
        vertices,
        VERTEX_CODEC_LEVEL,
        Some(VERTEX_CODEC_VERSION),
    )
    .expect("vertex buffer encoding")
}

thread_local! {
    /// Unpacked positions of the patch being decoded (12 bytes a vertex), reused.
    static POSITIONS: std::cell::RefCell<Vec<[u32; 3]>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Decodes a packed patch into `out`, which must be exactly the decoded size
/// (`patch_bytes(vertex_count, strip_index_count, attributes)`): afterwards `out` holds the
/// bytes `encode_patch` wrote for it. `strips` is how the strip was packed. Never panics;
/// allocates at most 12 bytes a vertex of scratch, once per thread.
pub fn unpack_patch(
    packed: &[u8],
    vertex_count: usize,
    strip_index_count: usize,
    attributes: u32,
    strips: StripCoding,
    out: &mut [u8],
) -> Result<(), UnpackError> {
    if strips == StripCoding::Coded {
        return super::coded::decode_patch(
            packed,
            vertex_count,
            strip_index_count,
            attributes,
            out,
        );
    }
    if attributes & !ATTR_ALL != 0 {
        return fail(format!("unknown attribute bits {attributes:#x}"));
    }
    let expected = patch_bytes_checked(vertex_count as u64, strip_index_count as u64, attributes);
    if expected != Some(out.len() as u64) {
        return fail(format!(
            "{} bytes to decode into, {vertex_count} vertices and {strip_index_count} strip \
             indices take {expected:?}",
            out.len()
        ));
    }
    if vertex_count == 0 && strip_index_count == 0 {
        out.fill(0);
        return match packed.len() {
            0 => Ok(()),
            len => fail(format!("an empty patch packed in {len} bytes, not 0")),
        };
    }
    let n = vertex_count;
    let stream_count = streams(attributes).count();
    let Some(head) = packed.get(..4 * stream_count) else {
        return fail(format!(
            "{} bytes cannot hold the sizes of {stream_count} streams",
            packed.len()
        ));
    };
    let mut from = head.len();
    let mut to = 0usize;
    for ((name, size), len) in streams(attributes).zip(head.chunks_exact(4)) {
        let len = le_u32(len) as usize;
        let Some(stream) = from.checked_add(len).and_then(|end| packed.get(from..end)) else {
            return fail(format!(
                "the {name} stream of {len} bytes at {from} exceeds the packed patch of {} bytes",
                packed.len()
            ));
        };
        from += len;
        let decoded = match name {
            "positions" => decode_positions(stream, n, &mut out[..8 * n]),
            "strip" => {
                let wide = n > MAX_U16_PATCH_VERTICES;
                let width = if wide { 4 } else { 2 };
                let target = &mut out[to..to + width * strip_index_count];
                match strips {
                    StripCoding::Nibbles => {
                        decode_nibbles(stream, n, width, target).map_err(UnpackError)
                    }
                    StripCoding::IndexSequence => {
                        decode_strip(stream, n, strip_index_count, width, target)
                    }
                    StripCoding::Coded => unreachable!("coded patches are decoded apart"),
                }
            }
            _ => decode_vertices(stream, n, size, &mut out[to..to + size * n]),
        };
        decoded.map_err(|e| UnpackError(format!("{name}: {}", e.0)))?;
        to += if name == "positions" { 8 * n } else { size * n };
    }
    // Every array was written in full; only the padding after the strip is left.
    let strip_width = if n > MAX_U16_PATCH_VERTICES { 4 } else { 2 };
    out[to + strip_width * strip_index_count..].fill(0);
    let padding = &packed[from..];
    if padding.len() >= 8 || padding.iter().any(|&b| b != 0) || !packed.len().is_multiple_of(8) {
        return fail(format!(
            "{} bytes after the streams (at most 7 zero bytes pad to a multiple of 8)",
            padding.len()
        ));
    }
    Ok(())
}

fn decode_vertices(
    stream: &[u8],
    n: usize,
    size: usize,
    target: &mut [u8],
) -> Result<(), UnpackError> {
    debug_assert_eq!(target.len(), n * size);
    // SAFETY: `target` holds n × size bytes; the decoder writes at most that many and reads
    // only `stream` (it checks every read against the given size).
    let code = unsafe {
        meshopt::ffi::meshopt_decodeVertexBuffer(
            target.as_mut_ptr().cast(),
            n,
            size,
            stream.as_ptr(),
            stream.len(),
        )
    };
    match code {
        0 => Ok(()),
        code => fail(format!("vertex codec error {code}")),
    }
}

fn decode_positions(stream: &[u8], n: usize, target: &mut [u8]) -> Result<(), UnpackError> {
    POSITIONS.with_borrow_mut(|scratch| {
        // Grown once per thread, never cleared: the decoder writes all of `..n`.
        if scratch.len() < n {
            scratch.resize(n, [0; 3]);
        }
        let scratch = &mut scratch[..n];
        decode_vertices(stream, n, 12, bytemuck::cast_slice_mut(scratch))?;
        // One pass packs (`pack_position`'s layout) and gathers every coordinate's bits: one
        // above the grid's makes the patch an error (found again only then, for the message).
        let mut bits = 0u32;
        for (q, to) in scratch.iter().zip(target.chunks_exact_mut(8)) {
            bits |= q[0] | q[1] | q[2];
            let packed =
                q[0] as u64 | (q[1] as u64) << POSITION_BITS | (q[2] as u64) << (2 * POSITION_BITS);
            to.copy_from_slice(&packed.to_le_bytes());
        }
        if bits > POSITION_MAX {
            let k = scratch
                .iter()
                .position(|q| q.iter().any(|&c| c > POSITION_MAX))
                .expect("a coordinate above the grid");
            return fail(format!(
                "vertex {k} at {:?} exceeds the {POSITION_MAX} grid",
                scratch[k]
            ));
        }
        Ok(())
    })
}

fn decode_strip(
    stream: &[u8],
    n: usize,
    m: usize,
    width: usize,
    target: &mut [u8],
) -> Result<(), UnpackError> {
    // SAFETY: `target` holds m × width bytes; the decoder writes m indices of `width` bytes
    // and reads only `stream`.
    let code = unsafe {
        meshopt::ffi::meshopt_decodeIndexSequence(
            target.as_mut_ptr().cast(),
            m,
            width,
            stream.as_ptr(),
            stream.len(),
        )
    };
    if code != 0 {
        return fail(format!("index codec error {code}"));
    }
    let bad = if width == 2 {
        target
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
            .position(|i| i != u16::MAX as u32 && i as usize >= n)
    } else {
        target
            .chunks_exact(4)
            .map(le_u32)
            .position(|i| i != u32::MAX && i as usize >= n)
    };
    match bad {
        Some(k) => fail(format!("strip index {k} is past the {n} vertices")),
        None => Ok(()),
    }
}

#[cfg(test)]
#[path = "packed_tests.rs"]
mod tests;

/// `contents` (a raw repository) with its patch blob packed as `codec`: each patch packed in
/// table order, the tets' patch ranges moved to match (checksums are the writer's). Panics if
/// `contents` is already packed, `codec` is not a packed one, or a patch does not fit its
/// record (an invalid repository).
pub fn pack_contents(
    contents: &super::writer::RepositoryContents,
    codec: PatchCodec,
) -> super::writer::RepositoryContents {
    assert_eq!(contents.codec, PatchCodec::Raw, "already packed");
    let strips = StripCoding::of(codec).expect("a packed codec");
    let attributes = contents.header.attributes;
    let mut packed = contents.clone();
    packed.codec = codec;
    packed.patch_blob.clear();
    for t in &mut packed.tets {
        let start = t.patch_offset as usize;
        let raw = &contents.patch_blob[start..start + t.patch_bytes as usize];
        t.patch_offset = packed.patch_blob.len() as u64;
        let size = pack_patch(
            raw,
            t.vertex_count as usize,
            t.strip_index_count as usize,
            attributes,
            strips,
            &mut packed.patch_blob,
        );
        t.patch_bytes = size as u32;
    }
    packed
}
