//! Coded repositories of the real scans (issue 49): every patch of the bunny's and the
//! dragon's builds (with the normals `tessera build` computes) codes and decodes to exactly
//! the bytes the uncompressed build stores, a build with the coded codec stores the same
//! patches, and the coded patches are smaller than the packed ones. Prints where the bytes go.
//!
//! `cargo test --release -p tessera-tests --test coded_scans -- --nocapture` prints the table.

use tessera_core::repository::coded::{code_patch_parts, decode_patch, CodedParts};
use tessera_core::repository::packed::{pack_patch, StripCoding};
use tessera_core::repository::{PatchCodec, Repository};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::normals::compute_missing_normals;
use tessera_preprocess::BuildConfig;
use tessera_tests::{build, testdata};

fn code_every_patch(name: &str, raw: &Repository, input_triangles: u64) -> (u64, u64) {
    let attributes = raw.header().attributes;
    let (mut total, mut packed_total) = (CodedParts::default(), 0u64);
    let (mut coded, mut packed, mut out) = (Vec::new(), Vec::new(), Vec::new());
    let mut coded_total = 0u64;
    for (i, t) in raw.tets().iter().enumerate() {
        let bytes = raw.patch_bytes(i).unwrap();
        let (n, m) = (t.vertex_count as usize, t.strip_index_count as usize);
        coded.clear();
        let (size, parts) = code_patch_parts(bytes, n, m, attributes, &mut coded);
        out.clear();
        out.resize(bytes.len(), 0xAA);
        decode_patch(&coded, n, m, attributes, &mut out)
            .unwrap_or_else(|e| panic!("{name}: tet {i}: {e}"));
        assert!(out == bytes, "{name}: tet {i} decodes to other bytes");
        coded_total += size as u64;
        total.header += parts.header;
        total.strip += parts.strip;
        total.positions += parts.positions;
        total.attributes += parts.attributes;
        total.padding += parts.padding;
        packed.clear();
        packed_total +=
            pack_patch(bytes, n, m, attributes, StripCoding::Nibbles, &mut packed) as u64;
    }
    let per = |b: f64| b / input_triangles as f64;
    let vertices: u64 = raw.tets().iter().map(|t| t.vertex_count as u64).sum();
    let indices: u64 = raw.tets().iter().map(|t| t.strip_index_count as u64).sum();
    eprintln!(
        "{name}: {} tets, {vertices} stored vertices, {indices} strip indices, attributes \
         {attributes:#x}; patches coded {coded_total} B, packed {packed_total} B, raw {} B",
        raw.tets().len(),
        raw.patch_blob().len()
    );
    eprintln!(
        "{name}: per input triangle: tables+lengths {:.3} B, strip {:.3} B ({:.2} bits an \
         index), positions {:.3} B ({:.1} bits a vertex), attributes {:.3} B ({:.1} bits a \
         vertex), padding+state {:.3} B; ids {:.3} B, directory {:.3} B",
        per(total.header),
        per(total.strip),
        8.0 * total.strip / indices as f64,
        per(total.positions),
        8.0 * total.positions / vertices as f64,
        per(total.attributes),
        8.0 * total.attributes / vertices as f64,
        per(total.padding),
        per(raw.id_blob().len() as f64),
        per((raw.file_bytes() - raw.patch_blob().len() as u64 - raw.id_blob().len() as u64) as f64),
    );
    (coded_total, packed_total)
}

#[test]
fn every_coded_patch_of_the_scans_decodes_to_the_uncompressed_build() {
    for name in ["mesh/bunny00.off", "mesh/dragon_vrip.ply.gz"] {
        let mut mesh = load_mesh(&testdata(name)).unwrap().mesh;
        // As `tessera build` does by default.
        compute_missing_normals(&mut mesh);
        let config = |codec| BuildConfig {
            codec,
            ..BuildConfig::default()
        };
        let raw = build(&mesh, &config(PatchCodec::Raw));
        let triangles = raw.repo.header().input_triangle_count;
        let (coded, packed) = code_every_patch(name, &raw.repo, triangles);
        assert!(coded < packed, "{name}: coded {coded} B, packed {packed} B");
        // The build's own coding: the same patches, the same coded bytes.
        let built = build(&mesh, &config(PatchCodec::Coded));
        let c = &built.repo;
        assert_eq!(c.codec(), PatchCodec::Coded);
        assert_eq!(
            c.patch_blob().len() as u64,
            coded,
            "{name}: the build's blob"
        );
        let mut decoded = Vec::new();
        for i in 0..c.tets().len() {
            decoded.resize(c.decoded_patch_bytes(i).unwrap(), 0);
            c.read_patch(i, &mut decoded).unwrap();
            assert!(
                decoded == raw.repo.patch_bytes(i).unwrap(),
                "{name}: tet {i}"
            );
        }
        c.validate_patches().unwrap();
    }
}
