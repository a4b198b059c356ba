//! The trade-off benchmark's peers, one file each, all drawing the source mesh as
//! `peer_mesh::PeerMesh` holds it:
//! - `full_resolution`: the source in one draw (error 0 by definition; the time baseline and
//!   the reference picture);
//! - `discrete_lod`: meshopt levels (nine by default), one per object by distance (seed 004);
//! - `cluster_dag`: meshoptimizer's clusterlod DAG, cut per frame on the CPU.

pub mod cluster_dag;
pub mod discrete_lod;
pub mod full_resolution;
pub mod peer_mesh;
