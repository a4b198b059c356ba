//! The build's last steps, once every patch is final: the table order (breadth-first from
//! the roots), the saturation of errors and spheres over the diamond DAG, the diamond and tet
//! tables, the header and the summary (`build.rs` is the driver).

use rustc_hash::FxHashMap as HashMap;
use std::time::Instant;

use tessera_core::bounds::round_up_f32;
use tessera_core::leb::{DiamondId, Simplex};
use tessera_core::repository::format::{
    AttributeErrorRecord, DiamondRecord, Header, TetRecord, ATTR_COLORS, ATTR_UVS, NO_INDEX,
};
use tessera_core::repository::RepositoryDirectory;

use crate::build_config::{BuildConfig, BuildSummary};
use crate::checkpoint::InputFacts;
use crate::finished_patches::FinishedPatches;
use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::saturate::{
    nest_simplex_spheres, saturate, saturate_attribute_errors, OwnErrors, RADIUS_MARGIN,
};
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
    // The attribute error table, for an input with colours or texture coordinates only (one
    // without keeps its bytes): saturated by the maximum, in table order.
    let attribute_errors = (attributes & (ATTR_COLORS | ATTR_UVS) != 0).then(|| {
        let saturated = saturate_attribute_errors(&hierarchy, &simplified.attribute_error);
        diamond_order
            .iter()
            .map(|&i| AttributeErrorRecord {
                colour: saturated[i].colour,
                normal_degrees: saturated[i].normal_degrees,
                uv: saturated[i].uv,
                reserved: 0.0,
            })
            .collect()
    });
    stage("saturate", t);

    // 4. The tet table: each record points into the blobs, laid out in table order.
    on_stage("tables");
    let t = Instant::now();
    let (mut tets, order) = breadth_first(&hierarchy, &table_index, &finished);
    let mut spheres = Vec::with_capacity(tets.len());
    let (mut patch_offset, mut id_offset) = (0u64, 0u64);
    for (tet, &row) in tets.iter_mut().zip(&order) {
        let p = finished.record(row)?;
        (tet.center, tet.radius) = p.sphere.to_f32();
        (tet.cone_axis, tet.cone_cos) = (p.cone.axis, p.cone.cos);
        tet.patch_offset = patch_offset;
        tet.patch_bytes = p.patch_bytes;
        tet.vertex_count = p.vertex_count;
        tet.strip_index_count = p.strip_index_count;
        tet.triangle_count = p.triangle_count;
        tet.id_offset = id_offset;
        tet.id_bytes = p.id_bytes;
        tet.patch_checksum = p.patch_checksum;
        spheres.push(p.sphere);
        patch_offset += p.patch_bytes as u64;
        id_offset += p.id_bytes as u64;
    }
    nest_simplex_spheres(&mut tets, &mut spheres, RADIUS_MARGIN * model_size);
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
        textures: None,
    };
    Ok(Built {
        directory: RepositoryDirectory {
            header,
            diamonds,
            tets,
            codec: config.codec,
            attribute_errors,
            // Added by the writing step (`texture/`), independent of the geometry.
            textures: None,
        },
        order,
        finished,
        summary,
    })
}

/// The tet table, breadth-first from the roots: a level at a time, each level's simplices in
/// the order of their parents (so siblings are adjacent), exactly sized, with each row's
/// level, the table rows of the diamond its split makes (`NO_INDEX` for a leaf) and of the
/// diamond whose split made it (`NO_INDEX` for a root) and its first child's row filled in;
/// and each row's simplex as the row of its finished patch's record. The patch fields are the
/// caller's to fill (a table of these rows beside the records was 20 B a simplex more at the
/// build's peak).
fn breadth_first(
    hierarchy: &Hierarchy,
    table_index: &HashMap<DiamondId, u32>,
    finished: &FinishedPatches,
) -> (Vec<TetRecord>, Vec<u32>) {
    let mesh = &hierarchy.mesh;
    // Each split turns one leaf into two: the table holds every root and two per split.
    let rows = 2 * mesh.leaf_count() - mesh.roots().len();
    let mut table: Vec<TetRecord> = Vec::with_capacity(rows);
    let mut order: Vec<u32> = Vec::with_capacity(rows);
    // Only a level's split simplices are kept (with their diamonds' rows): the next level is
    // their children, made as it is walked (a level's every simplex, twice as many, made
    // this step's peak larger than the tables).
    let mut level_rows = |simplices: &mut dyn Iterator<Item = (Simplex, u32)>, len: usize| {
        let next_start = table.len() + len;
        let mut split_ones: Vec<(Simplex, u32)> = Vec::new();
        for (s, parent_diamond) in simplices {
            // A simplex at the lattice resolution has no integer midpoint: its truncated
            // `split_point` may be another diamond's id, but it is never split.
            let split = s.can_split() && mesh.is_split(s.split_point());
            let (diamond, first_child) = if split {
                let diamond = table_index[&s.split_point()];
                let first = (next_start + 2 * split_ones.len()) as u32;
                split_ones.push((s, diamond));
                (diamond, first)
            } else {
                (NO_INDEX, NO_INDEX)
            };
            table.push(TetRecord {
                level: s.level() as u32,
                diamond,
                parent_diamond,
                first_child,
                ..bytemuck::Zeroable::zeroed()
            });
            order.push(finished.row(s.key));
        }
        split_ones
    };
    let roots = mesh.roots();
    let mut parents = level_rows(&mut roots.iter().map(|&r| (r, NO_INDEX)), roots.len());
    while !parents.is_empty() {
        let mut children = parents
            .iter()
            .flat_map(|&(p, diamond)| p.children().map(move |c| (c, diamond)));
        parents = level_rows(&mut children, 2 * parents.len());
    }
    debug_assert_eq!(table.len(), rows);
    (table, order)
}
