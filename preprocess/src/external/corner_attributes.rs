//! An OBJ's texture coordinates and normals, staged out of core. OBJ indexes them apart from
//! positions (`f v/vt/vn`); a vertex takes those of the first face corner that uses it
//! (`import/obj.rs`). In memory that is a `u32` a vertex per attribute and every `vt` and `vn`
//! value; here the values go to record files as they are read, each vertex's first corner
//! (found with a bit a vertex) to another, and the attributes are joined into vertex order
//! at the end by two external sorts each: the first corners by attribute index (the values
//! picked in one pass over their file), the picked values back by vertex.

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
    texcoords: RecordWriter<[f32; 2]>,
    normals: RecordWriter<[f32; 3]>,
}

impl CornerStager {
    pub fn new(dir: &Path) -> io::Result<CornerStager> {
        Ok(CornerStager {
            dir: dir.to_path_buf(),
            seen: Vec::new(),
            firsts: RecordFile::create(dir)?,
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
            texcoords,
            normals: normal_values,
        } = self;
        drop(seen);
        let firsts = firsts.finish()?;
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
        // Vertex 3 first with (4, 1), then with (0, 0): the first counts. Vertex 1 unused,
        // vertex 0 without a normal.
        s.corner(3, 4, 1).unwrap();
        s.corner(0, 2, NONE).unwrap();
        s.corner(3, 0, 0).unwrap();
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
}
