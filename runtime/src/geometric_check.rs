//! The exact crack check (no pixels): extract the cut for many eyes and tolerances and compare
//! its edges, by global vertex id, with the input's (the τ = 0 cut, i.e. every leaf).
//!
//! - crack: an edge used by one triangle of the cut that is not a border edge of the input,
//!   nor an input border chain simplified (`border_loops.rs`: height fields shorten theirs);
//! - non-manifold introduced: an edge used by more than two triangles that the input did not
//!   have as such;
//! - monotonicity violation: a diamond DAG edge with ρ(parent) < ρ(child) in f32, as the GPU
//!   computes it;
//! - traversal mismatch: the stateless scan and the top-down descent select different sets;
//! - position mismatch: a global id whose quantised position differs between two patches (a
//!   shared vertex must be bit-identical wherever it is stored, or the picture cracks even
//!   though the ids match).

use std::collections::HashSet;

use rayon::prelude::*;
use tessera_core::cut::{diamond_rhos, restrict_rhos, select_stateless, select_top_down};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::format::NO_INDEX;
use tessera_core::repository::reader::Repository;
use tessera_core::repository::{Header, RepositoryError};

use crate::border_loops::{edge_key, BorderLoops};
use crate::cut_patches::{decode, merged_runs, pass_of, passes, CutPatches, Pacer, PASS_BYTES};
use crate::views::check_views;

/// What to check.
#[derive(Clone, Debug)]
pub struct CheckConfig {
    /// Number of eyes (around and inside the model).
    pub views: usize,
    /// Pixel tolerances τ.
    pub tolerances: Vec<f32>,
    /// Viewport height in pixels (the error metric depends on it, not on the width).
    pub viewport_height: u32,
    /// Vertical field of view, degrees.
    pub fov_degrees: f64,
}

impl Default for CheckConfig {
    fn default() -> Self {
        CheckConfig {
            views: 64,
            tolerances: vec![0.5, 1.0, 2.0, 4.0, 8.0],
            viewport_height: 1080,
            fov_degrees: 60.0,
        }
    }
}

/// Totals over every cut.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CheckReport {
    pub cuts_checked: usize,
    pub cracks: usize,
    pub nonmanifold_introduced: usize,
    pub monotonicity_violations: usize,
    pub traversal_mismatches: usize,
    /// Global ids stored with two different positions (counted once per id).
    pub position_mismatches: usize,
    pub min_triangles: usize,
    pub max_triangles: usize,
    /// (view, τ, cracks) of the cut with the most cracks, if any has one.
    pub worst: Option<(usize, String, usize)>,
}

/// Each simplex's triangles as global vertex ids (degenerate strip triangles dropped).
pub fn decode_all_patches(repo: &Repository) -> Result<Vec<Vec<[u32; 3]>>, RepositoryError> {
    (0..repo.tets().len())
        .into_par_iter()
        .map(|i| decode(repo, i))
        .collect()
}

/// Global ids whose quantised position is not the same in every patch that stores them.
pub fn position_mismatches(repo: &Repository) -> Result<usize, RepositoryError> {
    position_mismatches_within(repo, PASS_BYTES)
}

/// `position_mismatches`, each pass over the patches gathering at most about `pass_bytes` of
/// (id, position) records (ids split between passes by hash; then sorted by id).
pub fn position_mismatches_within(
    repo: &Repository,
    pass_bytes: usize,
) -> Result<usize, RepositoryError> {
    // Sized by the tet table's vertex counts, not by the header's: a crafted header cannot
    // make this allocate more than the file's contents.
    let records: u64 = repo.tets().iter().map(|t| t.vertex_count as u64).sum();
    let passes = passes(records, std::mem::size_of::<(u32, [u32; 3])>(), pass_bytes);
    let mut mismatched = 0;
    for pass in 0..passes {
        // Ids spread evenly between passes (a hash): sized for one pass's share, plus slack.
        let share = records / passes;
        let mut stored: Vec<(u32, [u32; 3])> = Vec::with_capacity((share + share / 8) as usize);
        let pacer = Pacer::new(repo);
        for i in 0..repo.tets().len() {
            let patch = repo.patch(i)?;
            let patch = patch.view();
            for (local, id) in patch.global_ids().enumerate() {
                if pass_of(id as u64, passes) == pass {
                    stored.push((id, patch.position(local)));
                }
            }
            pacer.read(i);
        }
        repo.release_pages();
        stored.sort_unstable();
        mismatched += stored
            .chunk_by(|a, b| a.0 == b.0)
            .filter(|run| run.iter().any(|r| r.1 != run[0].1))
            .count();
    }
    Ok(mismatched)
}

/// Sorted (edge, use count) of a triangle set.
fn edge_counts<'a>(triangles: impl Iterator<Item = &'a [u32; 3]>) -> Vec<(u64, u32)> {
    counted(
        triangles
            .flat_map(|t| {
                [
                    edge_key(t[0], t[1]),
                    edge_key(t[1], t[2]),
                    edge_key(t[2], t[0]),
                ]
            })
            .collect(),
    )
}

/// Sorted (key, how many times) of `keys`.
fn counted(mut keys: Vec<u64>) -> Vec<(u64, u32)> {
    keys.sort_unstable();
    let mut out: Vec<(u64, u32)> = Vec::new();
    for k in keys {
        match out.last_mut() {
            Some((last, n)) if *last == k => *n += 1,
            _ => out.push((k, 1)),
        }
    }
    out
}

/// One eye of the check and the projection its ρ is computed with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckEye {
    /// Model-space eye.
    pub eye: [f64; 3],
    /// K and the near distance of ρ (`Camera::metric` for a camera).
    pub metric: ScreenSpaceMetric,
}

/// Runs the check; `patches` from `decode_all_patches`. The eyes are `check_views` (about one
/// in eight inside the model's box), with the metric of `config` and a near distance of 1e-4 of
/// the model's diagonal.
pub fn check_cuts(
    repo: &Repository,
    patches: &(impl CutPatches + ?Sized),
    config: &CheckConfig,
) -> CheckReport {
    let header = repo.header();
    let metric = check_metric(header, config);
    let eyes: Vec<CheckEye> = check_views(header.bbox_min, header.bbox_max, config.views)
        .into_iter()
        .map(|eye| CheckEye { eye, metric })
        .collect();
    check_cuts_at(repo, patches, &eyes, &config.tolerances)
}

/// The check's projection: `config`'s viewport and field of view, a near distance of 1e-4 of
/// the model's diagonal.
pub fn check_metric(header: &Header, config: &CheckConfig) -> ScreenSpaceMetric {
    let size = (0..3)
        .map(|i| (header.bbox_max[i] - header.bbox_min[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    ScreenSpaceMetric::new(
        config.viewport_height,
        config.fov_degrees,
        (size * 1e-4).max(1e-30),
    )
}

/// The input's edges and borders, against which any cut's triangles are checked.
pub struct CutChecker<'p, P: CutPatches + ?Sized> {
    patches: &'p P,
    input_border: HashSet<u64>,
    input_nonmanifold: HashSet<u64>,
    loops: BorderLoops,
    vertex_count: usize,
}

/// What one cut showed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CutFindings {
    /// Edges used by one triangle of the cut that are no border of the input (nor a simplified
    /// chain of one, for inputs whose border chains are free).
    pub cracks: usize,
    /// Edges used by more than two triangles of the cut that the input has at most twice.
    pub nonmanifold_introduced: usize,
    /// Triangles of the cut.
    pub triangles: usize,
}

impl<'p, P: CutPatches + ?Sized> CutChecker<'p, P> {
    /// Prepares the check of `repo`'s cuts; `patches` from `decode_all_patches`, or
    /// `RepositoryPatches` to decode them as the cuts reach them.
    pub fn new(repo: &Repository, patches: &'p P) -> CutChecker<'p, P> {
        Self::with_pass_bytes(repo, patches, PASS_BYTES)
    }

    /// `new`, the input's edges counted in passes of at most about `pass_bytes` of edge keys
    /// each (edges split between passes by hash).
    pub fn with_pass_bytes(repo: &Repository, patches: &'p P, pass_bytes: usize) -> Self {
        let tets = repo.tets();
        // The input's edges: the leaves hold exactly the input triangles.
        let leaves: Vec<usize> = (0..tets.len())
            .filter(|&i| tets[i].first_child == NO_INDEX)
            .collect();
        let leaf_triangles: u64 = leaves.iter().map(|&i| tets[i].triangle_count as u64).sum();
        let passes = passes(3 * leaf_triangles, std::mem::size_of::<u64>(), pass_bytes);
        let mut input_border = HashSet::new();
        let mut input_nonmanifold = HashSet::new();
        let mut vertex_count = 0;
        // Each pass: the pass's edge keys of a few chunks of leaves, each chunk's sorted, then
        // merged and counted (no concatenation: the pass holds its keys once).
        let chunk = leaves.len().div_ceil(16).max(1);
        for pass in 0..passes {
            let chunks: Vec<(Vec<u64>, usize)> = leaves
                .par_chunks(chunk)
                .map(|leaves| {
                    let mut keys = Vec::new();
                    let mut most = 0;
                    for &i in leaves {
                        let triangles = patches.triangles(i);
                        let m = triangles
                            .iter()
                            .flatten()
                            .max()
                            .map_or(0, |&v| v as usize + 1);
                        most = most.max(m);
                        keys.extend(
                            triangle_edge_keys(&triangles).filter(|&k| pass_of(k, passes) == pass),
                        );
                    }
                    keys.sort_unstable();
                    keys.shrink_to_fit();
                    (keys, most)
                })
                .collect();
            patches.release();
            let (lists, most): (Vec<Vec<u64>>, Vec<usize>) = chunks.into_iter().unzip();
            vertex_count = most.into_iter().fold(vertex_count, usize::max);
            merged_runs(&lists, |k, n| {
                if n == 1 {
                    input_border.insert(k);
                } else if n > 2 {
                    input_nonmanifold.insert(k);
                }
            });
        }
        let loops = if input_border.is_empty() {
            BorderLoops::from_border(std::iter::empty(), |_, _| false)
        } else {
            let triangles: Vec<[u32; 3]> = leaves
                .iter()
                .flat_map(|&i| {
                    let mut t = patches.triangles(i);
                    t.retain(|t| {
                        [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
                            .iter()
                            .any(|&(a, b)| input_border.contains(&edge_key(a, b)))
                    });
                    t
                })
                .collect();
            patches.release();
            BorderLoops::from_border(triangles.iter(), |a, b| {
                input_border.contains(&edge_key(a, b))
            })
        };
        CutChecker {
            patches,
            input_border,
            input_nonmanifold,
            loops,
            vertex_count,
        }
    }

    /// Checks the cut made of the simplices `cut` (any set: the rule's, a streaming frame's).
    pub fn check(&self, cut: &[u32]) -> CutFindings {
        let cut_triangles: Vec<[u32; 3]> = cut
            .iter()
            .flat_map(|&i| self.patches.triangles(i as usize))
            .collect();
        let triangles = cut_triangles.len();
        let edges = edge_counts(cut_triangles.iter());
        let mut cracks = edges
            .iter()
            .filter(|(k, n)| *n == 1 && !self.input_border.contains(k))
            .count();
        if cracks > 0 && !self.loops.is_empty() {
            // Border edges that are not the input's: simplified border chains, or cracks.
            let candidates: HashSet<u64> = edges
                .iter()
                .filter(|(k, n)| *n == 1 && !self.input_border.contains(k))
                .map(|(k, _)| *k)
                .collect();
            let mut used = vec![false; self.vertex_count];
            for t in &cut_triangles {
                for &v in t {
                    used[v as usize] = true;
                }
            }
            let is_used = |v: u32| used.get(v as usize).copied().unwrap_or(false);
            cracks = cut_triangles
                .iter()
                .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                .filter(|&(a, b)| {
                    candidates.contains(&edge_key(a, b)) && !self.loops.accepts(a, b, &is_used)
                })
                .count();
        }
        let nonmanifold_introduced = edges
            .iter()
            .filter(|(k, n)| *n > 2 && !self.input_nonmanifold.contains(k))
            .count();
        CutFindings {
            cracks,
            nonmanifold_introduced,
            triangles,
        }
    }
}

/// The edge keys of a triangle set, three a triangle.
fn triangle_edge_keys(triangles: &[[u32; 3]]) -> impl Iterator<Item = u64> + '_ {
    triangles.iter().flat_map(|t| {
        [
            edge_key(t[0], t[1]),
            edge_key(t[1], t[2]),
            edge_key(t[2], t[0]),
        ]
    })
}

/// The same check for the given eyes (any position, any metric: a camera's own near distance
/// and field of view) at every tolerance of `tolerances`; `worst` names the index into `eyes`.
pub fn check_cuts_at(
    repo: &Repository,
    patches: &(impl CutPatches + ?Sized),
    eyes: &[CheckEye],
    tolerances: &[f32],
) -> CheckReport {
    check_cuts_restricted(repo, patches, eyes, tolerances, None)
}

/// `check_cuts_at` with the cut rule using ρ'(D) = may_refine(D) ? ρ(D) : 0 where `may_refine`
/// flag words are given (`tessera_core::cut`; closed downwards, as streaming keeps them).
pub fn check_cuts_restricted(
    repo: &Repository,
    patches: &(impl CutPatches + ?Sized),
    eyes: &[CheckEye],
    tolerances: &[f32],
    may_refine: Option<&[u32]>,
) -> CheckReport {
    let tets = repo.tets();
    let diamonds = repo.diamonds();
    let header = repo.header();
    let checker = CutChecker::new(repo, patches);

    let per_view: Vec<CheckReport> = eyes
        .par_iter()
        .enumerate()
        .map(|(view, eye)| {
            let mut rhos = diamond_rhos(diamonds, eye_local(eye.eye, header.origin), &eye.metric);
            if let Some(words) = may_refine {
                restrict_rhos(&mut rhos, words);
            }
            let mut r = CheckReport {
                min_triangles: usize::MAX,
                ..Default::default()
            };
            for (i, d) in diamonds.iter().enumerate() {
                for &p in &d.parents[..d.parent_count as usize] {
                    // Anything but "parent ≥ child" counts, NaN included.
                    let ordered = rhos[p as usize].partial_cmp(&rhos[i]);
                    if !matches!(
                        ordered,
                        Some(std::cmp::Ordering::Greater | std::cmp::Ordering::Equal)
                    ) {
                        r.monotonicity_violations += 1;
                    }
                }
            }
            for &tau in tolerances {
                let cut = select_stateless(tets, &rhos, tau);
                if cut != select_top_down(tets, header.root_tet_count as usize, &rhos, tau) {
                    r.traversal_mismatches += 1;
                }
                let CutFindings {
                    cracks,
                    nonmanifold_introduced,
                    triangles,
                } = checker.check(&cut);
                r.nonmanifold_introduced += nonmanifold_introduced;
                r.cracks += cracks;
                if cracks > r.worst.as_ref().map_or(0, |w| w.2) {
                    r.worst = Some((view, format!("{tau}"), cracks));
                }
                r.cuts_checked += 1;
                r.min_triangles = r.min_triangles.min(triangles);
                r.max_triangles = r.max_triangles.max(triangles);
            }
            patches.release();
            r
        })
        .collect();
    let mut total = CheckReport {
        min_triangles: usize::MAX,
        ..Default::default()
    };
    for r in per_view {
        total.cuts_checked += r.cuts_checked;
        total.cracks += r.cracks;
        total.nonmanifold_introduced += r.nonmanifold_introduced;
        total.monotonicity_violations += r.monotonicity_violations;
        total.traversal_mismatches += r.traversal_mismatches;
        total.min_triangles = total.min_triangles.min(r.min_triangles);
        total.max_triangles = total.max_triangles.max(r.max_triangles);
        if r.worst.as_ref().map_or(0, |w| w.2) > total.worst.as_ref().map_or(0, |w| w.2) {
            total.worst = r.worst;
        }
    }
    if total.cuts_checked == 0 {
        total.min_triangles = 0;
    }
    // Every patch was decoded before (`decode_all_patches`, `RepositoryPatches::new`), so this
    // cannot fail on a valid repository.
    total.position_mismatches = position_mismatches(repo).unwrap_or(usize::MAX);
    total
}

impl CheckReport {
    /// True when nothing is wrong.
    pub fn is_clean(&self) -> bool {
        self.cracks == 0
            && self.nonmanifold_introduced == 0
            && self.monotonicity_violations == 0
            && self.traversal_mismatches == 0
            && self.position_mismatches == 0
    }
}
