//! The build driver: input mesh → repository, as a list of steps (seed 001: construction,
//! simplification, saturation; then strips and the file).

use std::cell::RefCell;
use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;
use tessera_core::leb::SimplexKey;
use tessera_core::repository::format::{ATTR_COLORS, ATTR_NORMALS, ATTR_UVS, POSITION_BITS};
use tessera_core::repository::writer::RepositoryContents;
use tessera_core::repository::{write_repository_streamed, BlobFeed, RepositoryDirectory};

use crate::build_checks::{validate, validate_config};
use crate::build_tables::{assemble, Built, Parts};
use crate::checkpoint::{
    drop_level_parts, save_hierarchy, save_level_part, save_levels, Checkpoint, CheckpointError,
    HierarchyCheckpoint, InputFacts, LevelsCheckpoint,
};
use crate::external::{LeafGroups, StagedMesh};
use crate::finished_patches::{FinishedPatches, PatchEncoding};
use crate::frame::LatticeFrame;
use crate::hierarchy::{
    build_hierarchy, build_hierarchy_bucketed, BucketBudget, Construction, Hierarchy, LeafCorners,
    MeshBarycentres,
};
use crate::mesh::InputMesh;
use crate::simplify::{
    simplify_from_leaves, simplify_hierarchy, simplify_levels, CurrentMesh, LevelCheckpoints,
    LevelState, SimplifyError,
};
use crate::texture::{PageMaker, WithPages};
use crate::texture_input::MeshTextures;
use crate::vertex_table::LivePatch;

pub use crate::build_config::{
    BuildConfig, BuildError, BuildSummary, Domain, MemoryBudget, TexturePagesSummary,
    COARSEST_SHARE, DEFAULT_LEAF_TRIANGLES, DEFAULT_LEAF_TRIANGLES_HEIGHT_FIELD, MAX_EXTENT,
};

/// Builds the repository for `mesh` and writes it to `out` (temporary file + rename: a failed
/// build never leaves a partial file). `on_stage` is told each stage's name as it starts.
/// The patches are encoded as they are made and streamed into the file (kept in temporary
/// files under `config.memory`), so the repository's blobs are never held whole.
pub fn build_repository(
    mesh: &InputMesh,
    config: &BuildConfig,
    out: &Path,
    on_stage: &(dyn Fn(&str) + Sync),
) -> Result<BuildSummary, BuildError> {
    write_built(Source::Memory(mesh), config, out, on_stage, None)
}

/// `build_repository` from a mesh staged on disk (`import::stage_mesh`), never loading it: the
/// same bytes as the build of the loaded mesh with the same `config`, which must have a
/// memory budget (its temporary directory holds the joins' files).
pub fn build_repository_staged(
    staged: &StagedMesh,
    config: &BuildConfig,
    out: &Path,
    on_stage: &(dyn Fn(&str) + Sync),
) -> Result<BuildSummary, BuildError> {
    if config.memory.is_none() {
        return Err(BuildError::Config(
            "a staged mesh is built under a memory budget".into(),
        ));
    }
    write_built(Source::Staged(staged), config, out, on_stage, None)
}

/// `build_repository_staged` that keeps `checkpoint` (`checkpoint/mod.rs`) up to date after
/// the hierarchy, the leaves and levels, and continues from it: from its `hierarchy` stage
/// (with `staged`, the checkpoint's own), from its `leaves` or `level-N` stage (then `staged`
/// is not read and may be `None`), or from the start with `staged`. The bytes are those of
/// `build_repository_staged`.
pub fn build_repository_checkpointed(
    staged: Option<&StagedMesh>,
    config: &BuildConfig,
    out: &Path,
    on_stage: &(dyn Fn(&str) + Sync),
    checkpoint: &mut Checkpoint,
) -> Result<BuildSummary, BuildError> {
    if config.memory.is_none() {
        return Err(BuildError::Config(
            "a checkpointed build is built under a memory budget".into(),
        ));
    }
    let damaged = |e: std::io::Error| CheckpointError::Damaged {
        dir: checkpoint.dir().to_path_buf(),
        reason: e.to_string(),
    };
    let resumed = crate::checkpoint::load_levels(checkpoint).map_err(damaged)?;
    let hierarchy = crate::checkpoint::load_hierarchy(checkpoint).map_err(damaged)?;
    let source = match (&resumed, staged) {
        (Some(_), _) => Source::Resumed,
        (None, Some(staged)) => Source::Staged(staged),
        (None, None) => {
            return Err(BuildError::Config(
                "no staged mesh and no simplification state to resume from".into(),
            ))
        }
    };
    let resume = Resume {
        checkpoint,
        hierarchy,
        levels: resumed,
    };
    write_built(source, config, out, on_stage, Some(resume))
}

/// Where the build's mesh is.
#[derive(Clone, Copy)]
enum Source<'a> {
    Memory(&'a InputMesh),
    Staged(&'a StagedMesh),
    /// In the checkpoint's simplification state (`Resume::levels`).
    Resumed,
}

/// A checkpointed build: its checkpoint, and the state it resumes from (if any).
struct Resume<'c> {
    checkpoint: &'c mut Checkpoint,
    /// The hierarchy and counts (stage `hierarchy`; the mesh is still the staged one).
    hierarchy: Option<HierarchyCheckpoint>,
    levels: Option<LevelsCheckpoint>,
}

fn write_built(
    source: Source,
    config: &BuildConfig,
    out: &Path,
    on_stage: &(dyn Fn(&str) + Sync),
    resume: Option<Resume>,
) -> Result<BuildSummary, BuildError> {
    let start = Instant::now();
    // The textures are checked (each decoded once) before the geometry's expensive work; their
    // pages are made while the writer writes their section, the file's last.
    let textures = config.textures.as_ref();
    let plan = textures
        .map(|t| crate::texture::plan(t, config.memory.as_ref(), config.texture_encoding))
        .transpose()?;
    if let Some(textures) = textures {
        check_wedges_in_bands(source, textures)?;
    }
    let mut built = build_parts(source, config, on_stage, resume)?;
    on_stage("write");
    let t = Instant::now();
    built.directory.textures = plan.as_ref().map(|p| p.directory.clone());
    let mut feed = WithPages {
        blobs: built.finished.feed(&built.order),
        pages: textures
            .zip(plan.as_ref())
            .map(|(t, p)| PageMaker::new(t, p)),
    };
    built.summary.repository_bytes = write_repository_streamed(out, &built.directory, &mut feed)?;
    built.summary.textures = feed.pages.as_ref().map(PageMaker::summary);
    built
        .summary
        .stages
        .push(("write", t.elapsed().as_secs_f64()));
    built.summary.seconds = start.elapsed().as_secs_f64();
    Ok(built.summary)
}

/// `texture::check_wedges_in_bands` over the mesh's coordinates, in memory or staged (a
/// resumed build's were checked when it began: its manifest holds the input and the bands).
fn check_wedges_in_bands(source: Source, textures: &MeshTextures) -> Result<(), BuildError> {
    let bands = &textures.bands;
    match source {
        Source::Memory(mesh) => {
            let mut uvs = mesh.uvs.as_ref().map(|u| u.iter().map(|&uv| Ok(uv)));
            let uvs = uvs.as_mut().map(|u| u as &mut dyn Iterator<Item = _>);
            crate::texture::check_wedges_in_bands(uvs, bands)
        }
        Source::Staged(staged) => {
            let file = staged.attributes.uvs.as_ref();
            let mut uvs = file.map(|f| f.read()).transpose().map_err(|e| {
                BuildError::Config(format!("reading the staged texture coordinates: {e}"))
            })?;
            let uvs = uvs.as_mut().map(|u| u as &mut dyn Iterator<Item = _>);
            crate::texture::check_wedges_in_bands(uvs, bands)
        }
        Source::Resumed => Ok(()),
    }
}

/// Builds the repository image in memory (the same bytes `build_repository` writes) of an
/// input without textures: a textured one is refused (its pages are made while the file is
/// written: `build_repository`).
pub fn build_contents(
    mesh: &InputMesh,
    config: &BuildConfig,
    on_stage: &(dyn Fn(&str) + Sync),
) -> Result<(RepositoryContents, BuildSummary), BuildError> {
    if config.textures.is_some() {
        return Err(BuildError::Config(
            "build_contents holds no texture pages: build a textured input with \
             build_repository"
                .into(),
        ));
    }
    let mut built = build_parts(Source::Memory(mesh), config, on_stage, None)?;
    let mut feed = built.finished.feed(&built.order);
    let mut patch_blob = Vec::new();
    let mut id_blob = Vec::new();
    for i in 0..built.order.len() {
        let read = feed
            .patch(i, &mut patch_blob)
            .and_then(|()| feed.ids(i, &mut id_blob));
        read.map_err(|source| BuildError::Temporary {
            dir: config
                .memory
                .as_ref()
                .map_or_else(Default::default, |m| m.temp_dir.clone()),
            source,
        })?;
    }
    let RepositoryDirectory {
        header,
        diamonds,
        tets,
        codec,
        attribute_errors,
        textures: _,
    } = built.directory;
    let contents = RepositoryContents {
        header,
        diamonds,
        tets,
        patch_blob,
        id_blob,
        codec,
        attribute_errors,
    };
    Ok((contents, built.summary))
}

fn build_parts(
    source: Source,
    config: &BuildConfig,
    on_stage: &(dyn Fn(&str) + Sync),
    resume: Option<Resume>,
) -> Result<Built, BuildError> {
    validate_config(config)?;
    let checked = resume.as_ref().and_then(|r| r.hierarchy.as_ref());
    let bbox = match source {
        Source::Memory(mesh) => validate(mesh)?,
        Source::Staged(_) if checked.is_some() => checked.expect("checked").facts.bbox,
        Source::Resumed => {
            resume
                .as_ref()
                .and_then(|r| r.levels.as_ref())
                .expect("a resumed build has its state")
                .facts
                .bbox
        }
        Source::Staged(staged) => crate::staged_build::validate_staged(
            staged,
            config.memory.as_ref().expect("checked by the caller"),
        )?,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(config.threads.unwrap_or(0))
        .build()
        .map_err(|e| BuildError::Config(e.to_string()))?;
    pool.install(|| build_in_pool(source, bbox, config, on_stage, resume))
}

fn build_in_pool(
    source: Source,
    (bbox_min, bbox_max): ([f64; 3], [f64; 3]),
    config: &BuildConfig,
    on_stage: &(dyn Fn(&str) + Sync),
    resume: Option<Resume>,
) -> Result<Built, BuildError> {
    let (mut checkpoint, resumed_counts, levels) = match resume {
        Some(r) => (Some(r.checkpoint), r.hierarchy, r.levels),
        None => (None, None, None),
    };
    let mut stages = Vec::new();
    let mut stage = |name: &'static str, t: Instant| stages.push((name, t.elapsed().as_secs_f64()));
    let (input_vertices, input_triangles, attributes) = match source {
        Source::Memory(mesh) => (
            mesh.positions.len(),
            mesh.triangles.len(),
            (mesh.normals.is_some() as u32 * ATTR_NORMALS)
                | (mesh.colors.is_some() as u32 * ATTR_COLORS)
                | (mesh.uvs.is_some() as u32 * ATTR_UVS),
        ),
        Source::Staged(staged) => {
            let a = &staged.attributes;
            (
                staged.positions.len() as usize,
                staged.triangles.len() as usize,
                (a.normals.is_some() as u32 * ATTR_NORMALS)
                    | (a.colors.is_some() as u32 * ATTR_COLORS)
                    | (a.uvs.is_some() as u32 * ATTR_UVS),
            )
        }
        Source::Resumed => {
            let f = &levels
                .as_ref()
                .expect("a resumed build has its state")
                .facts;
            (f.vertices, f.triangles, f.attributes)
        }
    };
    let facts = InputFacts {
        bbox: (bbox_min, bbox_max),
        vertices: input_vertices,
        triangles: input_triangles,
        attributes,
    };
    let (resumed_hierarchy, resumed_state, resumed_finished, resumed_parts) = match levels {
        Some(l) => (Some(l.hierarchy), Some(l.state), Some(l.finished), l.parts),
        None => (None, None, None, Vec::new()),
    };

    // Where everything sits: bounding box, repository origin (its minimum corner: every build
    // computation is relative to it, see frame.rs), lattice cube.
    let origin = bbox_min;
    let frame =
        LatticeFrame::around_box(bbox_min, bbox_max, config.lattice_bits, config.domain.dim());
    // Levels above the model's cube for the coarser versions past its roots, where the roots
    // alone could hold more than the coarsest cut's share of the input.
    let frame = frame.with_headroom(config.headroom_for(input_triangles));
    assert!(
        (1..=POSITION_BITS).contains(&config.position_bits),
        "position bits {} outside 1..={POSITION_BITS}",
        config.position_bits
    );
    let levels = (1u64 << config.position_bits) as f64 - 1.0;
    let step = [0, 1, 2].map(|i| (bbox_max[i] - bbox_min[i]) / levels);
    let model_size = crate::frame::diagonal(bbox_min, bbox_max).max(f64::MIN_POSITIVE);

    // 1. Hierarchy: each triangle in the leaf holding its barycentre.
    let leaf_cap = match config.construction {
        Construction::LeafTriangles(n) => n,
        Construction::Levels(_) => config.domain.default_leaf_triangles(),
    };
    let t = Instant::now();
    let (hierarchy, current, lists) = match (source, &config.memory, resumed_hierarchy) {
        (Source::Resumed, _, Some(hierarchy)) => (hierarchy, None, None),
        (Source::Resumed, _, None) => unreachable!("a resumed build has its state"),
        (_, _, _) if resumed_counts.is_some() => {
            let r = resumed_counts.expect("checked");
            (r.hierarchy, Some(r.current), Some(r.lists))
        }
        (source, memory, _) => {
            on_stage("hierarchy");
            let (hierarchy, current, mut lists) =
                hierarchy_and_counts(source, memory, &frame, leaf_cap, config)?;
            if let (Some(c), Source::Staged(_)) = (checkpoint.as_deref_mut(), source) {
                let spooled = lists
                    .as_mut()
                    .expect("a staged build spools its leaves' triangles");
                // The checkpoint's file from then on (the spool's, linked there).
                let saved =
                    save_hierarchy(c, &facts, &hierarchy, spooled, &current).map_err(|source| {
                        BuildError::Temporary {
                            dir: c.dir().to_path_buf(),
                            source,
                        }
                    })?;
                lists = Some(saved);
            }
            stage("hierarchy", t);
            (hierarchy, Some(current), lists)
        }
    };

    // 2. Simplification, diamond by diamond, finest first, borders locked; each patch
    //    encoded (strips, quantised positions, attributes) as soon as it is final.
    on_stage("simplify");
    let t = Instant::now();
    let spill_dir = config.memory.as_ref().map(|m| m.temp_dir.as_path());
    let temporary = |source| BuildError::Temporary {
        dir: spill_dir.map_or_else(Default::default, Path::to_path_buf),
        source,
    };
    let finished = match (resumed_finished, checkpoint.as_deref()) {
        (Some(finished), _) => finished,
        (None, Some(c)) => FinishedPatches::new_named(c.dir()).map_err(temporary)?,
        (None, None) => FinishedPatches::new(spill_dir).map_err(temporary)?,
    };
    let mut finished = finished;
    // Every simplex of the hierarchy gets a patch: the roots and two per split.
    finished.reserve(2 * hierarchy.mesh.leaf_count() - hierarchy.mesh.roots().len());
    let finished = RefCell::new(finished);
    let encoding = PatchEncoding {
        numbering_table: crate::simplify::numbering_table(input_vertices, spill_dir.is_some()),
        origin,
        bbox_min,
        step,
        attributes,
        codec: config.codec,
        // The current mesh's (the input's, in memory or staged; a resumed build's state's).
        vertex_starts: match (&current, &resumed_state) {
            (Some(current), _) => current.vertex_starts().clone(),
            (None, Some(state)) => state.vertex_starts().clone(),
            (None, None) => unreachable!("a build has its counts or its resumed state"),
        },
    };
    let mut sink =
        |patches: &[(SimplexKey, &LivePatch)]| finished.borrow_mut().add(patches, &encoding);
    let checkpoint_dir = checkpoint.as_deref().map(|c| c.dir().to_path_buf());
    let damaged_dir = checkpoint_dir.clone().unwrap_or_default();
    // A checkpointed build saves its state after the leaves and after each level, and the
    // results of a level being simplified in parts, as its pacing allows.
    let checkpoint = RefCell::new(checkpoint);
    let mut after_level = |state: &LevelState| match checkpoint.borrow_mut().as_deref_mut() {
        Some(c) => save_levels(c, &facts, &hierarchy, state, &mut finished.borrow_mut()),
        None => Ok(()),
    };
    let mut after_part =
        |state: &LevelState,
         diamonds: usize,
         write: &dyn Fn(&mut crate::checkpoint::Enc) -> std::io::Result<()>| {
            match checkpoint.borrow_mut().as_deref_mut() {
                Some(c) => save_level_part(c, state, diamonds, write),
                None => Ok(None),
            }
        };
    let mut drop_parts = || match checkpoint.borrow_mut().as_deref_mut() {
        Some(c) => drop_level_parts(c),
        None => Ok(0),
    };
    let mut checkpoints = LevelCheckpoints {
        in_parts: checkpoint.borrow().is_some(),
        after_level: &mut after_level,
        after_part: &mut after_part,
        drop_parts: &mut drop_parts,
        resumed_parts,
    };
    let simplified = match (source, &config.memory) {
        (Source::Resumed, _) => simplify_levels(
            resumed_state.expect("a resumed build has its state"),
            &hierarchy,
            &config.simplify,
            spill_dir,
            &mut sink,
            &mut checkpoints,
        ),
        (Source::Staged(staged), Some(memory)) => {
            let starts = current.as_ref().expect("counted").vertex_starts();
            let simplifier_of = crate::staged_build::simplifier_positions(
                staged,
                starts,
                &hierarchy.frame,
                memory,
            )?;
            let mut groups = LeafGroups::new(
                staged,
                lists.expect("a staged build spools its leaves' triangles"),
                &simplifier_of,
                crate::staged_build::leaf_group_triangles(memory),
            );
            // Once the last group is made, nothing reads the staged mesh again: its files are
            // emptied (the caller still owns them; a checkpoint's copies stay until the
            // checkpoint no longer needs them), which frees their disk space. The next group is
            // joined on its own thread while this one is encoded.
            let produce = || {
                let group = groups.next_group()?;
                if group.is_none() {
                    staged.discard()?;
                }
                Ok(group)
            };
            let current = current.expect("counted with the hierarchy");
            crate::external::prefetch::one_ahead(produce, |next| match checkpoint_dir {
                None => simplify_from_leaves(
                    next,
                    input_vertices,
                    &hierarchy,
                    current,
                    &config.simplify,
                    spill_dir,
                    &mut sink,
                ),
                Some(dir) => {
                    LevelState::from_leaves_in(next, input_vertices, current, (&dir, &hierarchy))
                        .and_then(|state| {
                            (checkpoints.after_level)(&state)?;
                            simplify_levels(
                                state,
                                &hierarchy,
                                &config.simplify,
                                spill_dir,
                                &mut sink,
                                &mut checkpoints,
                            )
                        })
                }
            })
        }
        (Source::Staged(_), None) => unreachable!("a staged build has a budget"),
        (Source::Memory(mesh), _) => simplify_hierarchy(
            mesh,
            &hierarchy,
            current.expect("counted with the hierarchy"),
            &config.simplify,
            spill_dir,
            &mut sink,
        ),
    }
    .map_err(|e| match e {
        SimplifyError::Conformity(e) => BuildError::Conformity(e),
        SimplifyError::Finished(e) => temporary(e),
        SimplifyError::Checkpoint(e) => BuildError::Checkpoint(CheckpointError::Damaged {
            dir: damaged_dir,
            reason: e.to_string(),
        }),
    })?;
    let mut finished = finished.into_inner();
    finished.seal().map_err(temporary)?;
    stage("simplify", t);

    let stages = std::mem::take(&mut stages);
    let parts = Parts {
        hierarchy,
        simplified,
        finished,
        facts,
        frame,
        step,
        model_size,
        stages,
    };
    assemble(parts, config, on_stage).map_err(temporary)
}

/// The hierarchy and the use counts, from the mesh in memory or staged on disk; a staged
/// mesh's leaves' triangles stay on disk (`LeafCorners`: the staged triangle file is gone
/// then), a loaded one's lists are in the hierarchy.
fn hierarchy_and_counts(
    source: Source,
    memory: &Option<MemoryBudget>,
    frame: &LatticeFrame,
    leaf_cap: usize,
    config: &BuildConfig,
) -> Result<(Hierarchy, CurrentMesh, Option<LeafCorners>), BuildError> {
    let frame = *frame;
    Ok(match (source, memory) {
        (Source::Staged(staged), Some(memory)) => {
            let (hierarchy, lists, current) = crate::staged_build::hierarchy_and_counts(
                staged,
                frame,
                config.construction,
                leaf_cap,
                memory,
            )?;
            (hierarchy, current, Some(lists))
        }
        (Source::Staged(_), None) | (Source::Resumed, _) => {
            unreachable!("a staged build has a budget; a resumed one its hierarchy")
        }
        (Source::Memory(mesh), None) => {
            let barycenters: Vec<[f64; 3]> = mesh
                .triangles
                .par_iter()
                .map(|tri| frame.location(tri.map(|v| mesh.positions[v as usize])))
                .collect();
            // The simplifier's sharing counts are independent of the hierarchy: both at once.
            let (hierarchy, current) = rayon::join(
                || build_hierarchy(frame, &barycenters, config.construction),
                || CurrentMesh::new(mesh),
            );
            (hierarchy, current, None)
        }
        (Source::Memory(mesh), Some(memory)) => {
            let budget = BucketBudget::new(memory.bucket_triangles(leaf_cap), &memory.temp_dir);
            let source = MeshBarycentres {
                frame: &frame,
                mesh,
            };
            let hierarchy = build_hierarchy_bucketed(frame, &source, config.construction, &budget)
                .map_err(|source| BuildError::Temporary {
                    dir: memory.temp_dir.clone(),
                    source,
                })?;
            let current =
                CurrentMesh::new_within(mesh, memory.bytes as usize / 4, &memory.temp_dir)
                    .map_err(|source| BuildError::Temporary {
                        dir: memory.temp_dir.clone(),
                        source,
                    })?;
            (hierarchy, current, None)
        }
    })
}
