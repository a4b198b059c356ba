//! `tessera simplify`: seed 004's out-of-core simplification (octree vertex clustering with
//! generalised quadrics), end to end, one mesh in, one or more smaller meshes out.
//!
//! ```text
//! staged mesh ─▶ sorted triangle soup (soup.rs) ─▶ octree of end nodes (octree.rs)
//!   ─▶ every node simplified bottom-up (levels.rs, node.rs, quadric.rs)
//!   ─▶ a cut: the seed's level k, or a cut of N triangles ─▶ PLY or GLB (writer.rs)
//!   ─▶ its sampled distance to the input (measure.rs)
//! ```
//!
//! Out of core: the mesh is staged and welded on disk by the importers (`import::stage_mesh`),
//! the soup and the nodes' outputs are record files, and each step holds a budgeted part of
//! them. What grows with the input whatever the budget: the octree's node table (about 60
//! bytes a node, input / T nodes or so) and the written mesh's vertex numbering (12-16 bytes
//! an output vertex).

pub mod layout;
pub mod levels;
pub mod measure;
pub mod node;
pub mod octree;
pub mod quadric;
pub mod soup;
pub mod writer;

use std::io;
use std::path::{Path, PathBuf};

use crate::external::StagedMesh;
use layout::{Attributes, Layout, Plain, Rich};
pub use levels::NodeStats;
pub use measure::Distance;

/// What to make.
#[derive(Clone, Debug)]
pub struct ClusterSettings {
    /// The seed's end-node size T (a node splits while it holds more); `None` with a target:
    /// searched.
    pub max_triangles_per_node: Option<u64>,
    /// The octree's depth limit D (at most 21).
    pub max_depth: u8,
    pub output: Outputs,
    /// Memory for the working sets, bytes.
    pub budget: usize,
    pub temp_dir: PathBuf,
    /// Measure each output's distance to the input.
    pub measure: bool,
}

/// Which meshes are written.
#[derive(Clone, Debug, PartialEq)]
pub enum Outputs {
    /// One mesh of about N triangles (±10 %), at `path`.
    Target { triangles: u64, path: PathBuf },
    /// The seed's levels 0..L (finest first), one file each.
    Levels { levels: u8, paths: Vec<PathBuf> },
}

/// One mesh written.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    pub path: PathBuf,
    /// The seed's level, for `Outputs::Levels`.
    pub level: Option<u8>,
    pub nodes: usize,
    pub triangles: u64,
    pub vertices: u64,
    pub bytes: u64,
    pub distance: Option<Distance>,
}

/// What was done.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterSummary {
    pub input_triangles: u64,
    pub input_vertices: u64,
    pub attributes: Attributes,
    /// The box's diagonal, model units.
    pub diagonal: f64,
    /// Each T tried and the triangles of its finest level (level 0).
    pub tries: Vec<(u64, u64)>,
    pub max_triangles_per_node: u64,
    pub nodes: usize,
    pub leaves: usize,
    pub depth: u8,
    /// Triangles of every seed level, finest first.
    pub level_triangles: Vec<u64>,
    pub stats: NodeStats,
    pub written: Vec<Written>,
}

/// Errors of the simplifier besides I/O: what was asked cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ClusterError {
    #[error(transparent)]
    Io(#[from] io::Error),
    #[error(
        "cannot make {target} triangles (within 10 %): the nearest cut of the octree has {got} \
         (level 0, the finest, has {finest}; tried --max-triangles-per-node {tried})"
    )]
    TargetUnreachable {
        target: u64,
        got: u64,
        finest: u64,
        tried: String,
    },
}

/// Bytes of the budget left to the process itself (its resident code and libraries, the
/// threads' stacks, small tables).
const RESERVE: usize = 16 << 20;

/// The smallest end-node size the target search tries.
const SMALLEST_T: u64 = 8;

/// Simplifies a staged mesh and writes what `settings.output` asks; `on_stage` is told each
/// stage's name as it starts (`soup`, `octree`, `nodes`, `write`, `measure`).
pub fn simplify_staged(
    staged: &StagedMesh,
    settings: &ClusterSettings,
    on_stage: &dyn Fn(&str),
) -> Result<ClusterSummary, ClusterError> {
    let a = &staged.attributes;
    if a.normals.is_some() || a.colors.is_some() || a.uvs.is_some() {
        run::<Rich>(staged, settings, on_stage)
    } else {
        run::<Plain>(staged, settings, on_stage)
    }
}

fn run<L: Layout>(
    staged: &StagedMesh,
    settings: &ClusterSettings,
    on_stage: &dyn Fn(&str),
) -> Result<ClusterSummary, ClusterError> {
    let dir = settings.temp_dir.as_path();
    // What the process holds besides the working sets (code, libraries, thread stacks, the
    // node table) is kept out of the budget.
    let budget = settings
        .budget
        .saturating_sub(RESERVE)
        .max(settings.budget / 2);
    on_stage("soup");
    let soup = soup::build::<L>(staged, budget, dir)?;
    let diagonal = (0..3)
        .map(|k| (soup.max[k] - soup.min[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let target = match &settings.output {
        Outputs::Target { triangles, .. } => Some(*triangles),
        Outputs::Levels { .. } => None,
    };
    let mut t = match (settings.max_triangles_per_node, target) {
        (Some(t), _) => t.max(1),
        // A node of T triangles keeps about its boundary, √(6T) edges made ragged by the
        // barycentre rule: level 0 came to about 5.5 input / √T on the dragon and a generated
        // mesh (T 34 to 348). T for a level 0 of about 3 N, so the cut has a level of
        // finer nodes to choose from, and the node table stays small.
        (None, Some(n)) => {
            let per = 1.83 * soup.triangles as f64 / n.max(1) as f64;
            ((per * per) as u64).clamp(SMALLEST_T, 1 << 20)
        }
        (None, None) => 1024,
    };
    let mut tries = Vec::new();
    let hierarchy = loop {
        on_stage("octree");
        let octree = octree::build(soup.keys.read()?, t, settings.max_depth)?;
        on_stage("nodes");
        let h = levels::simplify_all(&soup, octree, budget / 2, dir)?;
        let finest = h.triangles(&h.level_cut(0));
        tries.push((t, finest));
        let short = target.is_some_and(|n| finest * 10 < n * 9);
        if !short || settings.max_triangles_per_node.is_some() || t <= SMALLEST_T {
            break h;
        }
        t = (t / 4).max(SMALLEST_T);
    };
    let level_triangles: Vec<u64> = (0..=hierarchy.top_level())
        .map(|k| hierarchy.triangles(&hierarchy.level_cut(k)))
        .collect();
    let mut jobs: Vec<(PathBuf, Option<u8>, Vec<u32>)> = Vec::new();
    match &settings.output {
        Outputs::Target { triangles, path } => {
            let cut = hierarchy.target_cut(*triangles);
            let got = hierarchy.triangles(&cut);
            if got.abs_diff(*triangles) * 10 > *triangles {
                return Err(ClusterError::TargetUnreachable {
                    target: *triangles,
                    got,
                    finest: level_triangles[0],
                    tried: tries
                        .iter()
                        .map(|(t, _)| t.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
            jobs.push((path.clone(), None, cut));
        }
        Outputs::Levels { levels, paths } => {
            for k in 0..(*levels).min(hierarchy.top_level() + 1) {
                jobs.push((paths[k as usize].clone(), Some(k), hierarchy.level_cut(k)));
            }
        }
    }
    let mut written = Vec::new();
    for (path, level, cut) in jobs {
        on_stage("write");
        let w = writer::write_mesh(&hierarchy, &cut, soup.attributes, dir, &path)?;
        let distance = if settings.measure {
            on_stage("measure");
            Some(measure::measure(&soup, &hierarchy, &cut, budget / 2)?)
        } else {
            None
        };
        written.push(Written {
            path,
            level,
            nodes: cut.len(),
            triangles: w.triangles,
            vertices: w.vertices,
            bytes: w.bytes,
            distance,
        });
    }
    let nodes = &hierarchy.octree.nodes;
    Ok(ClusterSummary {
        input_triangles: soup.triangles,
        input_vertices: soup.vertices,
        attributes: soup.attributes,
        diagonal,
        max_triangles_per_node: t,
        tries,
        nodes: nodes.len(),
        leaves: hierarchy.octree.leaves(),
        depth: nodes.iter().map(|n| n.depth).max().unwrap_or(0),
        level_triangles,
        stats: hierarchy.stats,
        written,
    })
}

/// The file of level k beside `output`: its stem, `.levelK`, its extension
/// (`out.ply` → `out.level0.ply`).
pub fn level_path(output: &Path, level: u8) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match output.extension() {
        Some(ext) => format!("{stem}.level{level}.{}", ext.to_string_lossy()),
        None => format!("{stem}.level{level}"),
    };
    output.with_file_name(name)
}
