//! Finished patches: each simplex's patch encoded (strips, quantised positions, attributes,
//! global ids) as soon as it is final — the leaves' when the levels start, a diamond's
//! simplices' when the diamond is merged — with its bounding sphere, normal cone and checksum.
//! The simplifier then keeps only the live patches' triangles, and the writer streams the
//! encoded bytes into the repository in table order (`write_repository_streamed`).
//!
//! The bytes are kept in memory, or under a memory budget in two unnamed temporary files
//! (counted in `temp_bytes_peak`), read back one patch at a time when the file is written.
//! Under a budget the records the tables need (sphere, cone, counts, where the bytes are) go
//! to a third file, and memory keeps 20 bytes a simplex: its key and its record's row.
//! Either way the repository is the same bytes: a patch's encoding depends only on its
//! triangles (in the simplifier's order) and the input's positions and attributes.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::os::unix::fs::FileExt;
use std::path::Path;

use rayon::prelude::*;
use tessera_core::bounds::{NormalCone, Sphere};
use tessera_core::leb::SimplexKey;
use tessera_core::repository::format::{patch_checksum, PatchCodec};
use tessera_core::repository::packed::{pack_patch, StripCoding};
use tessera_core::repository::patch::{encode_patch, patch_bytes};
use tessera_core::repository::BlobFeed;

use crate::external::temp_usage::{Charge, TempKind};
use crate::packed_key::PackedKey;
use crate::strips::build_patch;
use crate::vertex_table::LivePatch;

mod checkpoint;
mod records;

use records::Records;

/// What the tet table needs of one encoded patch.
#[derive(Clone, Copy, Debug)]
pub struct FinishedPatch {
    /// Bounding sphere of the patch's vertices (their input positions relative to the
    /// repository origin).
    pub sphere: Sphere,
    pub cone: NormalCone,
    pub vertex_count: u32,
    pub strip_index_count: u32,
    pub triangle_count: u32,
    pub patch_bytes: u32,
    pub id_bytes: u32,
    pub patch_checksum: u32,
    /// Where its bytes are in the store.
    patch_at: u64,
    id_at: u64,
}

/// How a patch is encoded: how its vertices are numbered (`local_mesh`'s table: the input's
/// vertex count, or none under a memory budget), the repository origin and the position grid
/// (the positions and attributes are the patch's own).
pub struct PatchEncoding {
    pub numbering_table: Option<usize>,
    pub origin: [f64; 3],
    pub bbox_min: [f64; 3],
    pub step: [f64; 3],
    pub attributes: u32,
    /// Raw, or packed as it is encoded (`packed::pack_patch`).
    pub codec: PatchCodec,
    /// Which wedges start a vertex: a patch vertex's stored global id is its vertex's
    /// (`canonical`), so two wedges of one vertex share it (`mesh.rs`).
    pub vertex_starts: crate::mesh::VertexStarts,
}

/// Every finished patch by simplex, and its encoded bytes.
pub struct FinishedPatches {
    /// Each simplex's key and its row in `records`, appended as patches finish and sorted by
    /// key before the first lookup ([`Self::seal`]): 20 bytes a simplex (at 100 M input
    /// triangles, 1.6 M simplices: 32 MB; the records beside the keys took 166 MB).
    index: Vec<(PackedKey, u32)>,
    sorted: bool,
    records: Records,
    store: Store,
}

enum Store {
    Memory { patches: Vec<u8>, ids: Vec<u8> },
    Disk { patches: Spill, ids: Spill },
}

/// An unnamed append-only file, read back by ranges.
struct Spill {
    writer: BufWriter<File>,
    bytes: u64,
    charge: Charge,
    /// CRC-32 of the bytes appended (a checkpoint's record of the file).
    crc: crc32fast::Hasher,
}

impl Spill {
    fn new(dir: &Path) -> io::Result<Spill> {
        Ok(Spill::at_end(tempfile::tempfile_in(dir)?, 0, 0))
    }

    /// Appending to `file`, which holds `bytes` bytes of CRC-32 `crc` (positioned at its end).
    fn at_end(file: File, bytes: u64, crc: u32) -> Spill {
        let charge = Charge::new(TempKind::FinishedPatches);
        charge.grow(bytes);
        Spill {
            writer: BufWriter::with_capacity(1 << 20, file),
            bytes,
            charge,
            crc: crc32fast::Hasher::new_with_initial_len(crc, bytes),
        }
    }

    fn append(&mut self, bytes: &[u8]) -> io::Result<u64> {
        let at = self.bytes;
        self.writer.write_all(bytes)?;
        self.crc.update(bytes);
        self.bytes += bytes.len() as u64;
        self.charge.grow(bytes.len() as u64);
        Ok(at)
    }

    fn read(&mut self, at: u64, len: usize, out: &mut Vec<u8>) -> io::Result<()> {
        self.writer.flush()?;
        let start = out.len();
        out.resize(start + len, 0);
        self.writer.get_ref().read_exact_at(&mut out[start..], at)
    }
}

/// Patches encoded per parallel task before they are appended (bounds the encoded bytes
/// held at once).
const CHUNK: usize = 1024;

impl FinishedPatches {
    /// A store in memory, or in unnamed files in `spill_dir`.
    pub fn new(spill_dir: Option<&Path>) -> io::Result<FinishedPatches> {
        let store = match spill_dir {
            None => Store::Memory {
                patches: Vec::new(),
                ids: Vec::new(),
            },
            Some(dir) => Store::Disk {
                patches: Spill::new(dir)?,
                ids: Spill::new(dir)?,
            },
        };
        let records = match spill_dir {
            None => Records::Memory(Vec::new()),
            Some(dir) => Records::Disk(Spill::new(dir)?),
        };
        Ok(FinishedPatches {
            index: Vec::new(),
            sorted: true,
            records,
            store,
        })
    }

    /// Makes room in the index for `simplices` patches in all, so that it never grows by
    /// doubling (which holds the old and the new index at once).
    pub fn reserve(&mut self, simplices: usize) {
        self.index
            .reserve_exact(simplices.saturating_sub(self.index.len()));
        self.records.reserve(simplices);
    }

    /// Sorts the index for lookups and makes every record readable; panics if a simplex was
    /// finished twice.
    pub fn seal(&mut self) -> io::Result<()> {
        if let Some(key) = self.sort_index() {
            panic!("simplex {key:?} finished twice");
        }
        self.records.flush()
    }

    /// Sorts the index; returns a simplex it holds twice, if any.
    fn sort_index(&mut self) -> Option<SimplexKey> {
        if !self.sorted {
            self.index.par_sort_unstable_by_key(|(k, _)| *k);
            self.sorted = true;
        }
        self.index
            .windows(2)
            .find(|w| w[0].0 == w[1].0)
            .map(|w| w[0].0.key())
    }

    /// Encodes (in parallel) and stores the patches of these simplices; each simplex once.
    pub fn add(
        &mut self,
        patches: &[(SimplexKey, &LivePatch)],
        encoding: &PatchEncoding,
    ) -> io::Result<()> {
        for chunk in patches.chunks(CHUNK) {
            let encoded: Vec<(Vec<u8>, Vec<u8>, FinishedPatch)> = chunk
                .par_iter()
                .map(|&(_, patch)| encode(patch, encoding))
                .collect();
            for (&(key, _), (bytes, ids, mut patch)) in chunk.iter().zip(encoded) {
                (patch.patch_at, patch.id_at) = match &mut self.store {
                    Store::Memory { patches, ids: all } => {
                        let at = (patches.len() as u64, all.len() as u64);
                        patches.extend_from_slice(&bytes);
                        all.extend_from_slice(&ids);
                        at
                    }
                    Store::Disk { patches, ids: all } => {
                        (patches.append(&bytes)?, all.append(&ids)?)
                    }
                };
                let packed = PackedKey::of_hierarchy(key);
                let row = self.records.push(packed, &patch)?;
                self.index.push((packed, row));
                self.sorted = false;
            }
        }
        Ok(())
    }

    /// The row of `key`'s record. Panics when it has none (every simplex of the hierarchy
    /// gets one) or when the index is not [sealed](Self::seal).
    pub fn row(&self, key: SimplexKey) -> u32 {
        assert!(
            self.sorted,
            "finished patches looked up before they were sealed"
        );
        PackedKey::of(key)
            .and_then(|k| self.index.binary_search_by_key(&k, |(k, _)| *k).ok())
            .map(|i| self.index[i].1)
            .unwrap_or_else(|| panic!("simplex {key:?} has no finished patch"))
    }

    /// The record of `row` ([`Self::row`]).
    pub fn record(&self, row: u32) -> io::Result<FinishedPatch> {
        self.records.get(row)
    }

    /// The finished patch of `key` (see [`Self::row`]).
    pub fn get(&self, key: SimplexKey) -> io::Result<FinishedPatch> {
        self.record(self.row(key))
    }

    /// Feeds the writer the patches of `order` (the tet table's rows in the records, in
    /// table order).
    pub fn feed<'a>(&'a mut self, order: &'a [u32]) -> impl BlobFeed + 'a {
        Feed {
            patches: self,
            order,
            last: None,
        }
    }
}

struct Feed<'a> {
    patches: &'a mut FinishedPatches,
    order: &'a [u32],
    /// The last tet's record: its patch and then its ids are asked for.
    last: Option<(usize, FinishedPatch)>,
}

impl Feed<'_> {
    fn record(&mut self, tet: usize) -> io::Result<FinishedPatch> {
        match self.last {
            Some((t, p)) if t == tet => Ok(p),
            _ => {
                let p = self.patches.record(self.order[tet])?;
                self.last = Some((tet, p));
                Ok(p)
            }
        }
    }
}

impl BlobFeed for Feed<'_> {
    fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        let p = self.record(tet)?;
        match &mut self.patches.store {
            Store::Memory { patches, .. } => {
                let at = p.patch_at as usize;
                out.extend_from_slice(&patches[at..at + p.patch_bytes as usize]);
                Ok(())
            }
            Store::Disk { patches, .. } => patches.read(p.patch_at, p.patch_bytes as usize, out),
        }
    }

    fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        let p = self.record(tet)?;
        match &mut self.patches.store {
            Store::Memory { ids, .. } => {
                let at = p.id_at as usize;
                out.extend_from_slice(&ids[at..at + p.id_bytes as usize]);
                Ok(())
            }
            Store::Disk { ids, .. } => ids.read(p.id_at, p.id_bytes as usize, out),
        }
    }
}

/// The encoding of `live`: its bytes, id stream and record fields.
fn encode(live: &LivePatch, encoding: &PatchEncoding) -> (Vec<u8>, Vec<u8>, FinishedPatch) {
    let (tris, vertices) = (&live.triangles, &live.vertices);
    let mut patch = build_patch(
        tris,
        vertices,
        encoding.numbering_table,
        encoding.bbox_min,
        encoding.step,
    );
    if !encoding.vertex_starts.is_identity() {
        for g in &mut patch.global_ids {
            *g = encoding.vertex_starts.canonical(*g);
        }
    }
    let mut bytes = Vec::with_capacity(patch_bytes(
        patch.global_ids.len(),
        patch.strip.len(),
        encoding.attributes,
    ));
    let mut ids = Vec::with_capacity(2 * patch.global_ids.len());
    let placement = encode_patch(&patch, encoding.attributes, &mut bytes, &mut ids);
    if let Some(strips) = StripCoding::of(encoding.codec) {
        let mut packed = Vec::new();
        pack_patch(
            &bytes,
            patch.global_ids.len(),
            patch.strip.len(),
            encoding.attributes,
            strips,
            &mut packed,
        );
        bytes = packed;
    }
    let origin = encoding.origin;
    let rows = vertices.rows_of(tris);
    let position = |r: u32| vertices.positions[r as usize];
    let relative = |r: u32| {
        let p = position(r);
        [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]]
    };
    let sphere = Sphere::around_points(rows.iter().flatten().map(|&r| relative(r)));
    let cone = NormalCone::around_normals(rows.iter().map(|t| triangle_normal(t.map(position))));
    let finished = FinishedPatch {
        sphere,
        cone,
        vertex_count: patch.global_ids.len() as u32,
        strip_index_count: patch.strip.len() as u32,
        triangle_count: patch.triangle_count,
        patch_bytes: u32::try_from(bytes.len()).expect("a patch over 4 GiB"),
        id_bytes: placement.id_bytes,
        patch_checksum: patch_checksum(&bytes),
        patch_at: 0,
        id_at: 0,
    };
    (bytes, ids, finished)
}

fn triangle_normal([a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}
