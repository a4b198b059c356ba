//! The 10-bit octahedral normal grid the build stores normals on (`format::oct_encode_normal_grid`,
//! issue 49): every encoding is on the grid, decodes within the proven worst-case angle, and
//! re-encoding a decoded grid normal gives the same bytes.

use tessera_core::repository::format::{
    normal_grid_max_angle, oct_decode_normal, oct_encode_normal_grid,
};

fn angle(n: [f32; 3], d: [f32; 3]) -> f64 {
    let (n, d) = (n.map(f64::from), d.map(f64::from));
    let c = [
        n[1] * d[2] - n[2] * d[1],
        n[2] * d[0] - n[0] * d[2],
        n[0] * d[1] - n[1] * d[0],
    ];
    let sin = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    sin.atan2(n[0] * d[0] + n[1] * d[1] + n[2] * d[2])
}

#[test]
fn grid_normals_within_bound_and_idempotent() {
    let bound = normal_grid_max_angle();
    // 0.2379° for 511 steps: what the eye cannot see in shading (issue 49).
    assert!(bound < 0.0043, "{bound}");
    let mut worst = 0.0f64;
    let count = 200_000;
    for i in 0..count {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
        let r = (1.0 - z * z).sqrt();
        let phi = i as f32 * 2.399_963;
        let n = [r * phi.cos(), r * phi.sin(), z];
        let e = oct_encode_normal_grid(n);
        // On the grid: every component is round(k · 32767 / 511).
        for v in e {
            let k = (v as f64 * 511.0 / 32767.0).round();
            assert_eq!(v, (k * 32767.0 / 511.0).round() as i16);
        }
        let d = oct_decode_normal(e);
        worst = worst.max(angle(n, d));
        assert_eq!(oct_encode_normal_grid(d), e, "not idempotent at {n:?}");
    }
    // Coarser than the 16-bit grid, and within the proven bound.
    assert!(
        worst > 1e-3 && worst <= bound,
        "worst {worst} bound {bound}"
    );
    for n in [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
    ] {
        let d = oct_decode_normal(oct_encode_normal_grid(n));
        assert!(angle(n, d) < 1e-4, "{n:?} -> {d:?}");
    }
    assert_eq!(oct_encode_normal_grid([0.0; 3]), [0, 0]);
    assert_eq!(oct_encode_normal_grid([f32::NAN, 0.0, 1.0]), [0, 0]);
}
