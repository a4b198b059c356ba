//! Terrain baselines and the terrain benchmark (issue 5): ROAM (seed 002) and RUSTiC clusters
//! (seed 000) on the bintree of a padded square grid, measured against tessera's 2D path with
//! the same cameras and the same vertical-error metric.
//!
//! - `grid.rs`: the padded (2^k + 1)² square, bintree triangles, vertical error vs the grid.
//! - `roam.rs`, `roam/`: ROAM (seed 002): nested wedgies, split/merge queues, forced splits.
//! - `bench.rs`: `tessera bench terrain` (all three at equal budgets); `plots.rs` its plots.
//! - `rustic/`: RUSTiC triangle clusters by adaptive merge (seed 000) and ROAM over them.

pub mod bench;
pub mod grid;
pub mod plots;
pub mod roam;
pub mod rustic;
