//! The vertices a patch carries: global ids (sorted) with their input position, the f32
//! position the simplifier sees and the input's attributes.
//!
//! Patches carry their own vertices so that simplifying a diamond and encoding a patch read
//! nothing but the patches involved: no global vertex array, which an out-of-core build cannot
//! hold (issue 12). A vertex shared by several patches is carried by each, with the same data.

use crate::mesh::InputMesh;

/// Vertex data by global id, rows sorted by id, ids unique.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexTable {
    pub ids: Vec<u32>,
    /// Model-space input positions.
    pub positions: Vec<[f64; 3]>,
    /// What meshopt sees: the position relative to the model origin in model sizes, in f32,
    /// distinct vertices moved apart where they coincide in f32 (`simplify::separate_coincident`).
    pub simplifier: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub colors: Option<Vec<[u8; 4]>>,
    pub uvs: Option<Vec<[f32; 2]>>,
}

impl VertexTable {
    /// The rows of `ids` (sorted, unique) from the whole mesh; `simplifier` is indexed like
    /// the mesh's positions.
    pub fn from_mesh(mesh: &InputMesh, simplifier: &[[f32; 3]], ids: Vec<u32>) -> VertexTable {
        debug_assert!(ids.windows(2).all(|w| w[0] < w[1]));
        let rows = |ids: &[u32]| ids.iter().map(|&g| g as usize).collect::<Vec<_>>();
        let at = rows(&ids);
        VertexTable {
            positions: at.iter().map(|&g| mesh.positions[g]).collect(),
            simplifier: at.iter().map(|&g| simplifier[g]).collect(),
            normals: mesh
                .normals
                .as_ref()
                .map(|n| at.iter().map(|&g| n[g]).collect()),
            colors: mesh
                .colors
                .as_ref()
                .map(|c| at.iter().map(|&g| c[g]).collect()),
            uvs: mesh
                .uvs
                .as_ref()
                .map(|u| at.iter().map(|&g| u[g]).collect()),
            ids,
        }
    }

    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The row of vertex `g`. Panics when the table does not carry it (a patch always carries
    /// the vertices of its triangles).
    #[inline]
    pub fn row(&self, g: u32) -> usize {
        self.ids
            .binary_search(&g)
            .unwrap_or_else(|_| panic!("vertex {g} is not carried by this patch"))
    }

    /// The rows of these tables together (a vertex carried by several keeps one row).
    pub fn merge(tables: &[&VertexTable]) -> VertexTable {
        let mut rows: Vec<(u32, usize, usize)> = tables
            .iter()
            .enumerate()
            .flat_map(|(t, table)| table.ids.iter().enumerate().map(move |(r, &g)| (g, t, r)))
            .collect();
        rows.sort_unstable_by_key(|&(g, ..)| g);
        rows.dedup_by_key(|&mut (g, ..)| g);
        Self::gather(tables, &rows)
    }

    /// The rows of the vertices used by `triangles`.
    pub fn subset(&self, triangles: &[[u32; 3]]) -> VertexTable {
        let mut ids: Vec<u32> = triangles.iter().flatten().copied().collect();
        ids.sort_unstable();
        ids.dedup();
        let rows: Vec<(u32, usize, usize)> = ids.iter().map(|&g| (g, 0, self.row(g))).collect();
        Self::gather(&[self], &rows)
    }

    /// A table of the given (id, table, row) rows, in that order.
    fn gather(tables: &[&VertexTable], rows: &[(u32, usize, usize)]) -> VertexTable {
        let first = tables.first();
        let n = rows.len();
        let mut out = VertexTable {
            ids: Vec::with_capacity(rows.len()),
            positions: Vec::with_capacity(rows.len()),
            simplifier: Vec::with_capacity(rows.len()),
            normals: first
                .is_some_and(|t| t.normals.is_some())
                .then(|| Vec::with_capacity(n)),
            colors: first
                .is_some_and(|t| t.colors.is_some())
                .then(|| Vec::with_capacity(n)),
            uvs: first
                .is_some_and(|t| t.uvs.is_some())
                .then(|| Vec::with_capacity(n)),
        };
        for &(g, t, r) in rows {
            let table = tables[t];
            out.ids.push(g);
            out.positions.push(table.positions[r]);
            out.simplifier.push(table.simplifier[r]);
            if let Some(n) = &mut out.normals {
                n.push(table.normals.as_ref().expect("tables differ in attributes")[r]);
            }
            if let Some(c) = &mut out.colors {
                c.push(table.colors.as_ref().expect("tables differ in attributes")[r]);
            }
            if let Some(u) = &mut out.uvs {
                u.push(table.uvs.as_ref().expect("tables differ in attributes")[r]);
            }
        }
        out
    }

    /// Bytes held (a statistic for memory budgets).
    pub fn heap_bytes(&self) -> usize {
        let n = self.ids.len();
        n * (4 + 24 + 12)
            + self.normals.as_ref().map_or(0, |_| n * 12)
            + self.colors.as_ref().map_or(0, |_| n * 4)
            + self.uvs.as_ref().map_or(0, |_| n * 8)
    }
}

/// A live patch: its triangles by global vertex id and the vertices they use.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LivePatch {
    pub triangles: Vec<[u32; 3]>,
    pub vertices: VertexTable,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh() -> (InputMesh, Vec<[f32; 3]>) {
        let mesh = InputMesh {
            positions: (0..6).map(|i| [i as f64, 0.0, 1.0]).collect(),
            triangles: vec![[0, 1, 2], [2, 1, 3], [3, 4, 5]],
            normals: Some((0..6).map(|i| [0.0, i as f32, 1.0]).collect()),
            colors: None,
            uvs: Some((0..6).map(|i| [i as f32, 0.5]).collect()),
        };
        let simplifier = (0..6).map(|i| [i as f32 * 0.1, 0.0, 0.0]).collect();
        (mesh, simplifier)
    }

    #[test]
    fn merge_and_subset_keep_each_vertex_s_data() {
        let (mesh, simplifier) = mesh();
        let a = VertexTable::from_mesh(&mesh, &simplifier, vec![0, 1, 2, 3]);
        let b = VertexTable::from_mesh(&mesh, &simplifier, vec![2, 3, 4, 5]);
        let all = VertexTable::merge(&[&b, &a]);
        assert_eq!(
            all,
            VertexTable::from_mesh(&mesh, &simplifier, (0..6).collect())
        );
        let sub = all.subset(&[[3, 5, 1]]);
        assert_eq!(
            sub,
            VertexTable::from_mesh(&mesh, &simplifier, vec![1, 3, 5])
        );
        assert_eq!(sub.row(5), 2);
        assert_eq!(sub.positions[sub.row(3)], [3.0, 0.0, 1.0]);
    }

    #[test]
    #[should_panic(expected = "vertex 4 is not carried")]
    fn a_missing_vertex_is_a_bug_not_a_silent_zero() {
        let (mesh, simplifier) = mesh();
        VertexTable::from_mesh(&mesh, &simplifier, vec![0, 1]).row(4);
    }
}
