//! An OBJ's texture coordinates and normals, staged out of core. OBJ indexes them apart from
//! positions (`f v/vt/vn`); a vertex takes those of the first face corner that uses it
//! (`import/obj.rs`). In memory that is a `u32` a vertex per attribute and every `vt` and `vn`
//! value; here the values go to record files as they are read, each vertex's first corner
//! (found with a bit a vertex) to another, and the attributes are joined into vertex order
//! at the end by two external sorts each: the first corners by attribute index (the values
//! picked in one pass over their file), the picked values back by vertex.
//!
//! The in-memory import keeps a vertex's corners with other indices as wedges (`obj.rs`),
//! which the out-of-core build does not yet: the other corners are staged too, and a vertex
//! whose kept attribute's index differs between its corners refuses the staging
//! (`wedge_check::refused`; an OBJ repeating a value under two indices is refused as well).

use std::io;
use std::path::{Path, PathBuf};

use super::cursor::Cursor;
use super::fallible::{check, ok_values};
use super::sort::sort_external;
use super::staged::{RecordFile, RecordWriter};

/// No attribute index: a corner without one.
pub const NONE: u32 = u32::MAX;

/// An OBJ's attribute values and each vertex's first face corner, on disk.
pub struct CornerStager {
    dir: PathBuf,
    /// A bit a vertex: whether a face corner used it yet.
    seen: Vec<u64>,
    /// (vertex, texture coordinate index, normal index) of each vertex's first corner, in the
    /// order they were met.
    firsts: RecordWriter<[u32; 3]>,
    /// (vertex, texture coordinate index, normal index) of every later corner with either.
    others: RecordWriter<[u32; 3]>,
    texcoords: RecordWriter<[f32; 2]>,
    normals: RecordWriter<[f32; 3]>,
}

impl CornerStager {
    pub fn new(dir: &Path) -> io::Result<CornerStager> {
        Ok(CornerStager {
            dir: dir.to_path_buf(),
            seen: Vec::new(),
            firsts: RecordFile::create(dir)?,
            others: RecordFile::create(dir)?,
            texcoords: RecordFile::create(dir)?,
            normals: RecordFile::create(dir)?,
        })
    }

    /// The next `vt` value.
    pub fn texcoord(&mut self, uv: [f32; 2]) -> io::Result<()> {
        self.texcoords.push(&uv)
    }

    /// The next `vn` value.
    pub fn normal(&mut self, n: [f32; 3]) -> io::Result<()> {
        self.normals.push(&n)
    }

    /// A face corner: vertex `v` with its `vt` and `vn` indices ([`NONE`] where absent),
    /// already checked against the values read so far.
    pub fn corner(&mut self, v: u32, vt: u32, vn: u32) -> io::Result<()> {
        let (word, bit) = ((v / 64) as usize, v % 64);
        if word >= self.seen.len() {
            self.seen.resize(word + 1, 0);
        }
        if self.seen[word] >> bit & 1 == 0 {
            self.seen[word] |= 1 << bit;
            self.firsts.push(&[v, vt, vn])?;
        } else if vt != NONE || vn != NONE {
            self.others.push(&[v, vt, vn])?;
        }
        Ok(())
    }

    /// Each of `vertices` vertices' texture coordinate (when `uvs`) and normal (when
    /// `normals`) in vertex order, zero for a vertex whose first corner has none; sorting with
    /// about `budget` bytes of memory.
    #[allow(clippy::type_complexity)]
    pub fn finish(
        self,
        vertices: u64,
        uvs: bool,
        normals: bool,
        budget: usize,
    ) -> io::Result<(Option<RecordFile<[f32; 2]>>, Option<RecordFile<[f32; 3]>>)> {
        let CornerStager {
            dir,
            seen,
            firsts,
            others,
            texcoords,
            normals: normal_values,
        } = self;
        drop(seen);
        let firsts = firsts.finish()?;
        let others = others.finish()?;
        if uvs || normals {
            refuse_other_corners(&firsts, &others, [uvs, normals], budget, &dir)?;
        }
        drop(others);
        let texcoords = texcoords.finish()?;
        let normal_values = normal_values.finish()?;
        let uvs = match uvs {
            true => Some(by_vertex(&firsts, 1, &texcoords, vertices, budget, &dir)?),
            false => None,
        };
        drop(texcoords);
        let normals = match normals {
            true => Some(by_vertex(
                &firsts,
                2,
                &normal_values,
                vertices,
                budget,
                &dir,
            )?),
            false => None,
        };
        Ok((uvs, normals))
    }
}

/// Fails with `wedge_check::refused` where a later corner of a vertex (`others`) has another
/// index than its first corner (`firsts`) for a kept attribute (`kept`: texture coordinates,
/// normals): the in-memory import would keep it as a wedge.
fn refuse_other_corners(
    firsts: &RecordFile<[u32; 3]>,
    others: &RecordFile<[u32; 3]>,
    kept: [bool; 2],
    budget: usize,
    dir: &Path,
) -> io::Result<()> {
    if others.is_empty() {
        return Ok(());
    }
    let mut error = None;
    let firsts = sort_external(ok_values(firsts.read()?, &mut error), budget / 4, dir)?;
    check(error.take())?;
    let others = sort_external(ok_values(others.read()?, &mut error), budget / 4, dir)?;
    check(error.take())?;
    let mut firsts = firsts.peekable();
    for other in others {
        let other = other?;
        while firsts
            .peek()
            .is_some_and(|f| f.as_ref().map_or(true, |f| f[0] < other[0]))
        {
            firsts.next().expect("peeked")?;
        }
        let Some(first) = firsts.peek() else {
            return Err(io::Error::other("a corner without a first corner"));
        };
        let first = *first
            .as_ref()
            .map_err(|e| io::Error::new(e.kind(), e.to_string()))?;
        let differs = (1..3).any(|k| kept[k - 1] && first[k] != other[k]);
        if first[0] != other[0] || differs {
            return Err(super::wedge_check::refused());
        }
    }
    Ok(())
}

/// `values[first[slot]]` for each vertex's first corner, in vertex order (zero where the
/// corner has none, or the vertex no corner).
fn by_vertex<const N: usize>(
    firsts: &RecordFile<[u32; 3]>,
    slot: usize,
    values: &RecordFile<[f32; N]>,
    vertices: u64,
    budget: usize,
    dir: &Path,
) -> io::Result<RecordFile<[f32; N]>>
where
    [f32; N]: bytemuck::Pod,
{
    let mut error = None;
    // (attribute index, vertex), by attribute index.
    let wanted = sort_external(
        ok_values(firsts.read()?, &mut error)
            .filter(|f| f[slot] != NONE)
            .map(|f| [f[slot], f[0]]),
        budget / 2,
        dir,
    )?;
    check(error.take())?;
    // (vertex, the value's bits), by vertex.
    let mut cursor = Cursor::new(values)?;
    let picked = sort_external(
        ok_values(wanted, &mut error).map(|[index, v]| {
            let value = cursor.at(index);
            let mut record = [0u32; 4];
            record[0] = v;
            for (k, x) in value.iter().enumerate() {
                record[1 + k] = x.to_bits();
            }
            record
        }),
        budget / 2,
        dir,
    )?;
    check(error.take())?;
    check(cursor.error.take())?;
    let mut out = RecordFile::<[f32; N]>::create(dir)?;
    let mut next = 0u64;
    for record in picked {
        let record = record?;
        let v = record[0] as u64;
        while next < v {
            out.push(&[0.0; N])?;
            next += 1;
        }
        let mut value = [0.0f32; N];
        for (k, x) in value.iter_mut().enumerate() {
            *x = f32::from_bits(record[1 + k]);
        }
        out.push(&value)?;
        next += 1;
    }
    while next < vertices {
        out.push(&[0.0; N])?;
        next += 1;
    }
    out.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attributes_come_out_in_vertex_order_from_first_corners() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = CornerStager::new(dir.path()).unwrap();
        for i in 0..5 {
            s.texcoord([i as f32, 0.5]).unwrap();
            s.normal([0.0, 0.0, i as f32]).unwrap();
        }
        // Vertex 3 twice with (4, 1). Vertex 1 unused, vertex 0 without a normal.
        s.corner(3, 4, 1).unwrap();
        s.corner(0, 2, NONE).unwrap();
        s.corner(3, 4, 1).unwrap();
        s.corner(2, 2, 3).unwrap();
        // A budget of 0: the sorts spill a run a record.
        let (uvs, normals) = s.finish(5, true, true, 0).unwrap();
        let uvs = uvs.unwrap().read_all().unwrap();
        let normals = normals.unwrap().read_all().unwrap();
        assert_eq!(
            uvs,
            [[2.0, 0.5], [0.0, 0.0], [2.0, 0.5], [4.0, 0.5], [0.0, 0.0]]
        );
        assert_eq!(
            normals,
            [
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 3.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 0.0]
            ]
        );
    }

    /// A vertex whose corners name other values keeps them as wedges in memory: refused here.
    #[test]
    fn corners_that_disagree_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let stager = || {
            let mut s = CornerStager::new(dir.path()).unwrap();
            for i in 0..3 {
                s.texcoord([i as f32, 0.5]).unwrap();
                s.normal([0.0, 0.0, i as f32]).unwrap();
            }
            s.corner(1, 0, 0).unwrap();
            s.corner(0, 1, 1).unwrap();
            s.corner(1, 2, 0).unwrap(); // another texture coordinate, the same normal
            s
        };
        let refused = stager().finish(2, true, true, 0).err().unwrap();
        assert_eq!(refused.kind(), io::ErrorKind::Unsupported);
        // Where only the normals are kept, the corners agree.
        let (uvs, normals) = stager().finish(2, false, true, 0).unwrap();
        assert!(uvs.is_none());
        assert_eq!(
            normals.unwrap().read_all().unwrap(),
            [[0.0, 0.0, 1.0], [0.0; 3]]
        );
    }
}
