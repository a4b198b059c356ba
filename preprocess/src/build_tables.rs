//! The build's last steps, once every patch is final: the table order (breadth-first from
//! the roots), the saturation of errors and spheres over the diamond DAG, the diamond and tet
//! tables, the header and the summary (`build.rs` is the driver).

use rustc_hash::FxHashMap as HashMap;
use std::time::Instant;

use tessera_core::bounds::round_up_f32;
use tessera_core::leb::{DiamondId, Simplex};
use tessera_core::repository::format::{DiamondRecord, Header, TetRecord, NO_INDEX};
use tessera_core::repository::RepositoryDirectory;

use crate::build_config::{BuildConfig, BuildSummary};
use crate::checkpoint::InputFacts;
use crate::finished_patches::FinishedPatches;
use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::saturate::{nest_simplex_spheres, saturate, OwnErrors, RADIUS_MARGIN};
use crate::simplify::Simplified;

/// A built repository before it is written: its directory, its tet table's rows in the
/// finished patches' records, in order, and their encoded patches.
pub(crate) struct Built {
    pub directory: RepositoryDirectory,
    pub order: Vec<u32>,
    pub finished: FinishedPatches,
    pub summary: BuildSummary,
}

/// What the simplification leaves for the tables.
pub(crate) struct Parts {
    pub hierarchy: Hierarchy,
    pub simplified: Simplified,
    pub finished: FinishedPatches,
    pub facts: InputFacts,
    pub frame: LatticeFrame,
    pub step: [f64; 3],
    pub model_size: f64,
    /// (stage, seconds) so far.
    pub stages: Vec<(&'static str, f64)>,
}

pub(crate) fn assemble(
    parts: Parts,
    config: &BuildConfig,
    on_stage: &(dyn Fn(&str) + Sync),
) -> std::io::Result<Built> {
    let Parts {
        hierarchy,
        simplified,
        finished,
        facts,
        frame,
        step,
        model_size,
        mut stages,
    } = parts;
    let mut stage = |name: &'static str, t: Instant| stages.push((name, t.elapsed().as_secs_f64()));
    let (bbox_min, bbox_max) = facts.bbox;
    let origin = bbox_min;
    let (input_vertices, input_triangles, attributes) =
        (facts.vertices, facts.triangles, facts.attributes);
    // 3. Table order: breadth-first from the roots, so roots come first and siblings are
    //    adjacent; saturation of errors and spheres over the diamond DAG.
    on_stage("saturate");
    let t = Instant::now();
    // Diamond table in (level, id) order.
    let mut diamond_order: Vec<usize> = (0..hierarchy.diamonds.len()).collect();
    diamond_order.sort_by_key(|&i| (hierarchy.diamonds[i].level, hierarchy.diamonds[i].id));
    let table_index: HashMap<DiamondId, u32> = diamond_order
        .iter()
        .enumerate()
        .map(|(row, &i)| (hierarchy.diamonds[i].id, row as u32))
        .collect();
    let simplices = breadth_first(&hierarchy, &table_index, &finished);
    let patch_sphere = |key| finished.get(key).map(|p| p.sphere);
    let error_floor = step.iter().copied().fold(model_size * 1e-9, f64::max);
    // Patches are stored on the position lattice: each vertex within half a step per axis of
    // its input position, while the simplifier measured its error on the input's positions.
    // A drawn patch is within own(D) + this of the input, so every own error counts it.
    let quantisation_error = 0.5 * crate::frame::diagonal([0.0; 3], step);
    let saturated = saturate(
        &hierarchy,
        origin,
        OwnErrors {
            errors: &simplified.own_error,
            are_bounds: config.simplify.bounded_errors,
        },
        quantisation_error,
        &patch_sphere,
        error_floor,
        model_size,
    )?;
    let diamonds: Vec<DiamondRecord> = diamond_order
        .iter()
        .map(|&i| {
            let d = hierarchy.diamond(i);
            let (center, radius) = saturated.sphere[i].to_f32();
            let mut parents = [NO_INDEX; 4];
            for (slot, p) in parents.iter_mut().zip(&d.parents) {
                *slot = table_index[p];
            }
            DiamondRecord {
                center,
                radius,
                error: round_up_f32(saturated.error[i]),
                parents,
                parent_count: d.parents.len() as u8,
                tet_count: d.simplices.len() as u8,
                phase: d.phase(),
                pad: 0,
                level: d.level as u32,
                id: d.id,
            }
        })
        .collect();
    stage("saturate", t);

    // 4. The tet table: each record points into the blobs, laid out in table order.
    on_stage("tables");
    let t = Instant::now();
    let mut tets = Vec::with_capacity(simplices.len());
    let mut spheres = Vec::with_capacity(simplices.len());
    let (mut patch_offset, mut id_offset) = (0u64, 0u64);
    for entry in &simplices {
        let p = finished.record(entry.row)?;
        let (center, radius) = p.sphere.to_f32();
        tets.push(TetRecord {
            center,
            radius,
            cone_axis: p.cone.axis,
            cone_cos: p.cone.cos,
            diamond: entry.diamond,
            parent_diamond: entry.parent_diamond,
            first_child: entry.first_child,
            level: entry.level as u32,
            patch_offset,
            patch_bytes: p.patch_bytes,
            vertex_count: p.vertex_count,
            strip_index_count: p.strip_index_count,
            triangle_count: p.triangle_count,
            id_offset,
            id_bytes: p.id_bytes,
            patch_checksum: p.patch_checksum,
        });
        spheres.push(p.sphere);
        patch_offset += p.patch_bytes as u64;
        id_offset += p.id_bytes as u64;
    }
    nest_simplex_spheres(&mut tets, &mut spheres, RADIUS_MARGIN * model_size);
    let order: Vec<u32> = simplices.iter().map(|e| e.row).collect();
    drop(simplices);
    stage("tables", t);

    let header = Header {
        dimension: config.domain.dim() as u32,
        attributes,
        root_tet_count: hierarchy.mesh.roots().len() as u64,
        input_vertex_count: input_vertices as u64,
        input_triangle_count: input_triangles as u64,
        origin,
        bbox_min,
        bbox_max,
        position_step: step,
        lattice_origin: [0, 1, 2].map(|i| frame.model_origin[i] + frame.origin[i]),
        lattice_unit: frame.unit,
        lattice_bits: frame.bits,
        ..bytemuck::Zeroable::zeroed()
    };
    let summary = BuildSummary {
        input_triangles,
        input_vertices,
        tetrahedra: tets.len(),
        leaves: hierarchy.mesh.leaf_count(),
        diamonds: diamonds.len(),
        depth: hierarchy.depth(),
        patch_triangles: tets.iter().map(|t| t.triangle_count as usize).sum(),
        locked_vertices: simplified.locked_vertices,
        resimplified_diamonds: simplified.resimplified,
        root_error: diamonds.first().map_or(0.0, |d| d.error as f64),
        position_step: step,
        quantisation_error,
        repository_bytes: 0,
        seconds: 0.0,
        stages,
    };
    Ok(Built {
        directory: RepositoryDirectory {
            header,
            diamonds,
            tets,
            codec: config.codec,
        },
        order,
        finished,
        summary,
    })
}

/// One row of the simplex table: its simplex (the row of its finished patch's record, and its
/// level), the table rows of the diamond its split makes (`NO_INDEX` for a leaf) and of the
/// diamond whose split made it (`NO_INDEX` for a root), and its first child's row. (20 bytes:
/// at 100 M triangles the table has 1.6 M rows.)
struct TableEntry {
    row: u32,
    level: u16,
    diamond: u32,
    parent_diamond: u32,
    first_child: u32,
}

/// The simplex table, breadth-first from the roots: a level at a time, each level's simplices
/// in the order of their parents (so siblings are adjacent), exactly sized.
fn breadth_first(
    hierarchy: &Hierarchy,
    table_index: &HashMap<DiamondId, u32>,
    finished: &FinishedPatches,
) -> Vec<TableEntry> {
    let mesh = &hierarchy.mesh;
    // Each split turns one leaf into two: the table holds every root and two per split.
    let rows = 2 * mesh.leaf_count() - mesh.roots().len();
    let mut table: Vec<TableEntry> = Vec::with_capacity(rows);
    let mut level: Vec<(Simplex, u32)> = mesh.roots().iter().map(|&r| (r, NO_INDEX)).collect();
    while !level.is_empty() {
        let next_start = table.len() + level.len();
        let mut next = Vec::new();
        for (s, parent_diamond) in level {
            // A simplex at the lattice resolution has no integer midpoint: its truncated
            // `split_point` may be another diamond's id, but it is never split.
            let split = s.can_split() && mesh.is_split(s.split_point());
            let (diamond, first_child) = if split {
                let diamond = table_index[&s.split_point()];
                let first = (next_start + next.len()) as u32;
                next.extend(s.children().map(|c| (c, diamond)));
                (diamond, first)
            } else {
                (NO_INDEX, NO_INDEX)
            };
            table.push(TableEntry {
                row: finished.row(s.key),
                level: s.level(),
                diamond,
                parent_diamond,
                first_child,
            });
        }
        level = next;
    }
    debug_assert_eq!(table.len(), rows);
    table
}
