//! Terrain baselines and the terrain benchmark (issue 5): ROAM (seed 002) and RUSTiC clusters
//! (seed 000) on the bintree of a padded square grid, measured against tessera's 2D path with
//! the same cameras and the same vertical-error metric.
//!
//! - `grid.rs`: the padded (2^k + 1)² square, bintree triangles, vertical error vs the grid.

pub mod grid;
