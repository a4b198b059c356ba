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

    /// Rows by global id for many lookups (`RowIndex`), where `row`'s binary search per
    /// lookup made the patches' bounds and records a tenth of the simplification's time.
    pub fn row_index(&self) -> RowIndex {
        RowIndex::new(&self.ids)
    }

    /// The rows of each triangle's corners. Panics, like `row`, when a corner is not carried.
    pub fn rows_of(&self, triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
        let index = self.row_index();
        triangles
            .iter()
            .map(|t| t.map(|g| index.expect(g)))
            .collect()
    }

    /// The rows of the vertices used by `triangles`.
    pub fn subset(&self, triangles: &[[u32; 3]]) -> VertexTable {
        let mut ids: Vec<u32> = triangles.iter().flatten().copied().collect();
        ids.sort_unstable();
        ids.dedup();
        // Both lists are sorted: one walk finds every row.
        let mut from = 0;
        let rows: Vec<(u32, usize, usize)> = ids
            .iter()
            .map(|&g| {
                while self.ids.get(from).is_some_and(|&h| h < g) {
                    from += 1;
                }
                if self.ids.get(from) != Some(&g) {
                    panic!("vertex {g} is not carried by this patch");
                }
                (g, 0, from)
            })
            .collect();
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

/// The rows of a table's vertices by global id: open addressing with linear probing over
/// twice as many slots as ids, so a lookup is about one probe in a table that stays in cache
/// (a patch carries a few thousand vertices).
pub struct RowIndex {
    /// (id, row + 1); row + 1 = 0 marks an empty slot.
    slots: Vec<(u32, u32)>,
    shift: u32,
}

impl RowIndex {
    /// The index of `ids` (unique; the row of `ids[i]` is `i`).
    pub fn new(ids: &[u32]) -> RowIndex {
        let bits = (2 * ids.len()).max(16).next_power_of_two().trailing_zeros();
        let mut index = RowIndex {
            slots: vec![(0, 0); 1 << bits],
            shift: 32 - bits,
        };
        let mask = index.slots.len() - 1;
        for (row, &g) in ids.iter().enumerate() {
            let mut at = index.slot_of(g);
            while index.slots[at].1 != 0 {
                at = (at + 1) & mask;
            }
            index.slots[at] = (g, row as u32 + 1);
        }
        index
    }

    #[inline]
    fn slot_of(&self, g: u32) -> usize {
        // Fibonacci hashing: the top bits of the product.
        (g.wrapping_mul(0x9E37_79B9) >> self.shift) as usize
    }

    /// The row of `g`, `None` when the table does not carry it.
    #[inline]
    pub fn get(&self, g: u32) -> Option<u32> {
        let mask = self.slots.len() - 1;
        let mut at = self.slot_of(g);
        loop {
            let (id, row) = self.slots[at];
            if row == 0 {
                return None;
            }
            if id == g {
                return Some(row - 1);
            }
            at = (at + 1) & mask;
        }
    }

    /// The row of `g`; panics when the table does not carry it (a patch always carries the
    /// vertices of its triangles).
    #[inline]
    pub fn expect(&self, g: u32) -> u32 {
        self.get(g)
            .unwrap_or_else(|| panic!("vertex {g} is not carried by this patch"))
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
    fn the_row_index_finds_every_row_and_nothing_else() {
        for n in [0usize, 1, 7, 16, 1000, 5000] {
            // Clustered and spread ids, as patches have them.
            let ids: Vec<u32> = (0..n as u32)
                .map(|i| i * 3 + (i / 64) * 100_000 + 7)
                .collect();
            let index = RowIndex::new(&ids);
            for (row, &g) in ids.iter().enumerate() {
                assert_eq!(index.get(g), Some(row as u32));
            }
            for g in [0, 1, 8, 9, u32::MAX, u32::MAX - 1] {
                assert_eq!(index.get(g), None, "{g} among {n}");
            }
        }
    }

    #[test]
    fn rows_of_triangles_are_the_rows_row_gives() {
        let (mesh, simplifier) = mesh();
        let table = VertexTable::from_mesh(&mesh, &simplifier, vec![0, 2, 3, 5]);
        let triangles = [[5, 0, 2], [3, 3, 0]];
        let expected: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|g| table.row(g) as u32))
            .collect();
        assert_eq!(table.rows_of(&triangles), expected);
    }

    #[test]
    #[should_panic(expected = "vertex 4 is not carried")]
    fn a_missing_corner_is_a_bug_in_rows_of_too() {
        let (mesh, simplifier) = mesh();
        VertexTable::from_mesh(&mesh, &simplifier, vec![0, 1, 2]).rows_of(&[[0, 4, 1]]);
    }

    #[test]
    #[should_panic(expected = "vertex 4 is not carried")]
    fn a_missing_vertex_is_a_bug_in_subset_too() {
        let (mesh, simplifier) = mesh();
        VertexTable::from_mesh(&mesh, &simplifier, vec![0, 1, 2, 5]).subset(&[[0, 4, 1]]);
    }

    #[test]
    #[should_panic(expected = "vertex 4 is not carried")]
    fn a_missing_vertex_is_a_bug_not_a_silent_zero() {
        let (mesh, simplifier) = mesh();
        VertexTable::from_mesh(&mesh, &simplifier, vec![0, 1]).row(4);
    }
}
