//! Terrain baselines (issue 5): ROAM (seed 002) and RUSTiC clusters (seed 000) on the bintree
//! of a padded square grid; `tessera bench terrain` measures them against tessera's 2D path.
//!
//! - `grid.rs`: the padded (2^k + 1)² square, bintree triangles, vertical error vs the grid.
//! - `roam.rs`, `roam/`: ROAM (seed 002): nested wedgies, split/merge queues, forced splits.
//! - `rustic/`: RUSTiC triangle clusters by adaptive merge (seed 000) and ROAM over them.
//! - `square_mesh.rs`: how the baselines draw: one vertex per sample of the padded square.

pub mod grid;
pub mod roam;
pub mod rustic;
pub mod square_mesh;
