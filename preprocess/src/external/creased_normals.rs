//! A staged mesh's computed normals split at creases (`--crease-angle` below 180), out of
//! core: the same wedges, ids and f32 normals as `normals::compute_missing_normals_creased` of
//! the loaded mesh, so a build gives the same bytes either way.
//!
//! In memory, corners are joined across every manifold edge (two triangles) whose faces meet
//! at no more than the angle, and each group of a vertex's corners is a wedge. Whether two
//! corners of a vertex `v` join depends on `v`'s fan alone (the edge `v u` is in exactly the
//! fan's triangles holding `u`), and a group is labelled by its smallest corner, so a vertex
//! at a time gives the same groups:
//!
//! 1. Every corner as (vertex, triangle, corner, wedge, the other two vertices, the face's
//!    unit normal, the corner's contribution), from one join of the triangles with their
//!    positions (`joins::TriangleCorners`), sorted by (vertex, triangle) on disk.
//! 2. A vertex's fan at a time: its groups (a union-find of its corners), each group's normal
//!    (its contributions summed in triangle order), and the new wedges, the distinct (old
//!    wedge, group) in that order, numbered across the mesh as they come.
//! 3. Where some vertex splits: the triangles' corners, sorted back by corner, to the new
//!    wedges; positions, colours and texture coordinates picked at the old wedges (which
//!    ascend with the new ones). Otherwise the normals are the smooth ones
//!    (`vertex_normals.rs`), as in memory.
//!
//! Memory: the sorts' budget, and one vertex's fan.

use std::io;
use std::path::Path;

use super::cursor::Cursor;
use super::fallible::{check, ok_values};
use super::joins::TriangleCorners;
use super::position_file::{PositionBlocks, PositionCursor, PositionFile};
use super::sort::sort_external;
use super::staged::{RecordFile, StagedMesh};
use crate::normals::{accumulate, corner_contributions, finish, unit_normal};

/// A corner for the fans' sort: `[vertex, triangle, corner (0..3), old wedge, the other two
/// vertices, whether the face has a normal, its unit normal (f64 bits, high word first), the
/// corner's contribution (f32 bits)]`.
type FanCorner = [u32; 16];

/// Gives `staged` (which has no normals) angle-weighted normals split at creases sharper than
/// `crease_degrees` (below 180), with about `budget` bytes of memory, temporary files in
/// `dir`: new wedges where a vertex's corners split, their triangles and attributes rewritten.
pub fn stage_creased_normals(
    staged: &mut StagedMesh,
    crease_degrees: f64,
    budget: usize,
    dir: &Path,
) -> io::Result<()> {
    assert!(staged.attributes.normals.is_none(), "normals to compute");
    let cos_crease = crease_degrees.to_radians().cos();
    let starts = staged.vertex_starts()?;
    // 1. The corners, on disk, then sorted by (vertex, triangle).
    let mut corners = RecordFile::<FanCorner>::create(dir)?;
    let mut error = None;
    let join = TriangleCorners {
        staged,
        budget: budget / 2,
    };
    join.for_each(
        &|t, p| {
            let v = t.map(|w| starts.canonical(w));
            (t, v, unit_normal(p), corner_contributions(p))
        },
        &mut |index, (wedges, v, face, contributions)| {
            for k in 0..3 {
                let mut r = [0u32; 16];
                r[..6].copy_from_slice(&[
                    v[k],
                    index,
                    k as u32,
                    wedges[k],
                    v[(k + 1) % 3],
                    v[(k + 2) % 3],
                ]);
                if let Some(n) = face {
                    r[6] = 1;
                    for (i, x) in n.iter().enumerate() {
                        let bits = x.to_bits();
                        r[7 + 2 * i] = (bits >> 32) as u32;
                        r[8 + 2 * i] = bits as u32;
                    }
                }
                r[13..].copy_from_slice(&contributions[k].map(f32::to_bits));
                if let Err(e) = corners.push(&r) {
                    error.get_or_insert(e);
                }
            }
        },
    )?;
    check(error.take())?;
    let corners = corners.finish()?;
    let sorted = sort_external(ok_values(corners.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;
    drop(corners);

    // 2. Fans: new wedges (old wedge, normal) and each corner's new wedge, on disk.
    let mut wedges = Wedges::create(dir)?;
    let mut fan: Vec<FanCorner> = Vec::new();
    for record in sorted {
        let record = record?;
        if fan.first().is_some_and(|f| f[0] != record[0]) {
            wedges.fan(&fan, cos_crease)?;
            fan.clear();
        }
        fan.push(record);
    }
    if !fan.is_empty() {
        wedges.fan(&fan, cos_crease)?;
    }
    drop(fan);
    let Wedges {
        old_of_new,
        normals,
        new_of_corner,
        count,
        splits,
    } = wedges;
    let normals = normals.finish()?;
    if !splits {
        // No crease: the smooth normals (the in-memory build's too), those of the fans where
        // every wedge has a corner.
        let normals = match count == staged.positions.len() {
            true => normals,
            false => super::vertex_normals::stage_vertex_normals(staged, budget, dir)?,
        };
        staged.attributes.normals = Some(normals);
        return Ok(());
    }
    // 3. The triangles' corners by their new wedges, the attributes at the old ones.
    let new_of_corner = new_of_corner.finish()?;
    let by_corner = sort_external(ok_values(new_of_corner.read()?, &mut error), budget, dir)?;
    check(error.take())?;
    drop(new_of_corner);
    let mut triangles = RecordFile::<[u32; 3]>::create(dir)?;
    let mut t = [0u32; 3];
    for record in by_corner {
        let [_, k, new] = record?;
        t[k as usize] = new;
        if k == 2 {
            triangles.push(&t)?;
        }
    }
    let triangles = triangles.finish()?;
    if triangles.len() != staged.triangles.len() {
        return Err(io::Error::other("a triangle's corners went missing"));
    }
    let old_of_new = old_of_new.finish()?;
    let mut positions = PositionFile::create(dir)?;
    let mut cursor = PositionCursor::new(&staged.positions)?;
    for w in old_of_new.read()? {
        positions.push(&cursor.at(w?))?;
    }
    cursor.finish(&mut PositionBlocks::default())?;
    let a = &staged.attributes;
    let colors = a
        .colors
        .as_ref()
        .map(|f| pick(f, &old_of_new, dir))
        .transpose()?;
    let uvs = a
        .uvs
        .as_ref()
        .map(|f| pick(f, &old_of_new, dir))
        .transpose()?;
    staged.positions = positions.finish()?;
    staged.triangles = triangles;
    staged.attributes.colors = colors;
    staged.attributes.uvs = uvs;
    staged.attributes.normals = Some(normals);
    Ok(())
}

/// The records of `from` at `indices` (ascending, with repeats).
fn pick<T: bytemuck::Pod>(
    from: &RecordFile<T>,
    indices: &RecordFile<u32>,
    dir: &Path,
) -> io::Result<RecordFile<T>> {
    let mut out = RecordFile::<T>::create(dir)?;
    let mut cursor = Cursor::new(from)?;
    for i in indices.read()? {
        out.push(&cursor.at(i?))?;
    }
    check(cursor.error.take())?;
    out.finish()
}

/// The new wedges as the fans give them.
struct Wedges {
    /// Each new wedge's old wedge (ascending).
    old_of_new: super::staged::RecordWriter<u32>,
    /// Each new wedge's normal.
    normals: super::staged::RecordWriter<[f32; 3]>,
    /// (triangle, corner, new wedge) of every corner.
    new_of_corner: super::staged::RecordWriter<[u32; 3]>,
    /// New wedges so far.
    count: u64,
    /// Whether some vertex has two groups.
    splits: bool,
}

impl Wedges {
    fn create(dir: &Path) -> io::Result<Wedges> {
        Ok(Wedges {
            old_of_new: RecordFile::create(dir)?,
            normals: RecordFile::create(dir)?,
            new_of_corner: RecordFile::create(dir)?,
            count: 0,
            splits: false,
        })
    }

    /// One vertex's corners (sorted by triangle): its groups, their normals, its new wedges.
    fn fan(&mut self, fan: &[FanCorner], cos_crease: f64) -> io::Result<()> {
        // The fan's corners that share each neighbour: an edge with exactly two triangles,
        // smooth (or with a degenerate face), joins its two corners here.
        let mut by_neighbour: Vec<(u32, u32)> = (fan.iter().enumerate())
            .flat_map(|(i, c)| [(c[4], i as u32), (c[5], i as u32)])
            .collect();
        by_neighbour.sort_unstable();
        let mut parent: Vec<u32> = (0..fan.len() as u32).collect();
        fn root(parent: &mut [u32], mut c: u32) -> u32 {
            while parent[c as usize] != c {
                parent[c as usize] = parent[parent[c as usize] as usize];
                c = parent[c as usize];
            }
            c
        }
        let face = |c: &FanCorner| {
            (c[6] == 1).then(|| {
                [0, 1, 2].map(|i| f64::from_bits((c[7 + 2 * i] as u64) << 32 | c[8 + 2 * i] as u64))
            })
        };
        for run in by_neighbour.chunk_by(|a, b| a.0 == b.0) {
            let [(_, x), (_, y)] = run else {
                continue; // a border or a non-manifold edge
            };
            let smooth = match (face(&fan[*x as usize]), face(&fan[*y as usize])) {
                (Some(n1), Some(n2)) => n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2] >= cos_crease,
                _ => true,
            };
            if smooth {
                // The smaller corner (fan order is triangle order) is the root.
                let (x, y) = (root(&mut parent, *x), root(&mut parent, *y));
                parent[x.max(y) as usize] = x.min(y);
            }
        }
        let group: Vec<u32> = (0..fan.len() as u32)
            .map(|c| root(&mut parent, c))
            .collect();
        self.splits |= group.iter().any(|&g| g != group[0]);
        // Each group's normal: its contributions in triangle order.
        let mut sums = vec![[0.0f32; 3]; fan.len()];
        for (c, &g) in fan.iter().zip(&group) {
            accumulate(
                &mut sums[g as usize],
                [c[13], c[14], c[15]].map(f32::from_bits),
            );
        }
        // New wedges: distinct (old wedge, group's smallest corner), in that order.
        let corner_id = |i: u32| {
            let c = &fan[i as usize];
            3 * c[1] as u64 + c[2] as u64
        };
        let mut order: Vec<(u32, u64, u32)> = (0..fan.len() as u32)
            .map(|i| (fan[i as usize][3], corner_id(group[i as usize]), i))
            .collect();
        order.sort_unstable();
        let mut last = None;
        for (wedge, g, i) in order {
            if last != Some((wedge, g)) {
                last = Some((wedge, g));
                self.old_of_new.push(&wedge)?;
                self.normals
                    .push(&finish(sums[group[i as usize] as usize]))?;
                self.count += 1;
            }
            let c = &fan[i as usize];
            self.new_of_corner
                .push(&[c[1], c[2], self.count as u32 - 1])?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{weld, ImportReport, RawMesh};
    use crate::mesh::InputMesh;
    use crate::normals::compute_missing_normals_creased;

    /// A cube of `n` x `n` quads a face, each face's vertices its own (welded: a seam on
    /// every edge where `uvs`, else one wedge a vertex).
    fn cube(n: usize, uvs: bool) -> InputMesh {
        let faces: [[[f64; 3]; 3]; 6] = [
            [[1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
            [[0., 0., 0.], [0., 0., 1.], [0., 1., 0.]],
            [[0., 1., 0.], [0., 0., 1.], [1., 0., 0.]],
            [[0., 0., 0.], [1., 0., 0.], [0., 0., 1.]],
            [[0., 0., 1.], [1., 0., 0.], [0., 1., 0.]],
            [[0., 0., 0.], [0., 1., 0.], [1., 0., 0.]],
        ];
        let mut raw = RawMesh {
            uvs: uvs.then(Vec::new),
            ..Default::default()
        };
        for (f, [origin, u, v]) in faces.iter().enumerate() {
            let base = raw.positions.len() as u32;
            for i in 0..=n {
                for j in 0..=n {
                    let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                    raw.positions
                        .push([0, 1, 2].map(|k| origin[k] + a * u[k] + b * v[k]));
                    if let Some(uvs) = &mut raw.uvs {
                        uvs.push([(f as f64 + a) as f32 / 6.0, b as f32]);
                    }
                }
            }
            let at = |i: usize, j: usize| base + (i * (n + 1) + j) as u32;
            for i in 0..n {
                for j in 0..n {
                    raw.triangles
                        .push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                    raw.triangles
                        .push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
        weld(raw).mesh
    }

    /// Stages `mesh`, computes its creased normals out of core and checks them (and the
    /// wedges) against the in-memory ones, bit for bit.
    fn check(mesh: &InputMesh, crease_degrees: f64) {
        let mut want = mesh.clone();
        assert!(compute_missing_normals_creased(&mut want, crease_degrees));
        for budget in [0, 1 << 30] {
            let dir = tempfile::tempdir().unwrap();
            let report = ImportReport {
                raw_vertices: mesh.positions.len(),
                raw_triangles: mesh.triangles.len(),
                mesh: mesh.clone(),
                welded_vertices: 0,
                degenerate_triangles: 0,
                duplicate_triangles: 0,
                unreferenced_vertices: 0,
                textures: None,
                missing_textures: Vec::new(),
            };
            let mut staged = StagedMesh::from_report(report, dir.path()).unwrap();
            stage_creased_normals(&mut staged, crease_degrees, budget, dir.path()).unwrap();
            let got = staged.load().unwrap();
            assert_eq!(got, want, "budget {budget}, crease {crease_degrees}");
            let bits = |m: &InputMesh| {
                let normals = m.normals.as_ref().unwrap().iter();
                normals.map(|n| n.map(f32::to_bits)).collect::<Vec<_>>()
            };
            assert_eq!(bits(&got), bits(&want));
        }
    }

    #[test]
    fn creased_normals_are_the_in_memory_wedges_and_normals() {
        for uvs in [false, true] {
            let mesh = cube(5, uvs);
            // 60: every cube edge a crease (a corner's three faces apart); 120: none.
            check(&mesh, 60.0);
            check(&mesh, 120.0);
        }
        let mut sphere = crate::procedural::demo_mesh(5);
        sphere.normals = None;
        check(&sphere, 30.0);
    }
}
