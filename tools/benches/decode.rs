//! Decoding coded and packed patches (issues 15 and 49: >= 1 GB/s of decoded data per core).
//!
//! `cargo bench -p tessera-tools --bench decode`: builds the demo mesh (subdivision 7, 327,680
//! triangles with normals) coded (`coded`, the default since issue 49), then times
//! `Repository::read_patch` over every patch on one thread — the loader's work for a unit —
//! against the same patches packed (`packed`, the format before it), packed with the strip
//! coding before commit 4fa9fc2 of 2026-12-03 (`packed-v1`, meshoptimizer's index-sequence
//! codec) and the same reads from an unpacked build (a copy out of the map). Throughput is
//! decoded bytes: what the GPU receives.
//!
//! `TESSERA_DECODE_REPOS=a.tsr,b.tsr` adds the repositories named (e.g. the dragon built and
//! repacked with `tessera repack --codec coded|packed|raw`), each timed the same way under its
//! file name, and prints where a coded repository's bytes go (every patch decoded and coded
//! again by `coded::code_patch_parts`), per input triangle.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use tessera_core::repository::coded::{code_patch_parts, CodedParts};
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

/// Prints where `repo`'s bytes would go coded: per input triangle, each part of the coded
/// patches, the id blob and the rest (directory, header, alignment).
fn print_parts(name: &str, repo: &Repository) {
    let (mut parts, mut coded, mut out) = (CodedParts::default(), Vec::new(), Vec::new());
    let mut patches = 0u64;
    for (i, t) in repo.tets().iter().enumerate() {
        out.resize(repo.decoded_patch_bytes(i).expect("record"), 0);
        repo.read_patch(i, &mut out).expect("decodes");
        coded.clear();
        let (size, p) = code_patch_parts(
            &out,
            t.vertex_count as usize,
            t.strip_index_count as usize,
            repo.header().attributes,
            &mut coded,
        );
        patches += size as u64;
        parts.header += p.header;
        parts.strip += p.strip;
        parts.positions += p.positions;
        parts.attributes += p.attributes;
        parts.padding += p.padding;
    }
    let triangles = repo.header().input_triangle_count.max(1) as f64;
    let ids = repo.id_blob().len() as u64;
    let file = repo.file_bytes();
    let rest = file as f64 - repo.patch_blob().len() as f64 - ids as f64;
    eprintln!(
        "{name}: {file} B ({:?}), {triangles} input triangles; coded patches {patches} B; per \
         input triangle: positions {:.3}, strips {:.3}, attributes {:.3}, tables and lengths \
         {:.3}, padding and final states {:.3}, ids {:.3}, directory and header {:.3}; total \
         coded {:.3} B",
        repo.codec(),
        parts.positions / triangles,
        parts.strip / triangles,
        parts.attributes / triangles,
        parts.header / triangles,
        parts.padding / triangles,
        ids as f64 / triangles,
        rest / triangles,
        (patches + ids) as f64 / triangles + rest / triangles,
    );
}

fn decode(c: &mut Criterion) {
    let mut group = c.benchmark_group("read_patch");
    let mut repos: Vec<(String, Repository)> = [
        ("coded", PatchCodec::Coded),
        ("packed", PatchCodec::Packed),
        ("packed-v1", PatchCodec::PackedV1),
        ("raw", PatchCodec::Raw),
    ]
    .into_iter()
    .map(|(name, codec)| (name.to_string(), repository(codec)))
    .collect();
    for path in std::env::var("TESSERA_DECODE_REPOS")
        .unwrap_or_default()
        .split(',')
        .filter(|p| !p.is_empty())
    {
        let repo = Repository::open(std::path::Path::new(path)).expect("a repository");
        let name = std::path::Path::new(path).file_name().expect("a file name");
        let name = name.to_string_lossy().into_owned();
        print_parts(&name, &repo);
        repos.push((name, repo));
    }
    for (name, repo) in &repos {
        let mut out = Vec::new();
        let decoded = read_all(repo, &mut out) as u64;
        eprintln!(
            "{name}: {} patches, {decoded} bytes decoded from {} stored",
            repo.tets().len(),
            repo.patch_blob().len()
        );
        group.throughput(Throughput::Bytes(decoded));
        group.bench_function(name, |b| b.iter(|| read_all(repo, &mut out)));
    }
    group.finish();
}

criterion_group!(benches, decode);
criterion_main!(benches);
