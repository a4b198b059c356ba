//! Garland and Heckbert's generalised quadric (1998), seed 004 section 3.5.2: the squared
//! distance of a point of (position, attributes) space to the plane of a triangle there,
//! summed over a node's triangles weighted by their area, and the point minimising the sum,
//! found with a pseudo-inverse.
//!
//! For a triangle (p, q, r): e1 = (q - p)/|q - p|, e2 = (r - p - (e1·(r - p)) e1)/|...|,
//! A = I - e1 e1ᵀ - e2 e2ᵀ (the seed's Eq. 3.3 prints e1 twice: a misprint),
//! b = (p·e1) e1 + (p·e2) e2 - p, c = p·p - (p·e1)² - (p·e2)², and D²(v) = vᵀAv + 2bᵀv + c.
//! The optimum solves A v = -b. A node's A is singular wherever its triangles leave a
//! direction free (a flat node: every tangent direction), so the solve is a pseudo-inverse
//! about the node's area-weighted centroid v0: v = v0 + Σ over eigenpairs (λ, u) of A with
//! λ > `RELATIVE_THRESHOLD` λmax of (uᵀ(-b - A v0)/λ) u. Free directions stay at v0.

/// The most dimensions: position, normal, RGBA colour, texture coordinates.
pub const MAX_DIM: usize = 12;

/// Eigenvalues below this fraction of the largest count as zero (Lindstrom's OoCS uses 1e-3
/// for its 3 × 3 quadrics).
pub const RELATIVE_THRESHOLD: f64 = 1e-3;

/// An area-weighted sum of triangle quadrics in `n` dimensions, with the weighted centroid.
#[derive(Clone, Debug)]
pub struct Quadric {
    pub n: usize,
    pub a: [[f64; MAX_DIM]; MAX_DIM],
    pub b: [f64; MAX_DIM],
    pub c: f64,
    /// Sum of the weights (areas).
    pub area: f64,
    /// Sum of area × triangle centroid, and of the plain centroids (for zero-area nodes).
    centroid_sum: [f64; MAX_DIM],
    plain_sum: [f64; MAX_DIM],
    triangles: u64,
}

impl Quadric {
    pub fn new(n: usize) -> Quadric {
        assert!((3..=MAX_DIM).contains(&n));
        Quadric {
            n,
            a: [[0.0; MAX_DIM]; MAX_DIM],
            b: [0.0; MAX_DIM],
            c: 0.0,
            area: 0.0,
            centroid_sum: [0.0; MAX_DIM],
            plain_sum: [0.0; MAX_DIM],
            triangles: 0,
        }
    }

    /// Adds triangle (p, q, r) (points of `n` dimensions) with weight `area`.
    pub fn add_triangle(&mut self, p: &[f64], q: &[f64], r: &[f64], area: f64) {
        let n = self.n;
        self.triangles += 1;
        for i in 0..n {
            let c = (p[i] + q[i] + r[i]) / 3.0;
            self.plain_sum[i] += c;
            self.centroid_sum[i] += area * c;
        }
        if area <= 0.0 || !area.is_finite() {
            return;
        }
        let mut e1 = [0.0; MAX_DIM];
        let mut e2 = [0.0; MAX_DIM];
        for i in 0..n {
            e1[i] = q[i] - p[i];
            e2[i] = r[i] - p[i];
        }
        if !normalise(&mut e1[..n]) {
            return;
        }
        let d = dot(&e1[..n], &e2[..n]);
        for i in 0..n {
            e2[i] -= d * e1[i];
        }
        if !normalise(&mut e2[..n]) {
            return;
        }
        let (pe1, pe2) = (dot(&p[..n], &e1[..n]), dot(&p[..n], &e2[..n]));
        for i in 0..n {
            for j in 0..n {
                let identity = if i == j { 1.0 } else { 0.0 };
                self.a[i][j] += area * (identity - e1[i] * e1[j] - e2[i] * e2[j]);
            }
            self.b[i] += area * (pe1 * e1[i] + pe2 * e2[i] - p[i]);
        }
        self.c += area * (dot(&p[..n], &p[..n]) - pe1 * pe1 - pe2 * pe2);
    }

    /// The summed squared distance at `v`: vᵀAv + 2bᵀv + c (never below 0).
    pub fn error(&self, v: &[f64]) -> f64 {
        let n = self.n;
        let mut e = self.c;
        for i in 0..n {
            e += 2.0 * self.b[i] * v[i];
            for j in 0..n {
                e += v[i] * self.a[i][j] * v[j];
            }
        }
        e.max(0.0)
    }

    /// The area-weighted centroid (the plain one where every triangle has zero area).
    pub fn centroid(&self) -> [f64; MAX_DIM] {
        let mut c = [0.0; MAX_DIM];
        for (i, c) in c.iter_mut().enumerate().take(self.n) {
            *c = if self.area > 0.0 {
                self.centroid_sum[i] / self.area
            } else {
                self.plain_sum[i] / self.triangles.max(1) as f64
            };
        }
        c
    }

    /// The quadric's minimiser by the pseudo-inverse about the centroid.
    pub fn optimum(&self) -> [f64; MAX_DIM] {
        let all: Vec<usize> = (0..self.n).collect();
        let mut v = self.centroid();
        self.solve_over(&all, &mut v);
        v
    }

    /// Minimises over the coordinates after the position with the position fixed at
    /// `v[..3]` (the rest of `v` is the starting point): the attributes that best fit a
    /// position chosen by another rule.
    pub fn optimum_attributes(&self, v: &mut [f64; MAX_DIM]) {
        let free: Vec<usize> = (3..self.n).collect();
        if !free.is_empty() {
            self.solve_over(&free, v);
        }
    }

    /// Moves `v` along the coordinates `free` (others fixed) to the pseudo-inverse minimiser
    /// nearest it: v_f += A_ff⁺ (-(b + A v)_f).
    fn solve_over(&self, free: &[usize], v: &mut [f64; MAX_DIM]) {
        let m = free.len();
        let mut sub = [[0.0; MAX_DIM]; MAX_DIM];
        let mut residual = [0.0; MAX_DIM];
        for (i, &fi) in free.iter().enumerate() {
            let av: f64 = (0..self.n).map(|j| self.a[fi][j] * v[j]).sum();
            residual[i] = -(self.b[fi] + av);
            for (j, &fj) in free.iter().enumerate() {
                sub[i][j] = self.a[fi][fj];
            }
        }
        let (values, vectors) = symmetric_eigen(&sub, m);
        let largest = values[..m].iter().fold(0.0f64, |a, &l| a.max(l.abs()));
        if largest <= 0.0 {
            return;
        }
        for k in 0..m {
            let l = values[k];
            if l <= RELATIVE_THRESHOLD * largest {
                continue;
            }
            let mut along = 0.0;
            for i in 0..m {
                along += vectors[i][k] * residual[i];
            }
            for (i, &fi) in free.iter().enumerate() {
                v[fi] += along / l * vectors[i][k];
            }
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Scales to unit length; false for a zero vector.
fn normalise(v: &mut [f64]) -> bool {
    let len = dot(v, v).sqrt();
    if len <= 0.0 || !len.is_finite() {
        return false;
    }
    for x in v {
        *x /= len;
    }
    true
}

/// Eigenvalues and eigenvectors (columns) of the leading m × m block of a symmetric matrix,
/// by cyclic Jacobi rotations (m ≤ 12: a few sweeps).
pub fn symmetric_eigen(
    matrix: &[[f64; MAX_DIM]; MAX_DIM],
    m: usize,
) -> ([f64; MAX_DIM], [[f64; MAX_DIM]; MAX_DIM]) {
    let mut a = *matrix;
    let mut v = [[0.0; MAX_DIM]; MAX_DIM];
    for (i, row) in v.iter_mut().enumerate().take(m) {
        row[i] = 1.0;
    }
    let norm: f64 = (0..m)
        .flat_map(|i| (0..m).map(move |j| (i, j)))
        .map(|(i, j)| a[i][j] * a[i][j])
        .sum::<f64>()
        .sqrt();
    for _sweep in 0..64 {
        let off: f64 = (0..m)
            .flat_map(|i| (0..m).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum::<f64>()
            .sqrt();
        if off <= 1e-15 * norm || norm == 0.0 {
            break;
        }
        for p in 0..m {
            for q in p + 1..m {
                if a[p][q].abs() <= 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut().take(m) {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (mut rp, mut rq) = (a[p], a[q]);
                for (x, y) in rp.iter_mut().zip(rq.iter_mut()).take(m) {
                    let (apk, aqk) = (*x, *y);
                    *x = c * apk - s * aqk;
                    *y = s * apk + c * aqk;
                }
                (a[p], a[q]) = (rp, rq);
                for row in v.iter_mut().take(m) {
                    let (vkp, vkq) = (row[p], row[q]);
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    let mut values = [0.0; MAX_DIM];
    for (i, value) in values.iter_mut().enumerate().take(m) {
        *value = a[i][i];
    }
    (values, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64, z: f64) -> [f64; MAX_DIM] {
        let mut v = [0.0; MAX_DIM];
        v[..3].copy_from_slice(&[x, y, z]);
        v
    }

    fn area(a: &[f64], b: &[f64], c: &[f64]) -> f64 {
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
    }

    fn add(q: &mut Quadric, a: [f64; MAX_DIM], b: [f64; MAX_DIM], c: [f64; MAX_DIM]) {
        q.add_triangle(&a, &b, &c, area(&a, &b, &c));
    }

    #[test]
    fn a_planes_quadric_is_zero_on_it_and_grows_off_it() {
        // The plane z = 0.5, two triangles; with a colour linear over it (3 + 4 dims).
        let mut q = Quadric::new(3);
        let mut g = Quadric::new(7);
        let colour = |x: f64, y: f64| {
            let mut v = p(x, y, 0.5);
            v[3] = 0.2 + 0.5 * x;
            v[4] = 0.1 * y;
            v[5] = 0.3;
            v[6] = 1.0;
            v
        };
        for (a, b, c) in [
            ((0., 0.), (1., 0.), (1., 1.)),
            ((0., 0.), (1., 1.), (0., 1.)),
        ] {
            add(&mut q, p(a.0, a.1, 0.5), p(b.0, b.1, 0.5), p(c.0, c.1, 0.5));
            add(&mut g, colour(a.0, a.1), colour(b.0, b.1), colour(c.0, c.1));
        }
        for (x, y) in [(0.3, 0.7), (5.0, -2.0), (0.0, 0.0)] {
            assert!(q.error(&p(x, y, 0.5)) < 1e-12);
            assert!(g.error(&colour(x, y)) < 1e-12);
        }
        // Off the plane by 0.25: the squared distance times the total area (1).
        assert!((q.error(&p(0.3, 0.3, 0.75)) - 0.0625).abs() < 1e-12);
        // The right position with the wrong colour costs too.
        let mut wrong = colour(0.5, 0.5);
        wrong[3] += 0.1;
        assert!(g.error(&wrong) > 1e-3);
        // The optimum lies on the plane, at the centroid (the plane leaves x, y free), with
        // the colour the plane gives there.
        let o = g.optimum();
        assert!((o[2] - 0.5).abs() < 1e-9);
        let expected = colour(o[0], o[1]);
        for k in 0..7 {
            assert!((o[k] - expected[k]).abs() < 1e-9, "{o:?}");
        }
        assert!((o[0] - 0.5).abs() < 1e-9 && (o[1] - 0.5).abs() < 1e-9);
    }

    /// Triangles of the three faces x = 0, y = 0, z = 0 meeting at `corner` (offsets in
    /// the positive octant), and of two of them for a crease.
    fn faces(q: &mut Quadric, corner: [f64; 3], axes: &[usize]) {
        for &axis in axes {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let at = |a: f64, b: f64| {
                let mut x = p(corner[0], corner[1], corner[2]);
                x[u] += a;
                x[v] += b;
                x
            };
            add(q, at(0.0, 0.0), at(1.0, 0.0), at(1.0, 1.0));
            add(q, at(0.0, 0.0), at(1.0, 1.0), at(0.0, 1.0));
        }
    }

    #[test]
    fn the_pseudo_inverse_finds_a_corner_and_stays_on_a_crease() {
        let corner = [0.2, -0.3, 0.7];
        let mut q = Quadric::new(3);
        faces(&mut q, corner, &[0, 1, 2]);
        let o = q.optimum();
        for k in 0..3 {
            assert!((o[k] - corner[k]).abs() < 1e-9, "{o:?}");
        }
        // Two faces (x = 0.2 and y = -0.3): the crease is the line along z; A is singular
        // there, and the pseudo-inverse keeps the centroid's z.
        let mut q = Quadric::new(3);
        faces(&mut q, corner, &[0, 1]);
        let o = q.optimum();
        let c = q.centroid();
        assert!(
            (o[0] - 0.2).abs() < 1e-9 && (o[1] + 0.3).abs() < 1e-9,
            "{o:?}"
        );
        assert!((o[2] - c[2]).abs() < 1e-9);
        assert!(q.error(&o) < 1e-12);
    }

    #[test]
    fn attributes_refit_at_a_fixed_position() {
        let mut g = Quadric::new(4);
        let at = |x: f64, y: f64| {
            let mut v = p(x, y, 0.0);
            v[3] = x + 2.0 * y;
            v
        };
        add(&mut g, at(0., 0.), at(1., 0.), at(0., 1.));
        let mut v = p(0.5, 0.25, 0.0);
        v[3] = 7.0;
        g.optimum_attributes(&mut v);
        assert!((v[3] - 1.0).abs() < 1e-9, "{v:?}");
        assert_eq!(v[..3], [0.5, 0.25, 0.0]);
    }

    #[test]
    fn jacobi_diagonalises() {
        let mut m = [[0.0; MAX_DIM]; MAX_DIM];
        let rows = [[4.0, 1.0, 2.0], [1.0, 3.0, 0.5], [2.0, 0.5, 5.0]];
        for i in 0..3 {
            m[i][..3].copy_from_slice(&rows[i]);
        }
        let (l, v) = symmetric_eigen(&m, 3);
        for k in 0..3 {
            for i in 0..3 {
                let mv: f64 = (0..3).map(|j| m[i][j] * v[j][k]).sum();
                assert!((mv - l[k] * v[i][k]).abs() < 1e-10);
            }
        }
    }
}
