//! Packed repositories of the real scans and terrains (issue 15): every patch decodes to the
//! bytes the uncompressed build stores, the directories agree but for where the patches lie,
//! and the packed file is smaller.

use tessera_core::repository::{PatchCodec, Repository, TetRecord};
use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{BuildConfig, Domain, InputMesh};
use tessera_tests::{build, testdata};

/// The record without the fields that say where the stored patch lies.
fn placement_free(t: &TetRecord) -> TetRecord {
    TetRecord {
        patch_offset: 0,
        patch_bytes: 0,
        patch_checksum: 0,
        ..*t
    }
}

fn same_patches(name: &str, mesh: &InputMesh, config: BuildConfig) {
    let packed = build(
        mesh,
        &BuildConfig {
            codec: PatchCodec::Packed,
            ..config.clone()
        },
    );
    let raw = build(
        mesh,
        &BuildConfig {
            codec: PatchCodec::Raw,
            ..config
        },
    );
    let (p, r): (&Repository, &Repository) = (&packed.repo, &raw.repo);
    assert_eq!(
        (p.codec(), r.codec()),
        (PatchCodec::Packed, PatchCodec::Raw)
    );
    // The header's checksum covers the section table, which names the patch blob's kind.
    let unsealed = |h: &tessera_core::repository::Header| tessera_core::repository::Header {
        checksum: 0,
        ..*h
    };
    assert_eq!(
        unsealed(p.header()),
        unsealed(r.header()),
        "{name}: headers"
    );
    assert_eq!(p.diamonds(), r.diamonds(), "{name}: diamond tables");
    assert_eq!(p.id_blob(), r.id_blob(), "{name}: id blobs");
    let mut decoded = Vec::new();
    for (i, (a, b)) in p.tets().iter().zip(r.tets()).enumerate() {
        assert_eq!(placement_free(a), placement_free(b), "{name}: tet {i}");
        decoded.resize(p.decoded_patch_bytes(i).unwrap(), 0);
        p.read_patch(i, &mut decoded).unwrap();
        assert!(
            decoded == r.patch_bytes(i).unwrap(),
            "{name}: tet {i} decodes to other bytes"
        );
    }
    assert!(
        p.file_bytes() < r.file_bytes(),
        "{name}: packed {} B, raw {} B",
        p.file_bytes(),
        r.file_bytes()
    );
    eprintln!(
        "{name}: packed {} B, raw {} B ({:.2}x)",
        p.file_bytes(),
        r.file_bytes(),
        r.file_bytes() as f64 / p.file_bytes() as f64
    );
}

#[test]
fn every_packed_patch_of_the_scans_decodes_to_the_uncompressed_build() {
    for name in [
        "mesh/bunny00.off",
        "mesh/armadillo.off",
        "mesh/lion-head.off",
        "mesh/dragon_vrip_res2.ply.gz",
    ] {
        let mesh = load_mesh(&testdata(name)).unwrap().mesh;
        same_patches(name, &mesh, BuildConfig::default());
    }
}

#[test]
fn every_packed_patch_of_the_terrains_decodes_to_the_uncompressed_build() {
    for name in ["dem/volcano.json", "dem/jacksboro_fault_dem.npz"] {
        let grid = load_dem(&testdata(name), &DemOptions::default()).unwrap();
        let mesh = grid.to_mesh(&TerrainOptions::default());
        same_patches(name, &mesh, BuildConfig::for_domain(Domain::HeightField));
    }
}
