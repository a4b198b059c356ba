//! The cluster-DAG peer: meshoptimizer's clusterlod (`meshopt::clod_build`, its default
//! rasterisation config with 32-triangle clusters in groups of 8: `DagSettings`, the fewest
//! triangles at equal dense max error; 128 in groups of 16 before 2026-12-07) — the
//! Nanite-style continuous LOD over a DAG of cluster groups — with the cut chosen per frame on
//! the CPU and drawn in one call.
//!
//! - Rule (clusterlod.h): a cluster of group g is drawn iff ρ(g.simplified) > τ (its group
//!   would be too coarse once simplified) and, unless it is original geometry, ρ(groups[
//!   refined].simplified) ≤ τ (the group it was simplified from may be coarsened). In our
//!   words: own error ≤ τ < parent error. ρ projects a group's bounds like our ρ:
//!   error · K / max(|centre − eye| − radius, near) (`ScreenSpaceMetric::rho`); clusterlod
//!   makes these bounds monotone along the DAG, so the cut is consistent.
//! - Culling, as our renderer culls patches: a cluster whose own sphere
//!   (`ClodCluster::bounds`, for culling) is outside the frustum, or — when back faces are not
//!   drawn (`Faces::Front`, as our default frame) — whose triangles all face away
//!   (`meshopt::compute_cluster_bounds`'s normal cone, the apex test), is not drawn; the
//!   rasteriser draws the faces asked for.
//! - Drawing: the selected clusters' triangles are gathered and uploaded every frame
//!   (`FullMeshRenderer::set_triangles`); the upload's CPU time is reported apart from the
//!   selection's (`Subject::upload_ms`; the wall time includes both).

use std::time::Instant;

use anyhow::Context;
use tessera_core::cull::dot;
use tessera_core::metric::{center_minus_eye, ScreenSpaceMetric};
use tessera_runtime::camera::Camera;
use tessera_runtime::faces::Faces;
use tessera_runtime::gpu::full_mesh::FullMeshRenderer;
use tessera_runtime::gpu::{FramePhases, GpuContext};
use tessera_runtime::measure::Surface;

use super::peer_mesh::PeerMesh;
use crate::subject::{waited_ms, Drawn, Subject};

/// The settings of `clod_build` the bench may change (`tessera bench --dag`); every other
/// field of `clodConfig` is `clod_default_config`'s. `Default` is the setting that drew the
/// fewest triangles at equal dense max error in the sweep of BENCHMARKS.md ("The cluster
/// DAG's settings"): 32-triangle clusters in groups of 8 (groups of ~256 triangles, against
/// `clod_default_config(128)`'s ~2,048), 0.60–0.79x its triangles over 0.5–45 px on the
/// lion head, bear and bunny (geometric mean; up to 1.11x at a few fine levels). Permissive
/// mode, the sloppy fallback and edge limits changed no triangle on welded scans without
/// attributes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DagSettings {
    /// Triangles per cluster (`max_triangles`, 4–256; `max_vertices` the same,
    /// `min_triangles` a third): smaller clusters, a finer cut.
    pub cluster_triangles: usize,
    /// Clusters per group (`partition_size`, ≥ 2, a target: groups may be a third larger):
    /// the unit that is simplified together, its borders locked.
    pub partition_size: usize,
    /// `simplify_permissive`: meshopt's permissive mode (collapses across attribute seams
    /// and complex topology), else regular simplification.
    pub permissive: bool,
    /// `simplify_fallback_sloppy`: a group that regular (or permissive) simplification cannot
    /// halve is simplified sloppily, its error doubled (`simplify_error_factor_sloppy`).
    pub fallback_sloppy: bool,
    /// `simplify_ratio` (0–1): the share of a group's triangles its simplification aims for.
    pub ratio: f32,
    /// `simplify_error_edge_limit` (≥ 0; 0: off): a group's error at most this times its
    /// longest (short) edge.
    pub edge_limit: f32,
}

impl Default for DagSettings {
    fn default() -> DagSettings {
        DagSettings {
            cluster_triangles: 32,
            partition_size: 8,
            permissive: true,
            fallback_sloppy: true,
            ratio: 0.5,
            edge_limit: 0.0,
        }
    }
}

impl DagSettings {
    /// Reads `key=value` pairs separated by `;` or `/` over the default (`""`: the default):
    /// `triangles=N`, `partition=N`, `permissive=true|false`, `sloppy=true|false`,
    /// `ratio=X`, `edge-limit=X`.
    pub fn parse(text: &str) -> Result<DagSettings, String> {
        let mut s = DagSettings::default();
        for pair in text
            .split([';', '/'])
            .map(str::trim)
            .filter(|p| !p.is_empty())
        {
            let (key, value) = pair
                .split_once('=')
                .ok_or_else(|| format!("{pair:?}: expected key=value"))?;
            let bad = |e: &dyn std::fmt::Display| format!("{key}={value}: {e}");
            match key.trim() {
                "triangles" => s.cluster_triangles = value.parse().map_err(|e| bad(&e))?,
                "partition" => s.partition_size = value.parse().map_err(|e| bad(&e))?,
                "permissive" => s.permissive = value.parse().map_err(|e| bad(&e))?,
                "sloppy" => s.fallback_sloppy = value.parse().map_err(|e| bad(&e))?,
                "ratio" => s.ratio = value.parse().map_err(|e| bad(&e))?,
                "edge-limit" => s.edge_limit = value.parse().map_err(|e| bad(&e))?,
                other => {
                    return Err(format!(
                        "unknown key {other:?} (triangles, partition, permissive, sloppy, ratio, \
                         edge-limit)"
                    ))
                }
            }
        }
        if !(4..=256).contains(&s.cluster_triangles) {
            return Err(format!("triangles={} is not in 4-256", s.cluster_triangles));
        }
        if s.partition_size < 2 {
            return Err(format!("partition={} is under 2", s.partition_size));
        }
        if !(s.ratio > 0.0 && s.ratio < 1.0) {
            return Err(format!("ratio={} is not in (0, 1)", s.ratio));
        }
        if !(s.edge_limit >= 0.0 && s.edge_limit.is_finite()) {
            return Err(format!(
                "edge-limit={} is not a finite number >= 0",
                s.edge_limit
            ));
        }
        Ok(s)
    }

    /// clusterlod's config: `clod_default_config(cluster_triangles)` with these settings.
    pub fn config(&self) -> meshopt::ClodConfig {
        meshopt::ClodConfig {
            partition_size: self.partition_size,
            simplify_permissive: self.permissive,
            simplify_fallback_sloppy: self.fallback_sloppy,
            simplify_ratio: self.ratio,
            simplify_error_edge_limit: self.edge_limit,
            ..meshopt::clod_default_config(self.cluster_triangles)
        }
    }
}

impl std::fmt::Display for DagSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "triangles={};partition={};permissive={};sloppy={};ratio={};edge-limit={}",
            self.cluster_triangles,
            self.partition_size,
            self.permissive,
            self.fallback_sloppy,
            self.ratio,
            self.edge_limit
        )
    }
}

/// A sphere with an error, relative to the repository origin (clusterlod's `clodBounds`).
#[derive(Clone, Copy, Debug)]
struct Bounds {
    centre: [f32; 3],
    radius: f32,
    /// Model units; `f32::MAX` for a group that is never simplified.
    error: f32,
}

impl From<meshopt::ClodBounds> for Bounds {
    fn from(b: meshopt::ClodBounds) -> Bounds {
        Bounds {
            centre: b.center,
            radius: b.radius,
            error: b.error,
        }
    }
}

/// Culling volumes of a cluster.
#[derive(Clone, Copy, Debug)]
struct Cull {
    centre: [f32; 3],
    radius: f32,
    cone_apex: [f32; 3],
    cone_axis: [f32; 3],
    /// ≥ 1: the cone never culls.
    cone_cutoff: f32,
}

#[derive(Clone, Copy, Debug)]
struct Cluster {
    /// Its triangles: `triangles[first..first + count]`.
    first: u32,
    count: u32,
    /// The bounds it was simplified to (error 0 for original geometry).
    own: Bounds,
    /// Its group's simplified bounds: beyond them the cluster is replaced by coarser ones.
    parent: Bounds,
    cull: Cull,
}

/// What `build` made, for the report.
#[derive(Clone, Copy, Debug)]
pub struct DagStats {
    pub clusters: usize,
    pub groups: usize,
    /// DAG levels (the deepest group's depth + 1).
    pub levels: usize,
    pub seconds: f64,
    /// The settings it was built with.
    pub settings: DagSettings,
}

/// The DAG as built: every cluster's triangles, bounds and culling volumes.
pub struct Dag {
    clusters: Vec<Cluster>,
    triangles: Vec<[u32; 3]>,
    pub stats: DagStats,
}

/// Runs `clod_build` on the peers' positions with `settings` and keeps what the cut rule
/// needs.
pub fn build(mesh: &PeerMesh, settings: &DagSettings) -> Dag {
    let start = Instant::now();
    let adapter = mesh.vertex_adapter();
    let clod_mesh = meshopt::ClodMesh::new(mesh.indices(), &adapter);
    let mut groups: Vec<meshopt::ClodGroup> = Vec::new();
    let mut clusters = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    meshopt::clod_build(settings.config(), &clod_mesh, |group, cs| {
        for c in cs {
            let own = if c.refined < 0 {
                Bounds {
                    error: 0.0,
                    ..Bounds::from(c.bounds)
                }
            } else {
                Bounds::from(groups[c.refined as usize].simplified)
            };
            let b = meshopt::compute_cluster_bounds(c.indices, &adapter);
            clusters.push(Cluster {
                first: triangles.len() as u32,
                count: (c.indices.len() / 3) as u32,
                own,
                parent: Bounds::from(group.simplified),
                cull: Cull {
                    centre: c.bounds.center,
                    radius: c.bounds.radius,
                    cone_apex: b.cone_apex,
                    cone_axis: b.cone_axis,
                    cone_cutoff: b.cone_cutoff,
                },
            });
            triangles.extend(c.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]));
        }
        groups.push(group);
        groups.len() as i32 - 1
    });
    let stats = DagStats {
        clusters: clusters.len(),
        groups: groups.len(),
        levels: groups
            .iter()
            .map(|g| g.depth as usize + 1)
            .max()
            .unwrap_or(0),
        seconds: start.elapsed().as_secs_f64(),
        settings: *settings,
    };
    Dag {
        clusters,
        triangles,
        stats,
    }
}

impl Dag {
    /// The clusters the rule draws for `eye_local` (the eye relative to the repository origin)
    /// at `tau` pixels of `metric`, without culling: own error ≤ τ < parent error, each
    /// projected from its group's bounds (the module comment). The frame's selection is these
    /// clusters less the culled ones; the dense error pass measures all of them.
    pub fn cut(&self, eye_local: [f32; 3], metric: &ScreenSpaceMetric, tau: f32) -> Vec<u32> {
        (0..self.clusters.len() as u32)
            .filter(|&c| drawn(&self.clusters[c as usize], eye_local, metric, tau))
            .collect()
    }

    /// The triangles of `clusters` (indices into the peers' vertices), in order.
    pub fn triangles_of(&self, clusters: &[u32]) -> Vec<[u32; 3]> {
        clusters
            .iter()
            .flat_map(|&c| {
                let c = &self.clusters[c as usize];
                &self.triangles[c.first as usize..(c.first + c.count) as usize]
            })
            .copied()
            .collect()
    }
}

/// The rule: `c` is drawn at `tau` for `eye_local` iff ρ(own) ≤ τ < ρ(parent).
fn drawn(c: &Cluster, eye_local: [f32; 3], metric: &ScreenSpaceMetric, tau: f32) -> bool {
    let rho = |b: &Bounds| metric.rho(b.error, center_minus_eye(b.centre, eye_local), b.radius);
    rho(&c.own) <= tau && tau < rho(&c.parent)
}

pub struct ClusterDag<'m> {
    mesh: &'m PeerMesh,
    dag: Dag,
    renderer: FullMeshRenderer,
    origin: [f64; 3],
    faces: Faces,
    /// The last frame's cut: its triangles and cluster count.
    selected: Vec<[u32; 3]>,
    selected_clusters: u64,
    /// CPU milliseconds of the last submit's upload.
    last_upload_ms: f64,
}

impl<'m> ClusterDag<'m> {
    /// A renderer over the peers' vertices (`size`, drawing `faces`) that draws a cut of `dag`
    /// per frame; `origin`: the repository's, the frame of the DAG's bounds.
    pub fn new(
        ctx: &GpuContext,
        mesh: &'m PeerMesh,
        dag: Dag,
        origin: [f64; 3],
        size: (u32, u32),
        faces: Faces,
    ) -> anyhow::Result<ClusterDag<'m>> {
        let renderer =
            FullMeshRenderer::new(ctx, &mesh.positions, &mesh.triangles, origin, size, faces)
                .context("uploading the cluster DAG's vertices")?;
        Ok(ClusterDag {
            mesh,
            dag,
            renderer,
            origin,
            faces,
            selected: Vec::new(),
            selected_clusters: 0,
            last_upload_ms: 0.0,
        })
    }

    pub fn stats(&self) -> DagStats {
        self.dag.stats
    }

    /// The DAG it cuts.
    pub fn dag(&self) -> &Dag {
        &self.dag
    }

    /// The cut for `camera` at `tau` (the rule and culling of the module comment) into
    /// `self.selected`.
    fn select(&mut self, camera: &Camera, tau: f32) {
        let metric = camera.metric();
        let volume = camera.view_volume();
        let eye = camera.eye_local(self.origin);
        self.selected.clear();
        self.selected_clusters = 0;
        for c in &self.dag.clusters {
            if !drawn(c, eye, &metric, tau) {
                continue;
            }
            if !volume.sphere_visible(center_minus_eye(c.cull.centre, eye), c.cull.radius) {
                continue;
            }
            if self.faces == Faces::Front && c.cull.cone_cutoff < 1.0 {
                let to_apex = center_minus_eye(c.cull.cone_apex, eye);
                let length = dot(to_apex, to_apex).sqrt();
                if dot(to_apex, c.cull.cone_axis) >= c.cull.cone_cutoff * length {
                    continue;
                }
            }
            let range = c.first as usize..(c.first + c.count) as usize;
            self.selected.extend_from_slice(&self.dag.triangles[range]);
            self.selected_clusters += 1;
        }
    }
}

impl Subject for ClusterDag<'_> {
    fn name(&self) -> &'static str {
        "cluster_dag"
    }

    fn submit(&mut self, ctx: &GpuContext, camera: &Camera, tau: f32) -> anyhow::Result<f64> {
        let start = Instant::now();
        self.select(camera, tau);
        let upload = Instant::now();
        self.renderer.set_triangles(ctx, &self.selected)?;
        self.last_upload_ms = upload.elapsed().as_secs_f64() * 1e3;
        self.renderer.render(ctx, camera, false);
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }

    fn phased_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<FramePhases> {
        let select_ms = waited_ms(ctx, || {
            self.select(camera, tau);
            Ok(self.renderer.set_triangles(ctx, &self.selected)?)
        })?;
        let raster_ms = waited_ms(ctx, || {
            self.renderer.render(ctx, camera, false);
            Ok(())
        })?;
        Ok(FramePhases {
            select_ms,
            raster_ms,
        })
    }

    fn gpu_ms(&self, ctx: &GpuContext) -> anyhow::Result<Option<f64>> {
        Ok(self.renderer.read_gpu_ms(ctx)?)
    }

    fn upload_ms(&self) -> f64 {
        self.last_upload_ms
    }

    fn measured_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<(Drawn, image::RgbaImage)> {
        self.select(camera, tau);
        self.renderer.set_triangles(ctx, &self.selected)?;
        self.renderer.render(ctx, camera, true);
        let drawn = Drawn {
            patches: self.selected_clusters,
            triangles: self.selected.len() as u64,
            level: None,
        };
        Ok((drawn, self.renderer.read_image(ctx)?))
    }

    fn surface(&self) -> Surface<'_> {
        Surface {
            positions: &self.mesh.positions_f64,
            triangles: &self.selected,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::DagSettings;

    /// `--dag` text over the default, and back through `Display`.
    #[test]
    fn settings_parse_over_the_default_and_print_back() {
        let check = |text: &str, expected: DagSettings| {
            let s = DagSettings::parse(text).unwrap_or_else(|e| panic!("{text}: {e}"));
            assert_eq!(s, expected, "{text}");
            assert_eq!(DagSettings::parse(&s.to_string()), Ok(s), "{s}");
        };
        let d = DagSettings::default();
        check("", d);
        check(
            "triangles=64; partition=8",
            DagSettings {
                cluster_triangles: 64,
                partition_size: 8,
                ..d
            },
        );
        check(
            "permissive=false/sloppy=false/ratio=0.7/edge-limit=1",
            DagSettings {
                permissive: false,
                fallback_sloppy: false,
                ratio: 0.7,
                edge_limit: 1.0,
                ..d
            },
        );
        for bad in [
            "triangles",
            "leaves=3",
            "triangles=2",
            "triangles=300",
            "partition=1",
            "ratio=1",
            "permissive=yes",
            "edge-limit=-1",
        ] {
            assert!(DagSettings::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(d.config().max_triangles, d.cluster_triangles);
    }
}
