//! Bounding spheres and normal cones, computed in f64 and stored conservatively in f32.

/// A bounding sphere in model units (callers pick the frame, e.g. relative to the repository
/// origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: [f64; 3],
    pub radius: f64,
}

impl Sphere {
    pub const EMPTY: Sphere = Sphere {
        center: [0.0; 3],
        radius: -1.0,
    };

    pub fn is_empty(&self) -> bool {
        self.radius < 0.0
    }

    /// A sphere around `points`: centred on their bounding box, radius to the farthest point.
    /// Within 1.8× of the minimal sphere, exact to compute, never misses a point.
    pub fn around_points(points: impl Iterator<Item = [f64; 3]>) -> Sphere {
        // Collected once: a caller's iterator may be costly to run twice.
        let points: Vec<[f64; 3]> = points.collect();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &points {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        if lo[0] > hi[0] {
            return Sphere::EMPTY;
        }
        let center = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
        let radius = points
            .iter()
            .map(|&p| distance(p, center))
            .fold(0.0, f64::max);
        Sphere { center, radius }
    }

    /// The smallest sphere containing both (either may be empty).
    pub fn merge(&self, other: &Sphere) -> Sphere {
        if self.is_empty() {
            return *other;
        }
        if other.is_empty() {
            return *self;
        }
        let d = distance(self.center, other.center);
        if d + other.radius <= self.radius {
            return *self;
        }
        if d + self.radius <= other.radius {
            return *other;
        }
        let radius = 0.5 * (d + self.radius + other.radius);
        let t = (radius - self.radius) / d;
        let center = [0, 1, 2].map(|i| self.center[i] + (other.center[i] - self.center[i]) * t);
        // Rounding may leave an input a hair outside; grow until both are contained.
        let radius = radius
            .max(distance(center, self.center) + self.radius)
            .max(distance(center, other.center) + other.radius);
        Sphere { center, radius }
    }

    /// Grows the radius by `margin` (used to make containment survive f32 rounding). The
    /// empty sphere stays empty (its radius is −1: grown by a margin above 1, as for a model
    /// a million units across, it would become a sphere at the origin).
    pub fn inflated(&self, margin: f64) -> Sphere {
        if self.is_empty() {
            return *self;
        }
        Sphere {
            center: self.center,
            radius: self.radius + margin,
        }
    }

    /// f32 centre and a radius rounded up so that the f32 sphere still contains the f64 one.
    pub fn to_f32(&self) -> ([f32; 3], f32) {
        if self.is_empty() {
            return ([0.0; 3], 0.0);
        }
        let c = self.center.map(|x| x as f32);
        let shift = distance(self.center, c.map(|x| x as f64));
        (c, round_up_f32(self.radius + shift))
    }
}

/// Euclidean distance in f64.
pub fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The smallest f32 not below `x` (finite inputs).
pub fn round_up_f32(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// Cone bounding the unit normals of a set of triangles: every normal n has dot(n, axis) ≥ cos.
/// `cos = -1` means the normals span every direction (never back-face cull).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalCone {
    pub axis: [f32; 3],
    pub cos: f32,
}

impl NormalCone {
    pub const ALL: NormalCone = NormalCone {
        axis: [0.0, 0.0, 1.0],
        cos: -1.0,
    };

    /// Cone of the given (not necessarily unit) triangle normals; zero normals are ignored.
    pub fn around_normals(normals: impl Iterator<Item = [f64; 3]>) -> NormalCone {
        let unit: Vec<[f64; 3]> = normals
            .filter_map(|n| {
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                (l > 0.0 && l.is_finite()).then(|| n.map(|x| x / l))
            })
            .collect();
        let mut sum = [0.0; 3];
        for n in &unit {
            for i in 0..3 {
                sum[i] += n[i];
            }
        }
        let l = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
        if l < 1e-12 {
            return NormalCone::ALL;
        }
        let axis = sum.map(|x| x / l);
        let min_dot = unit
            .iter()
            .map(|n| n[0] * axis[0] + n[1] * axis[1] + n[2] * axis[2])
            .fold(1.0f64, f64::min);
        // Keep a small slack for the f32 axis; below 0.1 the cone is too wide to be useful.
        let cos = (min_dot - 1e-4) as f32;
        if cos <= 0.1 {
            return NormalCone::ALL;
        }
        NormalCone {
            axis: axis.map(|x| x as f32),
            cos,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merged_sphere_contains_both() {
        let a = Sphere {
            center: [0.0, 0.0, 0.0],
            radius: 1.0,
        };
        let b = Sphere {
            center: [3.0, 1.0, -2.0],
            radius: 0.5,
        };
        let m = a.merge(&b);
        assert!(distance(m.center, a.center) + a.radius <= m.radius);
        assert!(distance(m.center, b.center) + b.radius <= m.radius);
        assert_eq!(a.merge(&Sphere::EMPTY), a);
        assert!(Sphere::EMPTY.inflated(1e6).is_empty());
    }

    #[test]
    fn f32_sphere_contains_f64_sphere() {
        let s = Sphere {
            center: [0.1, 1e7 + 0.3, -0.7],
            radius: 0.123456789,
        };
        let (c, r) = s.to_f32();
        let c = c.map(|x| x as f64);
        assert!(distance(c, s.center) + s.radius <= r as f64);
    }

    #[test]
    fn cone_of_a_flat_patch_is_tight() {
        let cone = NormalCone::around_normals([[0.0, 0.0, 2.0], [0.0, 0.0, 1.0]].into_iter());
        assert!(cone.cos > 0.99);
        let all = NormalCone::around_normals([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]].into_iter());
        assert_eq!(all, NormalCone::ALL);
    }
}
