//! A glTF accessor: the checks the gltf crate's readers assume and do not make, and its
//! elements read in order a span at a time from wherever its buffer is (memory or a file),
//! converted as the gltf crate's readers convert them (normalised integers by the same
//! arithmetic), so that a mesh read by chunks is the mesh the crate's readers would give.

use std::io;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::Accessor;

use super::container::Bytes;

/// The element type a semantic needs.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Want {
    Vec3F32,
    Color,
    TexCoord,
    Index,
}

/// Checks what reading assumes: the accessor has the type its semantic needs and at least
/// one element, its elements lie within its buffer view and the view within its buffer
/// (sparse indices and values too), strides are at least an element; and an accessor without
/// a buffer view (zeros plus sparse values) has no more elements than the buffers have bytes.
/// `lengths` are the buffers' lengths.
pub(super) fn check_accessor(
    accessor: &Accessor,
    want: Want,
    lengths: &[u64],
) -> Result<(), String> {
    use DataType::{F32, U16, U32, U8};
    use Dimensions::{Scalar, Vec2, Vec3, Vec4};
    let (ty, dims) = (accessor.data_type(), accessor.dimensions());
    let ok = match want {
        Want::Vec3F32 => ty == F32 && dims == Vec3,
        Want::Color => matches!(ty, U8 | U16 | F32) && matches!(dims, Vec3 | Vec4),
        Want::TexCoord => matches!(ty, U8 | U16 | F32) && dims == Vec2,
        Want::Index => matches!(ty, U8 | U16 | U32) && dims == Scalar,
    };
    let name = format!("accessor {}", accessor.index());
    if !ok {
        return Err(format!("{name} has the wrong type ({ty:?} {dims:?})"));
    }
    let count = accessor.count();
    if count == 0 {
        return Err(format!("{name} has no elements"));
    }
    let size = accessor.size();
    match accessor.view() {
        Some(view) => check_view(&name, &view, accessor.offset(), size, count, lengths)?,
        None => {
            let bytes: u64 = lengths.iter().sum();
            if count as u64 > bytes {
                return Err(format!(
                    "{name} has {count} elements and no buffer view, more than the {bytes} \
                     bytes of buffers"
                ));
            }
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        if n == 0 || n > count {
            return Err(format!("{name}: {n} sparse values for {count} elements"));
        }
        let indices = sparse.indices();
        let index_size = indices.index_type().size();
        check_view(
            &format!("{name} sparse indices"),
            &indices.view(),
            indices.offset(),
            index_size,
            n,
            lengths,
        )?;
        let values = sparse.values();
        check_view(
            &format!("{name} sparse values"),
            &values.view(),
            values.offset(),
            size,
            n,
            lengths,
        )?;
    }
    Ok(())
}

/// `count` elements of `size` bytes from `offset` in `view` lie within the view, and the view
/// within its buffer.
fn check_view(
    name: &str,
    view: &::gltf::buffer::View,
    offset: usize,
    size: usize,
    count: usize,
    lengths: &[u64],
) -> Result<(), String> {
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{name}: buffer view {} has stride {stride}, less than the element's {size} bytes",
            view.index()
        ));
    }
    let end = (count as u128 - 1) * stride as u128 + offset as u128 + size as u128;
    if end > view.length() as u128 {
        return Err(format!(
            "{name}: {count} elements from byte {offset} need {end} bytes, buffer view {} has {}",
            view.index(),
            view.length()
        ));
    }
    let view_end = view.offset() as u128 + view.length() as u128;
    let buffer = view.buffer().index();
    let held = lengths.get(buffer).copied().unwrap_or(0);
    if view_end > held as u128 {
        return Err(format!(
            "buffer view {} ends at byte {view_end}, buffer {buffer} has {held} bytes",
            view.index()
        ));
    }
    Ok(())
}

/// Whether the accessor has data to read: a buffer view or sparse values (the gltf crate's
/// readers give nothing for one with neither).
pub(super) fn readable(accessor: &Accessor) -> bool {
    accessor.view().is_some() || accessor.sparse().is_some()
}

/// Evenly strided elements in a buffer.
struct Strided<'a> {
    bytes: &'a Bytes<'a>,
    first: u64,
    stride: u64,
    size: usize,
}

impl Strided<'_> {
    /// Elements `from..from + n`, packed, appended to `out`; `scratch` holds the span read.
    fn read(
        &self,
        from: usize,
        n: usize,
        out: &mut Vec<u8>,
        scratch: &mut Vec<u8>,
    ) -> io::Result<()> {
        if n == 0 {
            return Ok(());
        }
        let span = (n as u64 - 1) * self.stride + self.size as u64;
        scratch.resize(span as usize, 0);
        self.bytes
            .read_at(self.first + from as u64 * self.stride, scratch)?;
        if self.stride == self.size as u64 {
            out.extend_from_slice(scratch);
        } else {
            for k in 0..n {
                let at = k * self.stride as usize;
                out.extend_from_slice(&scratch[at..at + self.size]);
            }
        }
        Ok(())
    }
}

/// A view's elements from `offset`: its stride, or packed.
fn strided<'a>(
    view: &::gltf::buffer::View,
    offset: usize,
    size: usize,
    buffers: &'a [Bytes<'a>],
) -> Strided<'a> {
    Strided {
        bytes: &buffers[view.buffer().index()],
        first: (view.offset() + offset) as u64,
        stride: view.stride().unwrap_or(size) as u64,
        size,
    }
}

/// Sparse substitutions, held in memory (at most one per element, and within the buffers).
struct Sparse {
    indices: Vec<u32>,
    values: Vec<u8>,
    /// The next substitution: taken when its index is the element's (as the gltf crate's
    /// reader takes them: in order, so an index out of order is never taken).
    next: usize,
}

/// An accessor's elements in order (checked by [`check_accessor`] and [`readable`]).
pub(super) struct Elements<'a> {
    base: Option<Strided<'a>>,
    size: usize,
    count: usize,
    done: usize,
    sparse: Option<Sparse>,
    scratch: Vec<u8>,
}

impl<'a> Elements<'a> {
    pub fn new(accessor: &Accessor, buffers: &'a [Bytes<'a>]) -> io::Result<Elements<'a>> {
        let size = accessor.size();
        let base = accessor
            .view()
            .map(|view| strided(&view, accessor.offset(), size, buffers));
        let mut scratch = Vec::new();
        let sparse = match accessor.sparse() {
            Some(sparse) => {
                let n = sparse.count();
                let indices = sparse.indices();
                let index_type = indices.index_type();
                let index_size = index_type.size();
                let mut packed = Vec::with_capacity(n * index_size);
                strided(&indices.view(), indices.offset(), index_size, buffers).read(
                    0,
                    n,
                    &mut packed,
                    &mut scratch,
                )?;
                let indices = packed
                    .chunks_exact(index_size)
                    .map(|b| match b.len() {
                        1 => u32::from(b[0]),
                        2 => u32::from(u16::from_le_bytes([b[0], b[1]])),
                        _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                    })
                    .collect();
                let values_at = sparse.values();
                let mut values = Vec::with_capacity(n * size);
                strided(&values_at.view(), values_at.offset(), size, buffers).read(
                    0,
                    n,
                    &mut values,
                    &mut scratch,
                )?;
                Some(Sparse {
                    indices,
                    values,
                    next: 0,
                })
            }
            None => None,
        };
        Ok(Elements {
            base,
            size,
            count: accessor.count(),
            done: 0,
            sparse,
            scratch,
        })
    }

    pub fn count(&self) -> usize {
        self.count
    }

    /// Up to `max` next elements, packed (`size` bytes each), into `out`; how many (0 at the
    /// end).
    pub fn next_chunk(&mut self, max: usize, out: &mut Vec<u8>) -> io::Result<usize> {
        out.clear();
        let n = max.min(self.count - self.done);
        match &self.base {
            Some(base) => base.read(self.done, n, out, &mut self.scratch)?,
            None => out.resize(n * self.size, 0),
        }
        if let Some(sparse) = &mut self.sparse {
            for k in 0..n {
                let element = (self.done + k) as u64;
                if sparse
                    .indices
                    .get(sparse.next)
                    .is_some_and(|&i| u64::from(i) == element)
                {
                    let value = &sparse.values[sparse.next * self.size..][..self.size];
                    out[k * self.size..][..self.size].copy_from_slice(value);
                    sparse.next += 1;
                }
            }
        }
        self.done += n;
        Ok(n)
    }
}

fn f32_at(b: &[u8], k: usize) -> f32 {
    f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
}

fn u16_at(b: &[u8], k: usize) -> u16 {
    u16::from_le_bytes([b[2 * k], b[2 * k + 1]])
}

/// A `VEC3` of `f32`.
pub(super) fn vec3(e: &[u8]) -> [f32; 3] {
    [f32_at(e, 0), f32_at(e, 1), f32_at(e, 2)]
}

/// A colour as RGBA bytes: `u16` keeps its high byte, `f32` in [0, 1] scales by 255
/// (truncated), a missing alpha is opaque.
pub(super) fn color(e: &[u8], ty: DataType, dims: Dimensions) -> [u8; 4] {
    let channels = if dims == Dimensions::Vec3 { 3 } else { 4 };
    let mut c = [255u8; 4];
    for (k, v) in c.iter_mut().take(channels).enumerate() {
        *v = match ty {
            DataType::U8 => e[k],
            DataType::U16 => (u16_at(e, k) / 0x100) as u8,
            _ => (f32_at(e, k).max(0.0) * 255.0) as u8,
        };
    }
    c
}

/// Texture coordinates: normalised integers times the reciprocal of their maximum.
pub(super) fn tex_coord(e: &[u8], ty: DataType) -> [f32; 2] {
    match ty {
        DataType::U8 => [0, 1].map(|k| e[k] as f32 * 255.0_f32.recip()),
        DataType::U16 => [0, 1].map(|k| u16_at(e, k) as f32 * 65535.0_f32.recip()),
        _ => [f32_at(e, 0), f32_at(e, 1)],
    }
}

/// A vertex index.
pub(super) fn index(e: &[u8], ty: DataType) -> u32 {
    match ty {
        DataType::U8 => u32::from(e[0]),
        DataType::U16 => u32::from(u16_at(e, 0)),
        _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
    }
}
