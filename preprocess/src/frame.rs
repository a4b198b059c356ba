//! The build's frames: where the model sits and where the lattice cube sits.
//!
//! Everything the build computes — barycentres, point location, simplification, spheres,
//! errors — is computed relative to the *model origin* (the bounding box's minimum corner, also
//! the repository's origin), and the simplifier sees positions divided by the model's size. So a
//! model translated exactly (by a representable offset) builds the same repository apart from
//! the header's placement, and a scaled one the same up to the rounding of the scale: the cut
//! at a given view and τ does not depend on where the model is or on its units.
//!
//! The cube is a little larger than the bounding box (so no vertex lies on the cube's
//! boundary) and is divided into `2^bits` lattice units per side; every LEB vertex is an
//! integer lattice point. Triangles are located by their barycentre in lattice coordinates.

/// Maps model space to lattice coordinates of the cube `[0, 2^bits]^3` (3D), or of the square
/// `[0, 2^bits]^2` over x and y (2D, height fields: z is the height and plays no part).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatticeFrame {
    /// 3 (tetrahedra over a cube) or 2 (triangles over a square in the x, y plane).
    pub dim: u8,
    /// Model-space point every build computation is relative to (the bounding box minimum).
    pub model_origin: [f64; 3],
    /// Position of lattice point 0 relative to `model_origin`.
    pub origin: [f64; 3],
    /// Model units per lattice unit.
    pub unit: f64,
    /// log2 of the cube side in lattice units.
    pub bits: u32,
    /// Doublings between the model's cube and the lattice cube ([`Self::with_headroom`]): the
    /// model's cube is `[0, 2^(bits − headroom)]^dim`, a corner of the lattice cube, and the
    /// hierarchy has `dim · headroom` levels above it. 0: the model's cube is the lattice's.
    pub headroom: u32,
}

/// Steps per lattice unit of a triangle's location ([`LatticeFrame::location`]): a power of
/// two, so that a location is exact in f64 and its steps are integers. A triangle with its
/// corners on lattice points has its barycentre at thirds of a unit, which rounding to
/// sixteenths keeps strictly inside it.
pub const LOCATION_STEPS: f64 = 16.0;

/// Relative margin between the bounding box and the cube.
const CUBE_MARGIN: f64 = 0.01;

impl LatticeFrame {
    /// A cube (or, for `dim` 2, a square in x and y) around `[lo, hi]`, centred on the box,
    /// side `max extent · (1 + 2·margin)` over the axes it spans, with `lo` as the model origin.
    pub fn around_box(lo: [f64; 3], hi: [f64; 3], bits: u32, dim: u8) -> LatticeFrame {
        assert!(dim == 2 || dim == 3, "dimension must be 2 or 3");
        let mut extent = [0, 1, 2].map(|i| hi[i] - lo[i]);
        if dim == 2 {
            extent[2] = 0.0;
        }
        let largest = extent.iter().copied().fold(0.0, f64::max);
        // A degenerate (point) mesh still gets a unit cube.
        let side = if largest > 0.0 {
            largest * (1.0 + 2.0 * CUBE_MARGIN)
        } else {
            1.0
        };
        LatticeFrame {
            dim,
            model_origin: lo,
            origin: extent.map(|e| 0.5 * e - 0.5 * side),
            unit: side / (1u64 << bits) as f64,
            bits,
            headroom: 0,
        }
    }

    /// The same frame in a lattice cube `2^headroom` times as wide, the model's cube at its
    /// corner `[0, 2^bits]^dim` (same origin, same unit: every lattice coordinate, location and
    /// simplifier position is unchanged). LEB bisection of a Kuhn cube gives, every `dim`
    /// levels, the Kuhn subdivision of each sub-cube in the same orientation at the corner
    /// `0`, so the hierarchy below the model's cube is the one the smaller lattice had, and
    /// `dim · headroom` levels above it hold coarser versions of its roots: the chain past
    /// the roots that lets the coarsest cut of a small model reach a small share of its
    /// input (issue 46), in the same format and traversal.
    pub fn with_headroom(self, headroom: u32) -> LatticeFrame {
        LatticeFrame {
            bits: self.bits + headroom,
            headroom: self.headroom + headroom,
            ..self
        }
    }

    /// A model-space point relative to the model origin.
    #[inline]
    pub fn relative(&self, p: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| p[i] - self.model_origin[i])
    }

    /// Lattice coordinates of a point given relative to the model origin (z = 0 in 2D).
    #[inline]
    pub fn to_lattice(&self, r: [f64; 3]) -> [f64; 3] {
        let mut q = [0, 1, 2].map(|i| (r[i] - self.origin[i]) / self.unit);
        if self.dim == 2 {
            q[2] = 0.0;
        }
        q
    }

    /// Lattice coordinates of a triangle's barycentre (model-space corners): the corners are
    /// made relative first, so the result does not depend on where the model sits.
    #[inline]
    pub fn barycentre(&self, corners: [[f64; 3]; 3]) -> [f64; 3] {
        let [a, b, c] = corners.map(|p| self.relative(p));
        self.to_lattice([0, 1, 2].map(|i| (a[i] + b[i] + c[i]) / 3.0))
    }

    /// Where the hierarchy locates a triangle: its [`barycentre`](Self::barycentre) rounded to
    /// the nearest multiple of 1/[`LOCATION_STEPS`] of a lattice unit. Leaves are thousands of
    /// lattice units wide, so this moves few triangles to another leaf; what it buys is that a
    /// location is a small integer per axis in steps, which the out-of-core hierarchy's files
    /// delta-code in a byte or two where an f64 took eight (`hierarchy/location_codec.rs`).
    /// Every build locates through this, in memory or not, so both give the same leaves.
    #[inline]
    pub fn location(&self, corners: [[f64; 3]; 3]) -> [f64; 3] {
        self.barycentre(corners)
            .map(|x| (x * LOCATION_STEPS).round() / LOCATION_STEPS)
    }

    /// Whether a diamond or simplex of `level` lies above the model's cube (its `dim · headroom`
    /// levels of coarser versions past the model's roots).
    pub fn is_above_model(&self, level: u16) -> bool {
        (level as u32) < self.dim as u32 * self.headroom
    }

    /// Side of the model's cube in model units (the lattice cube's less its headroom).
    pub fn side(&self) -> f64 {
        self.unit * (1u64 << (self.bits - self.headroom)) as f64
    }

    /// The model's size: its largest extent (1 for a point), the unit the simplifier works in.
    pub fn model_size(&self) -> f64 {
        self.side() / (1.0 + 2.0 * CUBE_MARGIN)
    }
}

/// Length of the box diagonal.
pub fn diagonal(lo: [f64; 3], hi: [f64; 3]) -> f64 {
    ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
}
