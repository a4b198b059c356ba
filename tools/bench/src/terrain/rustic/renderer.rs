//! RUSTiC at run time (seed 000, chapter 2): ROAM over cluster triangles, then every ROAM
//! triangle replaced by its pre-built cluster.
//!
//! ROAM runs on the cluster levels only (its errors are the clusters' errors, so it never
//! splits below `Rustic::max_level`) with a budget of `triangle budget / mean cluster size`
//! ROAM triangles; the final mesh is the concatenation of the clusters of its leaves. A
//! conforming ROAM triangulation only puts side by side triangles of one level or of adjacent
//! levels, exactly the pairs whose clusters the adaptive merge keeps crack-free.

use std::time::Instant;

use super::Rustic;
use crate::terrain::grid::BinGrid;
use crate::terrain::roam::{Roam, RoamView};

/// What one `RusticRenderer::update` did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RusticFrame {
    /// ROAM triangles (clusters) overlapping the grid.
    pub roam_triangles: usize,
    /// Final triangles: the sub-triangles of those clusters.
    pub triangles: usize,
    /// ROAM's update plus gathering the clusters into the frame's triangle list.
    pub cpu_ms: f64,
}

/// The clusters and the ROAM triangulation over them, kept from frame to frame.
pub struct RusticRenderer {
    rustic: Rustic,
    roam: Roam,
    /// The final triangles of the last update.
    triangles: Vec<[[i32; 2]; 3]>,
}

impl RusticRenderer {
    pub fn new(grid: &BinGrid, rustic: Rustic) -> RusticRenderer {
        assert_eq!(grid.side, rustic.side(), "clusters built for another grid");
        let roam = Roam::new(grid, rustic.errors());
        RusticRenderer {
            rustic,
            roam,
            triangles: Vec::new(),
        }
    }

    /// One frame: ROAM over clusters with budget ⌈triangle_budget / mean cluster size⌉, then
    /// the clusters of its triangles gathered (the copy a renderer would upload).
    pub fn update(
        &mut self,
        grid: &BinGrid,
        view: &RoamView,
        triangle_budget: usize,
    ) -> RusticFrame {
        let start = Instant::now();
        let mean = self.rustic.mean_cluster_triangles().max(1.0);
        let budget = ((triangle_budget as f64 / mean).ceil() as usize).max(2);
        self.roam.update(grid, view, budget);
        let leaves = self.roam.leaves();
        self.triangles.clear();
        for t in &leaves {
            self.triangles.extend_from_slice(self.rustic.cluster(t));
        }
        RusticFrame {
            roam_triangles: leaves.len(),
            triangles: self.triangles.len(),
            cpu_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// The final triangles (sample-point corners, counter-clockwise) of the last update: the
    /// clusters of the ROAM triangles that overlap the grid.
    pub fn triangles(&self) -> Vec<[[i32; 2]; 3]> {
        self.triangles.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::grid::{sample_triangle, vertical_error, VerticalError};
    use crate::terrain::roam::WedgieErrors;
    use crate::terrain::rustic::tests::{check_conforming, rough, Rng};
    use tessera_runtime::camera::{Camera, Z_UP};

    fn orbit(grid: &BinGrid, azimuth: f64, elevation: f64, distance: f64) -> RoamView {
        let (lo, hi) = grid.world_bounds();
        RoamView::from_camera(&Camera::orbit(lo, hi, Z_UP, azimuth, elevation, distance))
    }

    fn error_of(grid: &BinGrid, tris: &[[[i32; 2]; 3]]) -> VerticalError {
        let tris: Vec<_> = tris.iter().map(|&c| sample_triangle(grid, c)).collect();
        vertical_error(grid, &tris)
    }

    /// Plain ROAM (nested wedgies of the full grid) at `budget` triangles.
    fn roam_at(grid: &BinGrid, view: &RoamView, budget: usize) -> (usize, VerticalError) {
        let mut roam = Roam::new(grid, WedgieErrors::from_grid(grid));
        roam.update(grid, view, budget);
        let tris: Vec<_> = roam.leaves().iter().map(|t| t.corners()).collect();
        (tris.len(), error_of(grid, &tris))
    }

    #[test]
    fn every_frame_is_crack_free_from_random_views_and_budgets() {
        let cases = [
            (rough(6, 65, 65, 3), 4),
            (rough(6, 65, 65, 5), 16),
            (rough(7, 129, 129, 4), 32),
        ];
        for (grid, n) in &cases {
            let mut renderer = RusticRenderer::new(grid, Rustic::build(grid, *n));
            let mut rng = Rng(*n as u64);
            let mut most_levels = 0;
            for frame in 0..40 {
                let view = orbit(
                    grid,
                    360.0 * rng.unit(),
                    5.0 + 80.0 * rng.unit(),
                    0.2 + 2.8 * rng.unit(),
                );
                let budget = 20 + rng.below(5000) as usize;
                let f = renderer.update(grid, &view, budget);
                let tris = renderer.triangles();
                assert_eq!(tris.len(), f.triangles);
                if let Err(e) = check_conforming(grid.side, &tris) {
                    panic!("N = {n}, frame {frame}, budget {budget}: {e}");
                }
                let levels: std::collections::BTreeSet<u32> =
                    renderer.roam.leaves().iter().map(|t| t.level()).collect();
                most_levels = most_levels.max(levels.len());
            }
            assert!(most_levels >= 3, "N = {n}: the views never mixed levels");
        }
    }

    /// RUSTiC and plain ROAM on one view at several budgets: (RUSTiC frame, its error, ROAM's
    /// error with as many triangles as RUSTiC has clusters, ROAM's error with as many as
    /// RUSTiC has final triangles).
    fn compare(
        grid: &BinGrid,
        n: usize,
        view: &RoamView,
        budgets: &[usize],
    ) -> Vec<(RusticFrame, VerticalError, VerticalError, VerticalError)> {
        let mut renderer = RusticRenderer::new(grid, Rustic::build(grid, n));
        budgets
            .iter()
            .map(|&budget| {
                let f = renderer.update(grid, view, budget);
                let e = error_of(grid, &renderer.triangles());
                let (_, same_work) = roam_at(grid, view, f.roam_triangles);
                let (_, same_triangles) = roam_at(grid, view, f.triangles);
                (f, e, same_work, same_triangles)
            })
            .collect()
    }

    #[test]
    fn clusters_beat_roam_at_equal_roam_work_and_nearly_match_it_at_equal_triangles() {
        // Seed 000's Table 4.1 compares ROAM with k triangles against RUSTiC with k clusters
        // (k·N final triangles): there RUSTiC must be far more accurate. At equal *final*
        // triangle counts the edge constraint costs accuracy instead (seed 000, chapter 5:
        // plain ROAM is RUSTiC with N = 1, and larger clusters are less accurate at equal
        // counts): measured on this terrain, RUSTiC's mean error is 0.99–1.18 × ROAM's and its
        // max error 0.80–1.28 × (lower only for N = 64, 128). So RUSTiC ≤ ROAM at equal
        // triangle counts does NOT hold in general; what is asserted there is the measured
        // bound: mean within 1.3 × and max within 1.4 × of ROAM's.
        let grid = rough(8, 257, 257, 21);
        let view = orbit(&grid, 30.0, 75.0, 2.5);
        for n in [16, 32, 64, 128] {
            for (f, e, same_work, same_triangles) in
                compare(&grid, n, &view, &[1000, 3000, 10_000, 30_000])
            {
                let what = format!(
                    "N = {n}, {} clusters, {} triangles",
                    f.roam_triangles, f.triangles
                );
                assert!(
                    e.max < same_work.max && e.mean < 0.6 * same_work.mean,
                    "{what}"
                );
                assert!(
                    e.mean <= 1.3 * same_triangles.mean,
                    "{what}: {e:?} vs {same_triangles:?}"
                );
                assert!(
                    e.max <= 1.4 * same_triangles.max,
                    "{what}: {e:?} vs {same_triangles:?}"
                );
                assert_eq!((e.uncovered, same_triangles.uncovered), (0, 0));
            }
        }
    }
}
