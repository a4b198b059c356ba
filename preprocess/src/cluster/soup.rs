//! The staged mesh as a triangle soup on disk, sorted by octree cell (seed 004 sections 3.3
//! and 4.2: "external sorting and dereferencing"): each triangle with its corners' vertex
//! words, keyed by the Morton code of its barycentre on the 2^21 grid over the model's cube.
//!
//! Dereferencing is a join within the budget: the vertices' words (position as f32, then the
//! attributes) are held in memory where they fit a quarter of the budget, else written once
//! to a file that each chunk of triangles (half the budget) reads in order a block at a time,
//! skipping blocks none of the chunk's corners (sorted by vertex) needs. The joined records
//! are written unsorted, then go through the external merge sort (`external::sort`) with
//! most of the budget, and the sorted soup and its keys are written as record files.

use std::io;
use std::path::Path;

use bytemuck::Zeroable;

use super::layout::{self, Attributes, Layout, COLOR_AT, KEY_BITS, NORMAL_AT, UV_AT};
use crate::external::staged::{RecordReader, RecordWriter};
use crate::external::{sort_external, RecordFile, StagedMesh};

/// The sorted soup.
pub struct Soup<L: Layout> {
    pub sorted: RecordFile<L::Rec>,
    /// The records' keys, in the same order (the octree is built from them alone).
    pub keys: RecordFile<u64>,
    /// The model box (of the f64 positions read; records hold them as f32).
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// The largest extent of the box: the side of the octree's cube.
    pub extent: f64,
    pub attributes: Attributes,
    pub vertices: u64,
    pub triangles: u64,
}

/// Bytes a triangle of a join chunk holds: its ids, its corners' sort keys and words, its
/// record.
fn join_bytes<L: Layout>() -> usize {
    12 + 24 + 12 * L::VW + std::mem::size_of::<L::Rec>()
}

/// Builds the sorted soup of `staged` in `dir` with about `budget` bytes of memory.
pub fn build<L: Layout>(staged: &StagedMesh, budget: usize, dir: &Path) -> io::Result<Soup<L>> {
    let a = &staged.attributes;
    let attributes = Attributes {
        normals: a.normals.is_some(),
        colors: a.colors.is_some(),
        uvs: a.uvs.is_some(),
    };
    assert!(L::VW >= 3 + 6 * attributes.any() as usize);
    let (min, max) = bounding_box(staged)?;
    let extent = (0..3).map(|k| max[k] - min[k]).fold(0.0f64, f64::max);
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            "the mesh has no extent (all its vertices at one point) or a position not finite",
        ));
    }
    let vertices = staged.positions.len();
    let vertex_bytes = vertices as usize * 4 * L::VW;
    let table = if vertex_bytes <= budget / 4 {
        let mut all = Vec::with_capacity(vertices as usize);
        for_each_vertex::<L>(staged, &mut |v| {
            all.push(v);
            Ok(())
        })?;
        VertexSource::Memory(all)
    } else {
        let mut file: RecordWriter<L::Vert> = RecordFile::create(dir)?;
        for_each_vertex::<L>(staged, &mut |v| file.push(&v))?;
        VertexSource::File(file.finish()?)
    };
    let chunk = (budget / 2 / join_bytes::<L>()).max(1 << 10);
    let mut join = Join::<L> {
        triangles: staged.triangles.read()?,
        chunk,
        table,
        min,
        extent,
        vertices,
        buffer: Vec::new(),
        at: 0,
        error: None,
    };
    let mut unsorted: RecordWriter<L::Rec> = RecordFile::create(dir)?;
    for r in join.by_ref() {
        unsorted.push(&r)?;
    }
    if let Some(e) = join.error.take() {
        return Err(e);
    }
    drop(join);
    let unsorted = unsorted.finish()?;
    let mut error = None;
    let records = unsorted.read()?.map_while(|r| match r {
        Ok(r) => Some(r),
        Err(e) => {
            error = Some(e);
            None
        }
    });
    // The sort fills its buffer from an iterator of unknown length, so the buffer grows by
    // doubling: a power of two records is what it then holds, not up to twice that.
    let record = std::mem::size_of::<L::Rec>();
    let sort_records = ((budget * 5 / 8 / record).max(2) + 1).next_power_of_two() / 2;
    let sorted = sort_external(records, sort_records * record, dir)?;
    if let Some(e) = error {
        return Err(e);
    }
    unsorted.discard()?;
    let mut records: RecordWriter<L::Rec> = RecordFile::create(dir)?;
    let mut keys: RecordWriter<u64> = RecordFile::create(dir)?;
    for r in sorted {
        let r = r?;
        keys.push(&layout::key::<L>(&r))?;
        records.push(&r)?;
    }
    let triangles = records.len();
    Ok(Soup {
        sorted: records.finish()?,
        keys: keys.finish()?,
        min,
        max,
        extent,
        attributes,
        vertices,
        triangles,
    })
}

fn bounding_box(staged: &StagedMesh) -> io::Result<([f64; 3], [f64; 3])> {
    let mut min = [f64::INFINITY; 3];
    let mut max = [f64::NEG_INFINITY; 3];
    for p in staged.positions.read()? {
        let p = p?;
        for k in 0..3 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    Ok((min, max))
}

/// Every vertex's words, in id order.
fn for_each_vertex<L: Layout>(
    staged: &StagedMesh,
    f: &mut dyn FnMut(L::Vert) -> io::Result<()>,
) -> io::Result<()> {
    let a = &staged.attributes;
    let mut normals = a.normals.as_ref().map(RecordFile::read).transpose()?;
    let mut colors = a.colors.as_ref().map(RecordFile::read).transpose()?;
    let mut uvs = a.uvs.as_ref().map(RecordFile::read).transpose()?;
    fn next<T: bytemuck::Pod>(r: &mut Option<RecordReader<T>>) -> io::Result<Option<T>> {
        match r {
            None => Ok(None),
            Some(r) => r
                .next()
                .transpose()?
                .map(Some)
                .ok_or_else(|| io::Error::other("a staged attribute file ends early")),
        }
    }
    for p in staged.positions.read()? {
        let p = p?;
        let mut v = L::Vert::zeroed();
        let w: &mut [u32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut v));
        for k in 0..3 {
            w[k] = (p[k] as f32).to_bits();
        }
        if let Some(n) = next(&mut normals)? {
            for k in 0..3 {
                w[NORMAL_AT + k] = n[k].to_bits();
            }
        }
        if let Some(c) = next(&mut colors)? {
            w[COLOR_AT] = u32::from_le_bytes(c);
        }
        if let Some(uv) = next(&mut uvs)? {
            w[UV_AT] = uv[0].to_bits();
            w[UV_AT + 1] = uv[1].to_bits();
        }
        f(v)?;
    }
    Ok(())
}

enum VertexSource<L: Layout> {
    Memory(Vec<L::Vert>),
    File(RecordFile<L::Vert>),
}

/// The soup's records, a chunk of triangles at a time; the first error ends the stream and
/// is kept in `error`.
struct Join<L: Layout> {
    triangles: RecordReader<[u32; 3]>,
    chunk: usize,
    table: VertexSource<L>,
    min: [f64; 3],
    extent: f64,
    vertices: u64,
    buffer: Vec<L::Rec>,
    at: usize,
    error: Option<io::Error>,
}

impl<L: Layout> Iterator for Join<L> {
    type Item = L::Rec;

    fn next(&mut self) -> Option<L::Rec> {
        if self.at == self.buffer.len() {
            if self.error.is_some() {
                return None;
            }
            if let Err(e) = self.fill() {
                self.error = Some(e);
                return None;
            }
            if self.buffer.is_empty() {
                return None;
            }
        }
        self.at += 1;
        Some(self.buffer[self.at - 1])
    }
}

impl<L: Layout> Join<L> {
    /// The next chunk's records into `buffer` (empty at the end).
    fn fill(&mut self) -> io::Result<()> {
        self.buffer.clear();
        self.at = 0;
        let part: Vec<[u32; 3]> = self
            .triangles
            .by_ref()
            .take(self.chunk)
            .collect::<io::Result<_>>()?;
        if part.is_empty() {
            return Ok(());
        }
        if let Some(bad) = part.iter().flatten().find(|&&v| v as u64 >= self.vertices) {
            return Err(io::Error::other(format!(
                "a staged triangle names vertex {bad} of {}",
                self.vertices
            )));
        }
        // Each corner's vertex words, in corner order.
        let mut words = vec![L::Vert::zeroed(); 3 * part.len()];
        match &self.table {
            VertexSource::Memory(all) => {
                for (slot, v) in part.iter().flatten().enumerate() {
                    words[slot] = all[*v as usize];
                }
            }
            VertexSource::File(file) => {
                let mut corners: Vec<u64> = part
                    .iter()
                    .flatten()
                    .enumerate()
                    .map(|(slot, &v)| ((v as u64) << 32) | slot as u64)
                    .collect();
                corners.sort_unstable();
                // Blocks of the vertex file in order, those no corner needs skipped.
                const BLOCK: u64 = 1 << 12;
                let mut reader = file.read_chunks(BLOCK as usize)?;
                let (mut block, mut start) = (Vec::new(), 0u64);
                for c in corners {
                    let id = c >> 32;
                    while id >= start + block.len() as u64 {
                        start += block.len() as u64;
                        block.clear();
                        let gap = (id - start) / BLOCK * BLOCK;
                        reader.skip_records(gap)?;
                        start += gap;
                        if !reader.read_into(&mut block)? {
                            return Err(io::Error::other("the vertex file ends early"));
                        }
                    }
                    words[c as u32 as usize] = block[(id - start) as usize];
                }
            }
        }
        let scale = (1u64 << KEY_BITS) as f64 / self.extent;
        let top = (1u32 << KEY_BITS) - 1;
        for (t, ids) in part.iter().enumerate() {
            let c: [&[u32]; 3] =
                [0, 1, 2].map(|k| bytemuck::cast_slice(std::slice::from_ref(&words[3 * t + k])));
            let mut q = [0u32; 3];
            for (axis, q) in q.iter_mut().enumerate() {
                let centre = (0..3)
                    .map(|k| f32::from_bits(c[k][axis]) as f64)
                    .sum::<f64>()
                    / 3.0
                    - self.min[axis];
                *q = ((centre * scale).floor().max(0.0) as u64).min(top as u64) as u32;
            }
            self.buffer
                .push(layout::record::<L>(layout::morton(q), *ids, c));
        }
        Ok(())
    }
}
