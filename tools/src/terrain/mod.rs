//! The terrain benchmark (issue 5): ROAM (seed 002) and RUSTiC clusters (seed 000) on the
//! bintree of a padded square grid, measured against tessera's 2D path with the same cameras
//! and the same vertical-error metric. The baselines themselves are in tessera-bench
//! (`tessera_bench::terrain`: `grid`, `roam`, `rustic`, `square_mesh`).
//!
//! - `bench.rs`: `tessera bench terrain` (all three at equal budgets); `plots.rs` its plots.

pub mod bench;
pub mod plots;
