//! The lattice frame: where the LEB cube sits in model space.
//!
//! The cube is a little larger than the mesh's bounding box (so no vertex lies on the cube's
//! boundary) and is divided into `2^bits` lattice units per side; every LEB vertex is an
//! integer lattice point. Triangles are located by their barycentre in lattice coordinates.

/// Maps model space to lattice coordinates of the cube `[0, 2^bits]^3`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatticeFrame {
    /// Model-space position of lattice point 0.
    pub origin: [f64; 3],
    /// Model units per lattice unit.
    pub unit: f64,
    /// log2 of the cube side in lattice units.
    pub bits: u32,
}

/// Relative margin between the bounding box and the cube.
const CUBE_MARGIN: f64 = 0.01;

impl LatticeFrame {
    /// A cube around `[lo, hi]`, centred on the box, side `max extent · (1 + 2·margin)`.
    pub fn around_box(lo: [f64; 3], hi: [f64; 3], bits: u32) -> LatticeFrame {
        let extent = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
        // A degenerate (point) mesh still gets a unit cube.
        let side = if extent > 0.0 {
            extent * (1.0 + 2.0 * CUBE_MARGIN)
        } else {
            1.0
        };
        let centre = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
        LatticeFrame {
            origin: centre.map(|c| c - 0.5 * side),
            unit: side / (1u64 << bits) as f64,
            bits,
        }
    }

    /// Model → lattice coordinates (f64; exact containment tests happen on these values).
    pub fn to_lattice(&self, p: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| (p[i] - self.origin[i]) / self.unit)
    }

    /// Side of the cube in model units.
    pub fn side(&self) -> f64 {
        self.unit * (1u64 << self.bits) as f64
    }
}

/// Length of the box diagonal.
pub fn diagonal(lo: [f64; 3], hi: [f64; 3]) -> f64 {
    ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
}
