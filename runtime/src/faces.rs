//! Which faces a frame shows: the one face rule every drawer and every measurement of a frame
//! must share, or two renderers of the same view draw different pictures (an open scan seen
//! from behind: one shows its back, the other nothing).
//!
//! - `Front`: back faces are not drawn (rasteriser back-face culling, counter-clockwise front,
//!   as `Renderer`'s default lit frame with its normal-cone culling); a back-facing triangle
//!   neither shows nor hides anything.
//! - `Both`: every triangle is drawn from either side (`FrameRequest::two_sided`, no cone
//!   culling).

use crate::vec3::{cross, dot, sub};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Faces {
    #[default]
    Front,
    Both,
}

impl Faces {
    /// Whether a triangle `[a, b, c]` (counter-clockwise front) is drawn for an eye at `eye`:
    /// always with `Both`; with `Front` when the eye is strictly on its front side (an edge-on
    /// triangle covers no pixel).
    pub fn shows(self, eye: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> bool {
        match self {
            Faces::Both => true,
            Faces::Front => dot(cross(sub(b, a), sub(c, a)), sub(eye, a)) > 0.0,
        }
    }

    /// The wgpu cull mode that draws these faces.
    pub fn cull_mode(self) -> Option<wgpu::Face> {
        match self {
            Faces::Front => Some(wgpu::Face::Back),
            Faces::Both => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_shows_counter_clockwise_triangles_seen_from_their_front() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(Faces::Front.shows([0.2, 0.2, 1.0], t));
        assert!(!Faces::Front.shows([0.2, 0.2, -1.0], t));
        assert!(!Faces::Front.shows([5.0, 5.0, 0.0], t), "edge-on");
        assert!(Faces::Both.shows([0.2, 0.2, -1.0], t));
        assert_eq!(Faces::Front.cull_mode(), Some(wgpu::Face::Back));
        assert_eq!(Faces::Both.cull_mode(), None);
    }
}
