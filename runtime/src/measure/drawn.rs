//! The surface a frame of ours drew, as a plain triangle soup: the patches of the selected
//! simplices, positions dequantised from the global grid exactly as stored
//! (`format::dequantize_position`, f64), relative to the repository origin.

use tessera_core::repository::format::dequantize_position;
use tessera_core::repository::reader::{Repository, RepositoryError};

use super::geometric_error::Surface;

/// Triangles with their own positions (f64, relative to a frame origin).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DrawnSurface {
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl DrawnSurface {
    /// The borrowed view the measurement takes.
    pub fn surface(&self) -> Surface<'_> {
        Surface {
            positions: &self.positions,
            triangles: &self.triangles,
        }
    }
}

/// The patches of `selection` (simplex indices, e.g. `Renderer::read_selection`), each patch's
/// vertices dequantised once, relative to `Header::origin`; the strips' non-degenerate
/// triangles (`PatchView::triangles`), as the GPU rasterises them.
///
/// Errors: a simplex index out of range or a patch that fails validation.
/// Cost: linear in the selected patches' vertices and strip indices.
pub fn drawn_cut(repo: &Repository, selection: &[u32]) -> Result<DrawnSurface, RepositoryError> {
    let h = repo.header();
    let mut surface = DrawnSurface::default();
    for &simplex in selection {
        let patch = repo.patch(simplex as usize)?;
        let patch = patch.view();
        let base = surface.positions.len() as u32;
        surface.positions.extend((0..patch.vertex_count()).map(|i| {
            let p = dequantize_position(patch.position(i), h.bbox_min, h.position_step);
            [0, 1, 2].map(|k| p[k] - h.origin[k])
        }));
        surface
            .triangles
            .extend(patch.triangles().map(|t| t.map(|v| base + v)));
    }
    Ok(surface)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::repository::format::{Header, TetRecord, NO_INDEX};
    use tessera_core::repository::patch::{encode_patch, PatchData};
    use tessera_core::repository::{write_repository, RepositoryContents};

    /// Two root leaves: a quad (strip 0 1 2 3: two triangles) and a single triangle.
    fn repository() -> Repository {
        let patches = [
            (
                vec![[0, 0, 0], [4, 0, 0], [0, 4, 0], [4, 4, 0]],
                vec![0, 1, 2, 3],
            ),
            (vec![[0, 0, 8], [8, 0, 8], [0, 8, 8]], vec![0, 1, 2]),
        ];
        let (mut blob, mut ids) = (Vec::new(), Vec::new());
        let mut tets = Vec::new();
        for (i, (positions, strip)) in patches.into_iter().enumerate() {
            let n = positions.len() as u32;
            let patch = PatchData {
                global_ids: (0..n).map(|v| 10 * i as u32 + v).collect(),
                positions,
                normals: None,
                colors: None,
                uvs: None,
                triangle_count: strip.len() as u32 - 2,
                strip,
            };
            let placement = encode_patch(&patch, 0, &mut blob, &mut ids);
            tets.push(TetRecord {
                center: [0.0; 3],
                radius: 1.0,
                cone_axis: [0.0, 0.0, 1.0],
                cone_cos: -1.0,
                diamond: NO_INDEX,
                parent_diamond: NO_INDEX,
                first_child: NO_INDEX,
                level: 0,
                patch_offset: placement.patch_offset,
                patch_bytes: placement.patch_bytes,
                vertex_count: n,
                strip_index_count: patch.strip.len() as u32,
                triangle_count: patch.triangle_count,
                id_offset: placement.id_offset,
                id_bytes: placement.id_bytes,
                patch_checksum: 0,
            });
        }
        let header = Header {
            root_tet_count: 2,
            input_vertex_count: 20,
            input_triangle_count: 3,
            origin: [1.0, 2.0, 3.0],
            bbox_min: [1.0, 2.0, 3.0],
            bbox_max: [9.0, 10.0, 11.0],
            position_step: [0.5; 3],
            lattice_origin: [0.0; 3],
            lattice_unit: 1.0,
            lattice_bits: 4,
            ..Header::new(3, 0)
        };
        let contents = RepositoryContents {
            header,
            diamonds: Vec::new(),
            tets,
            patch_blob: blob,
            id_blob: ids,
            codec: tessera_core::repository::PatchCodec::Raw,
            attribute_errors: None,
        };
        let mut bytes = Vec::new();
        write_repository(&mut bytes, &contents).unwrap();
        Repository::from_bytes(bytes).unwrap()
    }

    #[test]
    fn drawn_cuts_are_dequantised_relative_to_the_origin() {
        let repo = repository();
        let both = drawn_cut(&repo, &[0, 1]).unwrap();
        // bbox_min + q·step − origin = q·0.5 here.
        assert_eq!(both.positions[3], [2.0, 2.0, 0.0]);
        assert_eq!(both.positions[5], [4.0, 0.0, 4.0]);
        // The strip's two triangles (the second with its winding restored), then the third,
        // its indices past the first patch's vertices.
        assert_eq!(both.triangles, vec![[0, 1, 2], [2, 1, 3], [4, 5, 6]]);
        let second = drawn_cut(&repo, &[1]).unwrap();
        assert_eq!(second.triangles, vec![[0, 1, 2]]);
        assert_eq!(second.surface().positions.len(), 3);
        assert!(drawn_cut(&repo, &[2]).is_err(), "no simplex 2");
    }
}
