//! The measured geometric error of a frame, in pixels, both ways.
//!
//! 1. Sample: `SamplingConfig::samples_per_view` points on a surface, area-weighted from a
//!    fixed seed (`sampling.rs`): the same surface gives the same samples on every run.
//! 2. Keep what the eye sees: samples behind the eye, nearer than the near plane or outside
//!    the four side planes of the frustum are off screen; samples another part of their own
//!    surface hides (`visibility.rs`, a segment cast from the eye), or on a triangle the
//!    frame's face rule does not draw (`Faces::Front`: facing away), are hidden. Both are
//!    counted and skipped.
//! 3. Measure: the exact distance d to the other surface (`ReferenceMesh`), in pixels at the
//!    sample's Euclidean distance from the eye as the run-time rule projects an error:
//!    d · K / |p − eye|, K = height / (2·tan(fovy/2)) — the same K as ρ, so a measured error
//!    is comparable with τ.
//!
//! Two-sided (`two_sided_errors`): the visible samples of the drawn cut against the original
//! (how far what is drawn strays) and the visible samples of the original against the drawn
//! cut (what the cut lost: a hole, a flattened feature, a closed gap). The pair's pooled
//! maximum is a sampled lower bound of the visible two-sided (Hausdorff) distance in pixels.

use rayon::prelude::*;

use super::nearest::{MeshError, ReferenceMesh};
use super::sampling::sample_triangles;
use crate::camera::Camera;
use crate::faces::Faces;
use crate::vec3::{dot, length, sub};

/// A triangle soup to sample: positions in the reference mesh's frame (f64).
#[derive(Clone, Copy, Debug)]
pub struct Surface<'a> {
    pub positions: &'a [[f64; 3]],
    /// Indices into `positions` (each must be in range).
    pub triangles: &'a [[u32; 3]],
}

/// How to sample a view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingConfig {
    /// Points drawn on the surface per view, before the frustum test (off-screen samples are
    /// skipped, so fewer are measured).
    pub samples_per_view: usize,
    /// Seed of the sample stream (SplitMix64).
    pub seed: u64,
}

impl Default for SamplingConfig {
    fn default() -> Self {
        SamplingConfig {
            samples_per_view: 20_000,
            seed: 0x7e55_e7a0,
        }
    }
}

/// One view's measured samples, one direction.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewErrors {
    /// Error of every visible sample, pixels, in sample order.
    pub errors_px: Vec<f64>,
    /// Samples skipped as off-screen (behind the eye, before the near plane, outside a side).
    pub skipped: usize,
    /// On-screen samples skipped as hidden by their own surface (or facing away, see
    /// `VisibleSamples::hidden`).
    pub hidden: usize,
}

/// One view's measured samples both ways.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TwoSidedErrors {
    /// Samples of the drawn cut, distance to the original.
    pub to_original: ViewErrors,
    /// Samples of the original, distance to the drawn cut (infinite where nothing is drawn).
    pub to_cut: ViewErrors,
}

/// The samples of a surface the eye sees, with each one's pixels per unit of distance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VisibleSamples {
    pub points: Vec<[f64; 3]>,
    /// K / |p − eye| per point: a distance d at the point is d · scale pixels.
    pub pixels_per_unit: Vec<f64>,
    /// Off screen (see `ViewErrors::skipped`).
    pub skipped: usize,
    /// Hidden by the surface itself, or on a triangle the frame does not draw (facing away
    /// under `Faces::Front`).
    pub hidden: usize,
}

impl VisibleSamples {
    /// Each sample's distance to `other`, in pixels.
    pub fn errors_to(&self, other: &ReferenceMesh) -> ViewErrors {
        ViewErrors {
            errors_px: self
                .points
                .par_iter()
                .zip(&self.pixels_per_unit)
                .map(|(&p, &scale)| other.distance(p) * scale)
                .collect(),
            skipped: self.skipped,
            hidden: self.hidden,
        }
    }
}

/// Max, 99th percentile (nearest rank) and mean of pooled pixel errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSummary {
    pub samples: usize,
    pub max_px: f64,
    pub p99_px: f64,
    pub mean_px: f64,
}

impl ErrorSummary {
    /// The summary of `errors` (pixels); `None` when there are none.
    pub fn of(errors: &[f64]) -> Option<ErrorSummary> {
        if errors.is_empty() {
            return None;
        }
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let rank = ((0.99 * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
        Some(ErrorSummary {
            samples: sorted.len(),
            max_px: sorted[sorted.len() - 1],
            p99_px: sorted[rank - 1],
            mean_px: sorted.iter().sum::<f64>() / sorted.len() as f64,
        })
    }
}

/// The samples of `mesh`'s own surface that `camera` sees in a frame drawn with `faces`: on
/// screen (inside the view frustum), on a triangle the frame draws (with `Faces::Front`, one
/// facing the eye) and not hidden by `mesh` (`ReferenceMesh::hides`). Positions are relative
/// to `origin`, the mesh's frame.
///
/// Cost: `samples_per_view` segment casts, spread over rayon's threads.
pub fn visible_samples(
    mesh: &ReferenceMesh,
    camera: &Camera,
    origin: [f64; 3],
    config: &SamplingConfig,
    faces: Faces,
) -> VisibleSamples {
    let surface = mesh.surface();
    let samples = sample_triangles(surface, config.samples_per_view, config.seed);
    let basis = camera.basis();
    let eye = sub(camera.eye, origin);
    let tan_y = (0.5 * camera.fov_y_degrees.to_radians()).tan();
    let tan_x = tan_y * camera.aspect();
    let scale = camera.height as f64 / (2.0 * tan_y);
    // None: off screen; Some(None): hidden; Some(Some(scale)): seen.
    let seen: Vec<Option<Option<f64>>> = samples
        .par_iter()
        .map(|&(p, k)| {
            let d = sub(p, eye);
            let depth = dot(d, basis.forward);
            let on_screen = depth > 0.0
                && depth >= camera.near
                && dot(d, basis.right).abs() <= depth * tan_x
                && dot(d, basis.up).abs() <= depth * tan_y;
            // Projected as the run-time rule projects an error: over the Euclidean distance
            // to the eye (ρ = error · K / |c − eye|), not the depth along the view axis.
            let corners = surface.triangles[k].map(|v| surface.positions[v as usize]);
            on_screen.then(|| {
                (faces.shows(eye, corners) && !mesh.hides(eye, p, faces)).then(|| scale / length(d))
            })
        })
        .collect();
    let mut out = VisibleSamples::default();
    for ((p, _), s) in samples.into_iter().zip(seen) {
        match s {
            None => out.skipped += 1,
            Some(None) => out.hidden += 1,
            Some(Some(scale)) => {
                out.points.push(p);
                out.pixels_per_unit.push(scale);
            }
        }
    }
    out
}

/// The measured error of one view, both ways: the visible samples of `drawn` (the surface a
/// frame drew with `faces`, positions relative to `origin`) against `reference`, and
/// `original` (`visible_samples` of the reference for the same camera and `faces`, computed
/// once per view and shared by every cut measured from it) against `drawn`.
///
/// Errors: `drawn` with a non-finite position or an index out of range. A drawn surface with
/// no triangle has no samples, and every original sample is infinitely far from it.
/// Cost: a BVH over `drawn` (O(n log n)), then `samples_per_view` segment casts and
/// 2 · `samples_per_view` distance queries.
pub fn two_sided_errors(
    reference: &ReferenceMesh,
    original: &VisibleSamples,
    drawn: Surface<'_>,
    camera: &Camera,
    origin: [f64; 3],
    config: &SamplingConfig,
    faces: Faces,
) -> Result<TwoSidedErrors, MeshError> {
    if drawn.triangles.is_empty() {
        return Ok(TwoSidedErrors {
            to_original: ViewErrors::default(),
            to_cut: ViewErrors {
                errors_px: vec![f64::INFINITY; original.points.len()],
                skipped: original.skipped,
                hidden: original.hidden,
            },
        });
    }
    let drawn = ReferenceMesh::new(drawn.positions.to_vec(), drawn.triangles.to_vec())?;
    let seen = visible_samples(&drawn, camera, origin, config, faces);
    Ok(TwoSidedErrors {
        to_original: seen.errors_to(reference),
        to_cut: original.errors_to(&drawn),
    })
}

/// The seed of the original's samples for a view whose cut samples use `config.seed`: a
/// different stream, so the two directions never sample the same barycentrics.
pub fn original_sampling(config: &SamplingConfig) -> SamplingConfig {
    SamplingConfig {
        seed: config.seed.rotate_left(32) ^ 0x0419_1a15,
        ..*config
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of side 2·half in the plane z = `z`, split into 2·n² triangles.
    fn square(half: f64, z: f64, n: u32) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                positions.push([half * (2.0 * u - 1.0), half * (2.0 * v - 1.0), z]);
            }
        }
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                triangles.push([a, a + 1, a + n + 2]);
                triangles.push([a, a + n + 2, a + n + 1]);
            }
        }
        (positions, triangles)
    }

    /// A camera on the z axis looking down at the origin, 640 × 480, 60°.
    fn camera(eye_z: f64) -> Camera {
        Camera {
            up: [0.0, 1.0, 0.0],
            width: 640,
            height: 480,
            ..Camera::looking_at([0.0, 0.0, eye_z], [0.0; 3], 1.0)
        }
    }

    fn config(samples: usize) -> SamplingConfig {
        SamplingConfig {
            samples_per_view: samples,
            ..Default::default()
        }
    }

    /// The visible samples of `surface` against `reference` (one direction).
    fn pixel_errors(
        reference: &ReferenceMesh,
        surface: Surface<'_>,
        camera: &Camera,
        origin: [f64; 3],
        config: &SamplingConfig,
    ) -> ViewErrors {
        let drawn =
            ReferenceMesh::new(surface.positions.to_vec(), surface.triangles.to_vec()).unwrap();
        visible_samples(&drawn, camera, origin, config, Faces::Front).errors_to(reference)
    }

    #[test]
    fn samples_of_the_original_have_no_error() {
        let (positions, triangles) = square(1.0, 0.0, 8);
        let reference = ReferenceMesh::new(positions.clone(), triangles.clone()).unwrap();
        let surface = Surface {
            positions: &positions,
            triangles: &triangles,
        };
        let v = pixel_errors(&reference, surface, &camera(3.0), [0.0; 3], &config(2000));
        assert_eq!(v.errors_px.len() + v.skipped + v.hidden, 2000);
        assert_eq!(v.hidden, 0, "a flat square hides nothing of itself");
        assert!(v.errors_px.len() > 1500, "the square fills the view centre");
        let s = ErrorSummary::of(&v.errors_px).unwrap();
        assert!(s.max_px < 1e-9, "{s:?}");
    }

    /// A surface offset by d towards the eye, seen head-on from depth z: d·K/z pixels on the
    /// axis, d·K/|p − eye| off it.
    #[test]
    fn an_offset_of_d_at_depth_z_is_d_k_over_z_pixels() {
        let (positions, triangles) = square(1.0, 0.0, 4);
        let reference = ReferenceMesh::new(positions, triangles).unwrap();
        let d = 0.01;
        // A smaller square so every sample's nearest point is straight below it.
        let (lifted, lifted_triangles) = square(0.5, d, 3);
        let eye_z = 4.0;
        let cam = camera(eye_z);
        let surface = Surface {
            positions: &lifted,
            triangles: &lifted_triangles,
        };
        let v = pixel_errors(&reference, surface, &cam, [0.0; 3], &config(500));
        assert_eq!(v.skipped, 0);
        let k = 480.0 / (2.0 * (30f64).to_radians().tan());
        // Over the Euclidean distance: d·K/(z − d) on the axis, less off it (the lifted
        // square's corners are 0.5·√2 off the axis).
        let expected = d * k / (eye_z - d);
        let corner = d * k / ((eye_z - d).powi(2) + 0.5).sqrt();
        for e in &v.errors_px {
            assert!(
                *e <= expected * (1.0 + 1e-9) && *e >= corner * (1.0 - 1e-9),
                "{e}"
            );
        }
        let max = v.errors_px.iter().copied().fold(0.0, f64::max);
        assert!(
            max > 0.999 * expected,
            "a sample near the axis: {max} vs {expected}"
        );
        // The same in another frame: everything moved by an origin of 1e7.
        let origin = [1e7, -3e6, 5e5];
        let moved = Camera {
            eye: [0, 1, 2].map(|i| cam.eye[i] + origin[i]),
            target: origin,
            ..cam
        };
        let again = pixel_errors(&reference, surface, &moved, origin, &config(500));
        assert_eq!(again.errors_px.len(), 500);
        for (e, f) in again.errors_px.iter().zip(&v.errors_px) {
            assert!((e - f).abs() < 1e-6 * expected, "{e} vs {f}");
        }
    }

    #[test]
    fn samples_behind_the_eye_or_off_screen_are_skipped() {
        let (positions, triangles) = square(1.0, 0.0, 2);
        let reference = ReferenceMesh::new(positions.clone(), triangles.clone()).unwrap();
        let surface = Surface {
            positions: &positions,
            triangles: &triangles,
        };
        // Eye below the square, looking away from it.
        let away = Camera {
            target: [0.0, 0.0, -5.0],
            ..camera(-1.0)
        };
        let v = pixel_errors(&reference, surface, &away, [0.0; 3], &config(300));
        assert!(v.errors_px.is_empty() && v.skipped == 300, "{v:?}");
        // Very close: most of the square is outside the side planes.
        let near = pixel_errors(&reference, surface, &camera(0.2), [0.0; 3], &config(1000));
        assert!(near.skipped > 800 && !near.errors_px.is_empty(), "{near:?}");
    }

    /// Two parallel squares seen from above: the lower one's samples are hidden, and only the
    /// upper one's are measured.
    #[test]
    fn hidden_samples_are_counted_and_skipped() {
        let (mut positions, mut triangles) = square(1.0, 0.0, 4);
        let (lower, lower_triangles) = square(1.0, -0.5, 4);
        let base = positions.len() as u32;
        positions.extend(lower);
        triangles.extend(lower_triangles.iter().map(|t| t.map(|v| v + base)));
        let reference = ReferenceMesh::new(positions.clone(), triangles.clone()).unwrap();
        // Seen from straight above, far enough for the whole of both to be on screen.
        let cam = camera(6.0);
        let seen = visible_samples(&reference, &cam, [0.0; 3], &config(4000), Faces::Front);
        assert_eq!(seen.skipped, 0);
        assert_eq!(seen.points.len() + seen.hidden, 4000);
        // Half the area is the lower square; from straight above all of it is hidden.
        let share = seen.hidden as f64 / 4000.0;
        assert!((share - 0.5).abs() < 0.04, "{share}");
        assert!(
            seen.points.iter().all(|p| p[2] == 0.0),
            "only the upper square is seen"
        );
    }

    /// A sphere seen from distance D: the eye sees the cap within the tangent cone, a share
    /// (1 − 1/D)/2 of the area (an icosphere, four subdivisions, is close enough).
    #[test]
    fn a_sphere_shows_the_cap_its_tangent_cone_sees() {
        let (mut positions, mut triangles) = (
            vec![
                [1.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, -1.0],
            ],
            vec![
                [0, 2, 4],
                [2, 1, 4],
                [1, 3, 4],
                [3, 0, 4],
                [2, 0, 5],
                [1, 2, 5],
                [3, 1, 5],
                [0, 3, 5],
            ],
        );
        for _ in 0..5 {
            let mut next = Vec::new();
            let mut middle = std::collections::HashMap::new();
            let mut mid = |a: u32, b: u32, positions: &mut Vec<[f64; 3]>| {
                *middle.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let m: [f64; 3] =
                        [0, 1, 2].map(|i| positions[a as usize][i] + positions[b as usize][i]);
                    let l = length(m);
                    positions.push(m.map(|x| x / l));
                    positions.len() as u32 - 1
                })
            };
            for [a, b, c] in triangles {
                let (ab, bc, ca) = (
                    mid(a, b, &mut positions),
                    mid(b, c, &mut positions),
                    mid(c, a, &mut positions),
                );
                next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            triangles = next;
        }
        let sphere = ReferenceMesh::new(positions, triangles).unwrap();
        let seen = visible_samples(&sphere, &camera(10.0), [0.0; 3], &config(8000), Faces::Both);
        assert_eq!(seen.skipped, 0, "the whole sphere is on screen");
        let share = seen.points.len() as f64 / 8000.0;
        assert!((share - 0.45).abs() < 0.02, "{share}");
        // Every seen sample faces the eye.
        assert!(
            seen.points.iter().all(|p| p[2] > 0.09),
            "behind the tangent circle"
        );
    }

    /// A cut with a hole: its own samples are all on the original (0 px), but the original's
    /// samples in the hole are far from the cut — what a one-sided metric cannot see.
    #[test]
    fn the_two_sided_error_sees_a_hole() {
        let (positions, triangles) = square(1.0, 0.0, 8);
        let reference = ReferenceMesh::new(positions.clone(), triangles.clone()).unwrap();
        // Drop the triangles of the quadrant x > 0, y > 0.
        let holed: Vec<[u32; 3]> = triangles
            .iter()
            .copied()
            .filter(|t| {
                !t.iter()
                    .all(|&v| positions[v as usize][0] >= 0.0 && positions[v as usize][1] >= 0.0)
            })
            .collect();
        assert!(holed.len() < triangles.len());
        let cam = camera(3.0);
        let cfg = config(3000);
        let original = visible_samples(
            &reference,
            &cam,
            [0.0; 3],
            &original_sampling(&cfg),
            Faces::Front,
        );
        let drawn = Surface {
            positions: &positions,
            triangles: &holed,
        };
        let e = two_sided_errors(
            &reference,
            &original,
            drawn,
            &cam,
            [0.0; 3],
            &cfg,
            Faces::Front,
        )
        .unwrap();
        let forward = ErrorSummary::of(&e.to_original.errors_px).unwrap();
        assert!(forward.max_px < 1e-9, "{forward:?}");
        let backward = ErrorSummary::of(&e.to_cut.errors_px).unwrap();
        // The hole's centre (0.5, 0.5) is 0.5 from the cut: 0.5 · K / ~3 pixels.
        let k = 480.0 / (2.0 * (30f64).to_radians().tan());
        assert!(backward.max_px > 0.4 * k / 3.1, "{backward:?}");
        // Nothing drawn: every visible original sample is infinitely far.
        let empty = Surface {
            positions: &positions,
            triangles: &[],
        };
        let e = two_sided_errors(
            &reference,
            &original,
            empty,
            &cam,
            [0.0; 3],
            &cfg,
            Faces::Front,
        )
        .unwrap();
        assert!(e.to_original.errors_px.is_empty());
        assert_eq!(e.to_cut.errors_px.len(), original.points.len());
        assert!(e.to_cut.errors_px.iter().all(|x| x.is_infinite()));
    }

    #[test]
    fn summary_is_max_nearest_rank_p99_and_mean() {
        let errors: Vec<f64> = (1..=200).rev().map(f64::from).collect();
        let s = ErrorSummary::of(&errors).unwrap();
        assert_eq!((s.samples, s.max_px, s.p99_px), (200, 200.0, 198.0));
        assert!((s.mean_px - 100.5).abs() < 1e-12);
        assert_eq!(ErrorSummary::of(&[]), None);
    }
}
