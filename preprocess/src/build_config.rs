//! What controls a build and what it reports: `BuildConfig` (with its `Domain` and the
//! `--memory` budget), `BuildError`, `BuildSummary`. The driver is `build.rs`.

use tessera_core::repository::format::POSITION_BITS;
use tessera_core::repository::{PatchCodec, RepositoryError};

use crate::hierarchy::Construction;
use crate::simplify::SimplifySettings;

/// Default maximum triangles per leaf; chosen by the sweep in BENCHMARKS.md ("The patch
/// size, found by experiment").
pub const DEFAULT_LEAF_TRIANGLES: usize = 1024;

/// Default leaf size of a height field (2D): a grid fills its triangles evenly, so leaves hold
/// close to the cap and a smaller cap gives patches of the size a mesh's 1024 gives (measured
/// sweep in BENCHMARKS.md).
pub const DEFAULT_LEAF_TRIANGLES_HEIGHT_FIELD: usize = 256;

/// The share of the input the coarsest cut holds at most in a default build (issue 46: ≤ 1 %
/// of every test scan), reached through the levels above the model's cube (`headroom`).
pub const COARSEST_SHARE: f32 = 0.01;

/// Largest extent of a model along any axis, in its units.
pub const MAX_EXTENT: f64 = 1e30;

/// Everything that controls a build.
#[derive(Clone, Debug)]
pub struct BuildConfig {
    /// How deep the hierarchy goes (adaptive by leaf size, or a fixed number of levels).
    pub construction: Construction,
    /// Worker threads; None = one per core.
    pub threads: Option<usize>,
    /// log2 of the model's lattice cube side: bounds the depth below that cube at dimension ·
    /// bits levels.
    pub lattice_bits: u32,
    /// Doublings of the lattice cube around the model's cube (`LatticeFrame::with_headroom`),
    /// each giving the hierarchy `dim` levels above the model's cube: a chain of coarser
    /// versions past its roots, each keeping half, so that a small model's coarsest cut reaches
    /// `SimplifySettings::coarsest_share` of its input (its roots alone keep 2–13 % of the
    /// test scans: about six patches whatever the model's size). Finer levels are built exactly
    /// as without it. Used only where the roots could hold more than that share
    /// ([`Self::headroom_for`]).
    pub headroom: u32,
    /// What the hierarchy subdivides: tetrahedra for any mesh, triangles for a height field.
    pub domain: Domain,
    /// How each diamond is simplified.
    pub simplify: SimplifySettings,
    /// A memory budget (`--memory`): the stages that can work out of core do, with their
    /// temporary files in its directory. The repository is the same bytes with or without it.
    pub memory: Option<MemoryBudget>,
    /// How the repository stores its patches: coded (the default since issue 49), packed (the
    /// format before it) or raw (`--no-compress`). Each decodes to the same drawn bytes.
    pub codec: PatchCodec,
    /// Bits per axis of the position grid (`--position-bits`, 1..=`POSITION_BITS`): the step
    /// is the bounding box's extent / (2^bits − 1). Fewer bits make packed patches smaller and
    /// the quantisation error (counted in every stored error) larger.
    pub position_bits: u32,
    /// The input's textures and bands (`texture_input.rs`), written into the repository as
    /// pages (`tessera_core::texture`); `None` for an input without textures.
    pub textures: Option<crate::texture_input::MeshTextures>,
    /// How texture pages are stored (`--texture-encoding`): BC1 by default (6.06 times
    /// smaller on disk and on the GPU, lossy: the build reports its PSNR), RGBA8 lossless.
    pub texture_encoding: tessera_core::texture::PageEncoding,
}

/// How much memory the out-of-core stages may use, and where their temporary files go (all
/// unnamed: nothing is left behind, even when the build is killed — but for a checkpointed
/// build's checkpoint, `build_repository_checkpointed`, which is what a resume starts from).
///
/// Out of core today: the import of a mesh file (`import::stage_mesh`, done by the caller, who
/// then calls `build_repository_staged`: the mesh is never loaded), the hierarchy's
/// construction (`hierarchy::build_hierarchy_bucketed`), the live patches
/// (`simplify/live_store.rs`), a level's results (`simplify/result_spill.rs`) and the encoded
/// patches (`finished_patches.rs`). What still grows with the input is listed in
/// ARCHITECTURE.md, "The out-of-core build".
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryBudget {
    pub bytes: u64,
    pub temp_dir: std::path::PathBuf,
}

impl MemoryBudget {
    /// Triangles a bucket of the hierarchy's construction may hold: a quarter of the budget
    /// at about 70 bytes per triangle while a bucket is split, and never less than a few
    /// leaves.
    pub fn bucket_triangles(&self, leaf_triangles: usize) -> usize {
        ((self.bytes / 4 / 70) as usize).max(4 * leaf_triangles.max(1))
    }
}

/// The space the LEB hierarchy subdivides.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Domain {
    /// Tetrahedra over the model's bounding cube (3D LEB): any triangle mesh.
    Volume,
    /// Right triangles over the square around the model's x, y extent (2D LEB, BDAM's pair of
    /// bintrees): a height field, z being the height; triangles are located by their (x, y)
    /// barycentre.
    HeightField,
}

impl Domain {
    /// The default `--leaf-triangles` of this domain.
    pub fn default_leaf_triangles(self) -> usize {
        match self {
            Domain::Volume => DEFAULT_LEAF_TRIANGLES,
            Domain::HeightField => DEFAULT_LEAF_TRIANGLES_HEIGHT_FIELD,
        }
    }

    /// The LEB dimension: 3 or 2.
    pub fn dim(self) -> u8 {
        match self {
            Domain::Volume => 3,
            Domain::HeightField => 2,
        }
    }
}

impl BuildConfig {
    /// The headroom a build of `input_triangles` gets: `headroom` where the roots, holding
    /// patches of up to about `--leaf-triangles` (6 of them, 2 for a height field), could hold
    /// more than `coarsest_share` of the input (below 614,400 triangles at the defaults for
    /// meshes, 51,200 for height fields), else none: larger models reach it without, and their
    /// builds stay as they were (the levels above add empty simplices along the model cube's
    /// faces: 14 % more simplices, 1.1 % more bytes on the dragon, whose roots keep 0.03 %).
    /// None for `Construction::Levels`, which counts its levels from the model's cube.
    pub fn headroom_for(&self, input_triangles: usize) -> u32 {
        let roots = match self.domain {
            Domain::Volume => 6.0,
            Domain::HeightField => 2.0,
        };
        match self.construction {
            Construction::LeafTriangles(leaf)
                if input_triangles as f64 * (self.simplify.coarsest_share as f64)
                    < roots * leaf as f64 =>
            {
                self.headroom
            }
            _ => 0,
        }
    }

    /// The defaults for a domain: its leaf size, and for height fields border chains free to
    /// shorten (`SimplifySettings::keep_borders`, ARCHITECTURE.md "Lock rule").
    pub fn for_domain(domain: Domain) -> BuildConfig {
        BuildConfig {
            construction: Construction::LeafTriangles(domain.default_leaf_triangles()),
            threads: None,
            lattice_bits: 20,
            // One doubling: `dim` levels above the model's cube, enough for the coarsest cut of
            // every test scan to reach `COARSEST_SHARE` (issue 46).
            headroom: 1,
            domain,
            memory: None,
            codec: PatchCodec::Coded,
            position_bits: POSITION_BITS,
            textures: None,
            texture_encoding: tessera_core::texture::PageEncoding::Bc1,
            simplify: SimplifySettings {
                keep_borders: domain == Domain::Volume,
                coarsest_share: COARSEST_SHARE,
                ..SimplifySettings::default()
            },
        }
    }
}

impl Default for BuildConfig {
    /// `for_domain(Domain::Volume)`.
    fn default() -> Self {
        BuildConfig::for_domain(Domain::Volume)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("the mesh has no triangles")]
    EmptyMesh,
    #[error("vertex {index} has a non-finite coordinate")]
    NonFinite { index: usize },
    #[error("triangle {index} references vertex {vertex}, but the mesh has {count} vertices")]
    IndexOutOfRange {
        index: usize,
        vertex: u32,
        count: usize,
    },
    #[error(
        "triangle {index} uses vertex {vertex} twice: weld the mesh first \
         (tessera_preprocess::import::weld drops such triangles)"
    )]
    RepeatedVertex { index: usize, vertex: u32 },
    #[error(
        "the model spans {extent:e} units along axis {axis}; at most {MAX_EXTENT:e} \
         (bounds are stored in f32 relative to the model)"
    )]
    TooLarge { axis: usize, extent: f64 },
    #[error("invalid configuration: {0}")]
    Config(String),
    #[error(transparent)]
    Repository(#[from] RepositoryError),
    #[error(transparent)]
    Conformity(#[from] crate::simplify::ConformityError),
    #[error(transparent)]
    Checkpoint(#[from] crate::checkpoint::CheckpointError),
    /// A texture of the input that cannot be made into pages (unreadable, not PNG or JPEG,
    /// corrupt, too large), or bands that do not fit the textures.
    #[error("texture {name:?}: {reason}")]
    Texture { name: String, reason: String },
    #[error("temporary files in {dir}: {source}")]
    Temporary {
        dir: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// What a build did, for `--json` and the benchmark.
#[derive(Clone, Debug, Default)]
pub struct BuildSummary {
    pub input_triangles: usize,
    pub input_vertices: usize,
    pub tetrahedra: usize,
    pub leaves: usize,
    pub diamonds: usize,
    pub depth: u16,
    pub patch_triangles: usize,
    pub locked_vertices: usize,
    /// Diamond simplifications redone after a conflict with their level's batch.
    pub resimplified_diamonds: usize,
    pub root_error: f64,
    /// Model units per position step on each axis (`Header::position_step`).
    pub position_step: [f64; 3],
    /// Half the diagonal of one position step: how far a stored vertex may lie from its input
    /// position. Added to every diamond's own error before saturation.
    pub quantisation_error: f64,
    pub repository_bytes: u64,
    pub seconds: f64,
    /// (stage, seconds) in order.
    pub stages: Vec<(&'static str, f64)>,
    /// The texture pages written, where the input has textures.
    pub textures: Option<TexturePagesSummary>,
}

/// The texture pages a build wrote (`texture::PageMaker`).
#[derive(Clone, Debug, Default)]
pub struct TexturePagesSummary {
    pub encoding: tessera_core::texture::PageEncoding,
    pub pages: u32,
    /// Bytes of the pages (`pages × encoding.page_bytes()`).
    pub page_bytes: u64,
    /// PSNR in dB of every page's stored finest mip, decoded, against its texels as cut, over
    /// the colour channels of all pages together (∞: lossless).
    pub psnr_db: f64,
}
