//! Longest-edge bisection on an exact integer lattice, shared by 2D (height fields) and 3D
//! (arbitrary meshes): simplices, diamonds and their DAG, conforming refinement, point location.

pub mod conforming;
pub mod diamond;
pub mod plane;
pub mod predicates;
pub mod simplex;

pub use conforming::ConformingMesh;
pub use diamond::{Diamond, DiamondId};
pub use plane::LatticePlane;
pub use predicates::LatticePoint;
pub use simplex::{Bisector, PreparedSimplex, Simplex, SimplexKey};
