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

use std::collections::{HashMap, HashSet};

use rayon::prelude::*;
use tessera_core::cut::{diamond_rhos, restrict_rhos, select_stateless, select_top_down};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::format::NO_INDEX;
use tessera_core::repository::reader::Repository;
use tessera_core::repository::{Header, RepositoryError};

use crate::border_loops::{edge_key, BorderLoops};
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
        .map(|i| {
            let patch = repo.patch(i)?;
            let patch = patch.view();
            let ids: Vec<u32> = patch.global_ids().collect();
            Ok(patch
                .triangles()
                .map(|t| t.map(|l| ids[l as usize]))
                .collect())
        })
        .collect()
}

/// Global ids whose quantised position is not the same in every patch that stores them.
pub fn position_mismatches(repo: &Repository) -> Result<usize, RepositoryError> {
    // Keyed by the ids the patches hold, not sized by the header's vertex count: a crafted
    // header cannot make this allocate more than the file's contents.
    let mut position: HashMap<u32, ([u32; 3], bool)> = HashMap::new();
    for i in 0..repo.tets().len() {
        let patch = repo.patch(i)?;
        let patch = patch.view();
        for (local, id) in patch.global_ids().enumerate() {
            let q = patch.position(local);
            let (stored, mismatched) = position.entry(id).or_insert((q, false));
            *mismatched |= *stored != q;
        }
    }
    Ok(position.values().filter(|(_, m)| *m).count())
}

/// Sorted (edge, use count) of a triangle set.
fn edge_counts<'a>(triangles: impl Iterator<Item = &'a [u32; 3]>) -> Vec<(u64, u32)> {
    let mut keys: Vec<u64> = triangles
        .flat_map(|t| {
            [
                edge_key(t[0], t[1]),
                edge_key(t[1], t[2]),
                edge_key(t[2], t[0]),
            ]
        })
        .collect();
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
    patches: &[Vec<[u32; 3]>],
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
pub struct CutChecker<'p> {
    patches: &'p [Vec<[u32; 3]>],
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

impl<'p> CutChecker<'p> {
    /// Prepares the check of `repo`'s cuts; `patches` from `decode_all_patches`.
    pub fn new(repo: &Repository, patches: &'p [Vec<[u32; 3]>]) -> CutChecker<'p> {
        let tets = repo.tets();
        // The input's edges: the leaves hold exactly the input triangles.
        let reference = edge_counts(
            (0..tets.len())
                .filter(|&i| tets[i].first_child == NO_INDEX)
                .flat_map(|i| patches[i].iter()),
        );
        let input_border: HashSet<u64> = reference
            .iter()
            .filter(|(_, n)| *n == 1)
            .map(|(k, _)| *k)
            .collect();
        let loops = BorderLoops::from_border(
            (0..tets.len())
                .filter(|&i| tets[i].first_child == NO_INDEX)
                .flat_map(|i| patches[i].iter()),
            |a, b| input_border.contains(&edge_key(a, b)),
        );
        let vertex_count = patches
            .iter()
            .flatten()
            .flatten()
            .max()
            .map_or(0, |&v| v as usize + 1);
        let input_nonmanifold: HashSet<u64> = reference
            .iter()
            .filter(|(_, n)| *n > 2)
            .map(|(k, _)| *k)
            .collect();
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
        let patches = self.patches;
        let triangles: usize = cut.iter().map(|&i| patches[i as usize].len()).sum();
        let edges = edge_counts(cut.iter().flat_map(|&i| patches[i as usize].iter()));
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
            for t in cut.iter().flat_map(|&i| patches[i as usize].iter()) {
                for &v in t {
                    used[v as usize] = true;
                }
            }
            let is_used = |v: u32| used.get(v as usize).copied().unwrap_or(false);
            cracks = cut
                .iter()
                .flat_map(|&i| patches[i as usize].iter())
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

/// The same check for the given eyes (any position, any metric: a camera's own near distance
/// and field of view) at every tolerance of `tolerances`; `worst` names the index into `eyes`.
pub fn check_cuts_at(
    repo: &Repository,
    patches: &[Vec<[u32; 3]>],
    eyes: &[CheckEye],
    tolerances: &[f32],
) -> CheckReport {
    check_cuts_restricted(repo, patches, eyes, tolerances, None)
}

/// `check_cuts_at` with the cut rule using ρ'(D) = may_refine(D) ? ρ(D) : 0 where `may_refine`
/// flag words are given (`tessera_core::cut`; closed downwards, as streaming keeps them).
pub fn check_cuts_restricted(
    repo: &Repository,
    patches: &[Vec<[u32; 3]>],
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
    // Patches were parsed by `decode_all_patches`, so this cannot fail on a valid repository.
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
