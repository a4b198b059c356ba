//! Decoding packed patches (issue 15: >= 1 GB/s of decoded data per core).
//!
//! `cargo bench -p tessera-tools --bench decode`: builds the demo mesh (subdivision 7, 327,680
//! triangles with normals) packed, then times `Repository::read_patch` over every patch on one
//! thread — the loader's work for a unit — against the same patches packed with the strip
//! coding before commit 4fa9fc2 of 2026-12-03 (`packed-v1`, meshoptimizer's index-sequence codec) and
//! the same reads from an unpacked build (a copy out of the map). Throughput is decoded bytes:
//! what the GPU receives.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use tessera_core::repository::{write_repository, PatchCodec, Repository};
use tessera_preprocess::procedural::demo_mesh;
use tessera_preprocess::{build_contents, BuildConfig};

fn repository(codec: PatchCodec) -> Repository {
    let config = BuildConfig {
        codec,
        threads: Some(1),
        ..BuildConfig::default()
    };
    let (contents, _) = build_contents(&demo_mesh(7), &config, &|_| {}).expect("demo build");
    let mut bytes = Vec::new();
    write_repository(&mut bytes, &contents).expect("in-memory write");
    Repository::from_bytes(bytes).expect("opens")
}

fn read_all(repo: &Repository, out: &mut Vec<u8>) -> usize {
    let mut total = 0;
    for i in 0..repo.tets().len() {
        let size = repo.decoded_patch_bytes(i).expect("record");
        out.resize(size, 0);
        repo.read_patch(i, out).expect("decodes");
        total += size;
    }
    total
}

fn decode(c: &mut Criterion) {
    let mut group = c.benchmark_group("read_patch");
    for (name, codec) in [
        ("packed", PatchCodec::Packed),
        ("packed-v1", PatchCodec::PackedV1),
        ("raw", PatchCodec::Raw),
    ] {
        let repo = repository(codec);
        let mut out = Vec::new();
        let decoded = read_all(&repo, &mut out) as u64;
        eprintln!(
            "{name}: {} patches, {decoded} bytes decoded from {} stored",
            repo.tets().len(),
            repo.patch_blob().len()
        );
        group.throughput(Throughput::Bytes(decoded));
        group.bench_function(name, |b| b.iter(|| read_all(&repo, &mut out)));
    }
    group.finish();
}

criterion_group!(benches, decode);
criterion_main!(benches);
