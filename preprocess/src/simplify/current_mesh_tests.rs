//! Tests of the use counts (`current_mesh.rs`).

use super::*;

/// Vertex 0 in `n` triangles of a fan over vertices 1..=n+1, and unused vertices up to
/// past the first shard's end.
fn fan(n: u32) -> InputMesh {
    let rim = n + 1 + (1 << SHARD_BITS);
    InputMesh {
        positions: (0..=rim).map(|i| [i as f64, 0.0, 0.0]).collect(),
        triangles: (0..n).map(|i| [0, i + 1, i + 2]).collect(),
        ..Default::default()
    }
}

#[test]
fn a_shard_keeps_each_vertex_count_across_the_escape() {
    // Odd length: the last byte's high nibble is padding.
    let mut shard = Shard::zeroed(7);
    let mut expected = [0u32; 7];
    let steps = [
        (0, 14),
        (1, 15),
        (2, 16),
        (1, 3),
        (0, 15),
        (6, 300),
        (5, 1),
        (2, 14),
        (6, 14),
        (0, 0),
        (3, u32::MAX),
        (4, 9),
        (3, 15),
        (3, 2),
    ];
    for (at, n) in steps {
        shard.set(at, n);
        expected[at] = n;
        let got: Vec<u32> = (0..7).map(|i| shard.get(i)).collect();
        assert_eq!(got, expected, "after setting vertex {at} to {n}");
    }
    assert!(shard.large.is_empty() || shard.large.keys().all(|&k| expected[k as usize] >= 15));
    assert_eq!(shard.nibbles.len(), 4);
}

#[test]
fn counts_of_255_and_more_survive_merges_and_the_checkpoint() {
    let mesh = fan(300);
    let mut current = CurrentMesh::new(&mesh);
    assert_eq!(current.use_count(0), 300);
    assert_eq!(current.use_count(1), 1);
    assert_eq!(current.use_count(2), 2);
    // Down across 255 and up again; a vertex of the second shard too.
    let second = 1 << SHARD_BITS;
    for (change, expected) in [(-100, 200), (-1, 199), (60, 259), (-4, 255), (-1, 254)] {
        let mut changes = CountChanges {
            vertices: vec![(0, change), (second, 1)],
            tracked_edges: Vec::new(),
        };
        changes.sort_by_shard();
        current.merge(std::iter::once(&changes));
        assert_eq!(current.use_count(0), expected, "after {change}");
    }
    assert_eq!(current.use_count(second), 5);
    // Through the checkpoint's encoding and back: the same counts.
    let mut e = crate::checkpoint::Enc::default();
    current.encode(&mut e);
    let bytes = e.into_bytes();
    let mut d = crate::checkpoint::Dec::new(&bytes);
    let back = CurrentMesh::decode(&mut d, mesh.positions.len()).unwrap();
    d.finish().unwrap();
    for v in 0..mesh.positions.len() as u32 {
        assert_eq!(back.use_count(v), current.use_count(v), "vertex {v}");
    }
    // A fan of 255 and more straight from the input, and after a merge that adds to it.
    let big = CurrentMesh::new(&fan(1000));
    assert_eq!(big.use_count(0), 1000);
}

#[test]
fn counts_within_a_budget_are_the_counts_in_memory() {
    // A fan with fins: edges (0, i) of three and four triangles.
    let mut mesh = fan(600);
    let far = mesh.positions.len() as u32 - 1;
    for i in (1..600).step_by(7) {
        mesh.triangles.push([0, i, far - i]);
        if i % 2 == 1 {
            mesh.triangles.push([i, 0, far - i - 1]);
        }
    }
    let encoded = |current: &CurrentMesh| {
        let mut e = crate::checkpoint::Enc::default();
        current.encode(&mut e);
        e.into_bytes()
    };
    let expected = encoded(&CurrentMesh::new(&mesh));
    assert!(CurrentMesh::new(&mesh).may_have_nonmanifold());
    let dir = tempfile::tempdir().unwrap();
    for budget in [1 << 20, 8 * 400, 8 * 64, 8] {
        let within = CurrentMesh::new_within(&mesh, budget, dir.path()).unwrap();
        assert_eq!(encoded(&within), expected, "budget {budget}");
    }
}
