//! The dense error pass of the trade-off benchmark (issue 46): every subject's cut measured
//! exactly as `check --errors` measures ours, so that "equal max error" means the same for all.
//!
//! For each subject, at each of the check's eyes (`views::check_views`, `--error-views`, 16 by
//! default: one in eight inside the model's box, the others 0.6 to 6 bounding radii away) and
//! each τ:
//! 1. the triangles the subject selects there with its own rule at the run-time projection
//!    (`check_metric`: ρ = error·k / max(|centre − eye| − radius, near), k from the target's
//!    height and a 60° field of view), WITHOUT culling: visible or not, facing the eye or not;
//!    - ours: the stateless rule over the diamonds (`cut::select_stateless`);
//!    - cluster DAG: own error ≤ τ < parent error over the clusters (`Dag::cut`);
//!    - discrete LODs: the coarsest level within τ at the object's sphere (`level_at`);
//!    - full resolution: the input, error 0 by definition (not measured);
//! 2. measured against the repository's leaves (the input on the position lattice) by
//!    `surface::measure_screen_surface`: a barycentric lattice on every triangle (15 points a
//!    cut triangle, 6 a leaf: `STEPS`, the check's), both directions, each distance less the
//!    quantisation error in pixels at the sample's distance from the eye. Ours is
//!    `measure_screen_cut`, what `check --errors` reports.
//!
//! Per (subject, τ): the triangles (mean over the eyes), the largest error over the eyes and
//! the eye where it is. Deterministic (fixed eyes, no random sampling): measured once, not per
//! timed frame. Cuts a subject draws identically at several τ of one eye (a discrete level,
//! the roots) are measured once. The cuts run in parallel (rayon), each one thread.

use std::collections::HashMap;
use std::time::Instant;

use rayon::prelude::*;
use serde_json::json;
use tessera_bench::peers::cluster_dag::Dag;
use tessera_bench::peers::discrete_lod::{level_at, Level};
use tessera_bench::peers::peer_mesh::PeerMesh;
use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::reader::Repository;
use tessera_core::repository::surface::{
    measure_screen_surface, patch_surface, quantisation_error, PatchSurface,
};
use tessera_runtime::geometric_check::{check_metric, CheckConfig};
use tessera_runtime::views::check_views;

/// Lattice steps a side on each cut triangle and each leaf: `check --errors`'s.
pub const STEPS: (usize, usize) = crate::check_errors::STEPS;

/// A subject whose cuts the pass measures, with what its rule needs.
pub enum Subject<'a> {
    Ours(&'a Repository),
    ClusterDag(&'a Dag, &'a PeerMesh),
    /// The levels and the object's bounding sphere, relative to the repository origin.
    DiscreteLod(&'a [Level], ([f32; 3], f32), &'a PeerMesh),
}

impl Subject<'_> {
    /// The name in the report, as the timed subjects' (`tessera_bench::subject::Subject`).
    pub fn name(&self) -> &'static str {
        match self {
            Subject::Ours(_) => "ours",
            Subject::ClusterDag(..) => "cluster_dag",
            Subject::DiscreteLod(..) => "discrete_lod",
        }
    }

    /// What the subject selects at `eye_local` and `tau`, no culling: our simplices, the
    /// DAG's clusters, or the one discrete level. Equal keys draw equal triangles.
    fn select(&self, eye_local: [f32; 3], metric: &ScreenSpaceMetric, tau: f32) -> Vec<u32> {
        match self {
            Subject::Ours(repo) => {
                let rhos = diamond_rhos(repo.diamonds(), eye_local, metric);
                select_stateless(repo.tets(), &rhos, tau)
            }
            Subject::ClusterDag(dag, _) => dag.cut(eye_local, metric, tau),
            Subject::DiscreteLod(levels, sphere, _) => {
                let errors = levels.iter().map(|l| l.error);
                vec![level_at(errors, *sphere, eye_local, metric, tau) as u32]
            }
        }
    }

    /// The triangles of a selection, in model coordinates (`origin`: the repository's, which
    /// the peers' positions are relative to).
    fn surface(&self, selection: &[u32], origin: [f64; 3]) -> anyhow::Result<PatchSurface> {
        let peer = |mesh: &PeerMesh, triangles: &[[u32; 3]]| PatchSurface {
            positions: mesh
                .positions_f64
                .iter()
                .map(|p| [0, 1, 2].map(|i| p[i] + origin[i]))
                .collect(),
            indices: triangles.as_flattened().to_vec(),
        };
        Ok(match self {
            Subject::Ours(repo) => patch_surface(repo, selection.iter().map(|&t| t as usize))?,
            Subject::ClusterDag(dag, mesh) => peer(mesh, &dag.triangles_of(selection)),
            Subject::DiscreteLod(levels, _, mesh) => {
                peer(mesh, &levels[selection[0] as usize].triangles)
            }
        })
    }
}

/// What to measure.
#[derive(Clone, Debug)]
pub struct DenseSettings {
    /// The check's eyes (`check_views`).
    pub views: usize,
    /// Pixel tolerances τ, one row each.
    pub tolerances: Vec<f32>,
    /// The target's height: τ is in its pixels (60° vertical field of view).
    pub viewport_height: u32,
}

/// One subject at one τ over every eye.
#[derive(Clone, Debug, PartialEq)]
pub struct DenseRow {
    pub tolerance: f32,
    /// Mean over the eyes.
    pub triangles: f64,
    /// The largest error over the eyes (px; infinite where a cut is empty).
    pub max_px: f64,
    /// The eye (index into `check_views`) where `max_px` is.
    pub worst_view: usize,
    /// Each eye's largest error.
    pub max_px_per_view: Vec<f64>,
    /// Points sampled, both directions, every eye (cuts measured once count once per τ).
    pub samples: u64,
}

/// A subject's dense rows, one per τ.
#[derive(Clone, Debug)]
pub struct DenseRows {
    pub name: &'static str,
    pub rows: Vec<DenseRow>,
}

/// The whole pass.
#[derive(Clone, Debug)]
pub struct DensePass {
    pub eyes: Vec<[f64; 3]>,
    pub metric: ScreenSpaceMetric,
    pub subjects: Vec<DenseRows>,
    /// Distinct cuts measured, and the wall seconds of the pass.
    pub cuts_measured: usize,
    pub seconds: f64,
}

/// One measured cut.
#[derive(Clone, Copy, Debug)]
struct Measured {
    triangles: usize,
    max_px: f64,
    samples: u64,
}

/// Measures every subject's cut at every eye and τ of `settings` against `repo`'s leaves
/// (module comment). `on_progress(done, total)` is called as cuts finish.
pub fn measure(
    repo: &Repository,
    subjects: &[Subject<'_>],
    settings: &DenseSettings,
    on_progress: &(dyn Fn(usize, usize) + Sync),
) -> anyhow::Result<DensePass> {
    assert!(settings.views > 0, "the dense pass needs at least one eye");
    let start = Instant::now();
    let h = repo.header();
    let metric = check_metric(
        h,
        &CheckConfig {
            viewport_height: settings.viewport_height,
            ..CheckConfig::default()
        },
    );
    let eyes = check_views(h.bbox_min, h.bbox_max, settings.views);
    let q = quantisation_error(repo);
    let leaves = tessera_core::repository::surface::leaf_surface(repo)?;
    let taus = &settings.tolerances;

    // 1. Every selection (cheap), the distinct ones per (subject, eye) kept.
    let mut keys: Vec<Vec<Vec<usize>>> = Vec::new(); // [subject][eye][τ] → job
    let mut jobs: Vec<(usize, usize, Vec<u32>)> = Vec::new(); // (subject, eye, selection)
    for (s, subject) in subjects.iter().enumerate() {
        let mut per_eye = Vec::new();
        for (v, &eye) in eyes.iter().enumerate() {
            let local = eye_local(eye, h.origin);
            let mut seen: HashMap<Vec<u32>, usize> = HashMap::new();
            let per_tau = taus
                .iter()
                .map(|&tau| {
                    let selection = subject.select(local, &metric, tau);
                    *seen.entry(selection.clone()).or_insert_with(|| {
                        jobs.push((s, v, selection));
                        jobs.len() - 1
                    })
                })
                .collect();
            per_eye.push(per_tau);
        }
        keys.push(per_eye);
    }

    // 2. Each distinct cut measured, in parallel.
    let done = std::sync::atomic::AtomicUsize::new(0);
    let measured: Vec<Measured> = jobs
        .par_iter()
        .map(|(s, v, selection)| {
            let cut = subjects[*s].surface(selection, h.origin)?;
            let m = measure_screen_surface(&cut, &leaves, eyes[*v], &metric, q, STEPS);
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            on_progress(k, jobs.len());
            Ok(Measured {
                triangles: m.triangles,
                max_px: m.max_px,
                samples: m.samples,
            })
        })
        .collect::<anyhow::Result<_>>()?;

    // 3. The rows.
    let subjects = subjects
        .iter()
        .zip(&keys)
        .map(|(subject, per_eye)| DenseRows {
            name: subject.name(),
            rows: taus
                .iter()
                .enumerate()
                .map(|(i, &tau)| {
                    let at = |v: usize| measured[per_eye[v][i]];
                    let per_view: Vec<f64> = (0..eyes.len()).map(|v| at(v).max_px).collect();
                    let worst_view = (0..eyes.len())
                        .max_by(|&a, &b| per_view[a].total_cmp(&per_view[b]).then(b.cmp(&a)))
                        .unwrap_or(0);
                    DenseRow {
                        tolerance: tau,
                        triangles: (0..eyes.len()).map(|v| at(v).triangles as f64).sum::<f64>()
                            / eyes.len() as f64,
                        max_px: per_view[worst_view],
                        worst_view,
                        max_px_per_view: per_view,
                        samples: (0..eyes.len()).map(|v| at(v).samples).sum(),
                    }
                })
                .collect(),
        })
        .collect();
    Ok(DensePass {
        eyes,
        metric,
        subjects,
        cuts_measured: jobs.len(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The dense rows of the full-resolution peer: the input at every τ, error 0 by definition.
pub fn full_resolution_rows(triangles: usize, tolerances: &[f32], views: usize) -> DenseRows {
    DenseRows {
        name: "full_resolution",
        rows: tolerances
            .iter()
            .map(|&tolerance| DenseRow {
                tolerance,
                triangles: triangles as f64,
                max_px: 0.0,
                worst_view: 0,
                max_px_per_view: vec![0.0; views],
                samples: 0,
            })
            .collect(),
    }
}

/// A dense row as JSON (`dense` in each row of `bench --json`).
pub fn row_json(row: &DenseRow) -> serde_json::Value {
    json!({
        "triangles": row.triangles,
        "max_px": finite_or_null(row.max_px),
        "worst_view": row.worst_view,
        "max_px_per_view": row.max_px_per_view.iter().map(|&x| finite_or_null(x)).collect::<Vec<_>>(),
        "samples": row.samples,
    })
}

/// JSON has no infinity: an empty cut's error is null.
fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// The pass's definition and cost, as JSON (`dense` at the top of `bench --json`).
pub fn pass_json(pass: &DensePass) -> serde_json::Value {
    json!({
        "views": pass.eyes.len(),
        "eyes": pass.eyes,
        "metric": {
            "distance": "euclidean",
            "sides": "two-sided",
            "visible_only": false,
            "culling": "none",
            "against": "leaves",
            "sampled": "lower bound",
            "steps": [STEPS.0, STEPS.1],
            "k": pass.metric.k,
            "near": pass.metric.near,
            "as": "check --errors",
        },
        "cuts_measured": pass.cuts_measured,
        "seconds": pass.seconds,
    })
}
