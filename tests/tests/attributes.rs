//! Normals, colours and UVs of the input survive into every patch, by global vertex id.

use tessera_core::repository::format::{dequantize_position, oct_decode_normal};
use tessera_preprocess::procedural::demo_mesh;
use tessera_preprocess::BuildConfig;
use tessera_tests::build;

#[test]
fn attributes_survive_into_every_patch() {
    let mesh = tessera_tests::attributed_demo_mesh(4);
    let n = mesh.positions.len();
    let built = build(
        &mesh,
        &BuildConfig {
            construction: tessera_preprocess::Construction::LeafTriangles(64),
            ..Default::default()
        },
    );
    let repo = &built.repo;
    let h = repo.header();
    assert_eq!(h.attributes, 7, "normals, colours and uvs are all stored");
    let normals = mesh.normals.as_ref().unwrap();
    let (colors, uvs) = (mesh.colors.as_ref().unwrap(), mesh.uvs.as_ref().unwrap());
    let mut checked = 0;
    for i in 0..repo.tets().len() {
        let patch = repo.patch(i).unwrap();
        let patch = patch.view();
        let (pn, pc, pu) = (
            patch.normals().unwrap(),
            patch.colors().unwrap(),
            patch.uvs().unwrap(),
        );
        for (local, g) in patch.global_ids().enumerate() {
            let g = g as usize;
            assert_eq!(pc[local], colors[g]);
            assert_eq!(pu[local], uvs[g]);
            let d = oct_decode_normal(pn[local]);
            let dot: f32 = (0..3).map(|k| d[k] * normals[g][k]).sum();
            assert!(
                dot > 0.9999,
                "normal of vertex {g} changed: {d:?} vs {:?}",
                normals[g]
            );
            let p = dequantize_position(patch.position(local), h.bbox_min, h.position_step);
            for ((got, want), step) in p.iter().zip(mesh.positions[g]).zip(h.position_step) {
                assert!((got - want).abs() <= step, "position of {g}");
            }
            checked += 1;
        }
    }
    assert!(
        checked > n,
        "every level's patches were checked ({checked} vertices)"
    );
}

#[test]
fn a_mesh_without_attributes_stores_none() {
    let mut mesh = demo_mesh(3);
    mesh.normals = None;
    let built = build(&mesh, &BuildConfig::default());
    assert_eq!(built.repo.header().attributes, 0);
    assert!(built.repo.patch(0).unwrap().view().normals().is_none());
}
