//! Stage `hierarchy`: the hierarchy (`hierarchy.bin`: the frame and the split diamonds, rebuilt
//! by splitting them again in (level, id) order), each leaf's input triangles
//! (`leaf-triangles.bin`, their vertex ids coded: the spool `LeafCorners` wrote, linked into the
//! checkpoint; `leaf-index.bin`, where each leaf's are) and the use counts (`counts.bin`),
//! with what the build knew of its input (bounding box, counts, attributes) in the stage's
//! values. The staged mesh's vertex files stay listed (the leaves are made from them and
//! these); its triangle file does not.

use std::collections::BTreeMap;
use std::io;

use tessera_core::leb::{ConformingMesh, Diamond};

use super::{Checkpoint, Dec, Enc, FileRecord, StageRecord};
use crate::frame::LatticeFrame;
use crate::hierarchy::{decode_corners, Hierarchy, LeafCorners, LeafListSpool, SplitDiamond};
use crate::simplify::CurrentMesh;

pub(super) const HIERARCHY: &str = "hierarchy.bin";
const LEAF_TRIANGLES: &str = "leaf-triangles.bin";
const LEAF_INDEX: &str = "leaf-index.bin";
const COUNTS: &str = "counts.bin";

/// What the build knew of its input when it started simplifying.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct InputFacts {
    pub bbox: ([f64; 3], [f64; 3]),
    pub vertices: usize,
    pub triangles: usize,
    pub attributes: u32,
}

impl InputFacts {
    /// The stage values that record the facts (the box as f64 bits).
    pub(super) fn values(&self) -> BTreeMap<String, u64> {
        let mut values = BTreeMap::new();
        for i in 0..3 {
            values.insert(format!("bbox_min_{i}_bits"), self.bbox.0[i].to_bits());
            values.insert(format!("bbox_max_{i}_bits"), self.bbox.1[i].to_bits());
        }
        values.insert("input_vertices".into(), self.vertices as u64);
        values.insert("input_triangles".into(), self.triangles as u64);
        values.insert("attributes".into(), self.attributes as u64);
        values
    }

    pub(super) fn from_values(values: &BTreeMap<String, u64>) -> io::Result<InputFacts> {
        let value = |k: &str| {
            values
                .get(k)
                .copied()
                .ok_or_else(|| invalid(format!("no {k}")))
        };
        let mut bbox = ([0.0; 3], [0.0; 3]);
        for i in 0..3 {
            bbox.0[i] = f64::from_bits(value(&format!("bbox_min_{i}_bits"))?);
            bbox.1[i] = f64::from_bits(value(&format!("bbox_max_{i}_bits"))?);
        }
        Ok(InputFacts {
            bbox,
            vertices: value("input_vertices")? as usize,
            triangles: value("input_triangles")? as usize,
            attributes: value("attributes")? as u32,
        })
    }
}

/// A build's hierarchy, its leaves' triangles (read from the checkpoint's file as needed) and
/// use counts, read back from its checkpoint.
pub(crate) struct HierarchyCheckpoint {
    pub facts: InputFacts,
    pub hierarchy: Hierarchy,
    pub lists: LeafCorners,
    pub current: CurrentMesh,
}

/// Saves the hierarchy (with its leaves' triangles) and the use counts, and commits stage
/// `hierarchy` (the staged mesh's vertex files stay: the leaves are made from them; its
/// triangle file goes). Returns the triangles as saved, read from the checkpoint's file, for
/// the build to use instead of `lists` (which it can then close: they are on disk once).
pub(crate) fn save_hierarchy(
    checkpoint: &mut Checkpoint,
    facts: &InputFacts,
    hierarchy: &Hierarchy,
    lists: &mut LeafCorners,
    current: &CurrentMesh,
) -> io::Result<LeafCorners> {
    // Streamed to their files, a leaf's list at a time: at 100 M triangles the lists and
    // counts alone take 600 MB.
    let files = vec![
        write_file(checkpoint, HIERARCHY, &encode_hierarchy(hierarchy))?,
        keep_leaf_triangles(checkpoint, lists)?,
        write_streamed(checkpoint, LEAF_INDEX, |e| {
            encode_leaf_index(e, &lists.spool);
            Ok(())
        })?,
        write_streamed(checkpoint, COUNTS, |e| {
            current.encode(e);
            Ok(())
        })?,
    ];
    checkpoint.commit_keeping(
        StageRecord {
            name: "hierarchy".into(),
            files,
            values: facts.values(),
        },
        &|name| name != super::staged::TRIANGLES_FILE,
    )?;
    open_leaf_lists(leaf_paths(checkpoint), hierarchy, facts.vertices)
}

/// The leaves' triangles' file and index in `checkpoint`.
fn leaf_paths(checkpoint: &Checkpoint) -> (std::path::PathBuf, std::path::PathBuf) {
    (checkpoint.path(LEAF_TRIANGLES), checkpoint.path(LEAF_INDEX))
}

/// The spool's file, named in the checkpoint (linked: on disk once).
fn keep_leaf_triangles(checkpoint: &Checkpoint, lists: &mut LeafCorners) -> io::Result<FileRecord> {
    let (bytes, crc32) = lists.spool.keep_at(&checkpoint.path(LEAF_TRIANGLES))?;
    Ok(FileRecord {
        name: LEAF_TRIANGLES.into(),
        bytes,
        crc32,
        sparse: false,
    })
}

/// The hierarchy and counts of a checkpoint whose last stage is `hierarchy`.
pub(crate) fn load_hierarchy(checkpoint: &Checkpoint) -> io::Result<Option<HierarchyCheckpoint>> {
    let Some(stage) = checkpoint.last_stage().filter(|s| s.name == "hierarchy") else {
        return Ok(None);
    };
    let facts = InputFacts::from_values(&stage.values)?;
    let hierarchy = decode_hierarchy(&std::fs::read(checkpoint.path(HIERARCHY))?)?;
    let lists = open_leaf_lists(leaf_paths(checkpoint), &hierarchy, facts.vertices)?;
    let bytes = std::fs::read(checkpoint.path(COUNTS))?;
    let mut d = Dec::new(&bytes);
    let current = CurrentMesh::decode(&mut d, facts.vertices)?;
    d.finish()?;
    Ok(Some(HierarchyCheckpoint {
        facts,
        hierarchy,
        lists,
        current,
    }))
}

/// Where every leaf's triangles are in `leaf-triangles.bin`, in key order: the count, then
/// each leaf's key, offset, triangle count and bytes.
fn encode_leaf_index(e: &mut Enc, lists: &LeafListSpool) {
    e.u64(lists.spans().len() as u64);
    for &(key, (at, n, bytes)) in lists.spans() {
        e.key(key);
        e.u64(at);
        e.u64(n as u64);
        e.u64(bytes);
    }
}

/// The leaves' triangles `save_hierarchy` kept, checked in one pass over their file (every
/// leaf of `hierarchy` once, nothing else, the leaves end to end in key order, each decoding
/// to its count of triangles with every vertex id below `vertices`) and left in it.
fn open_leaf_lists(
    (data, index): (std::path::PathBuf, std::path::PathBuf),
    hierarchy: &Hierarchy,
    vertices: usize,
) -> io::Result<LeafCorners> {
    let file = std::fs::File::open(data)?;
    let len = file.metadata()?.len();
    let index = std::fs::read(index)?;
    let not_ours = || invalid("the leaves' triangles are not the hierarchy's");
    let mut d = Dec::new(&index);
    // Each leaf's entry: its key and three u64s (45 bytes).
    let spans = d.list(45, |d| {
        let key = d.key()?;
        Ok((key, (d.u64()?, d.u64()?, d.u64()?)))
    })?;
    d.finish()?;
    if spans.len() != hierarchy.mesh.leaf_count() {
        return Err(not_ours());
    }
    let mut seen = rustc_hash::FxHashSet::default();
    let mut index = Vec::with_capacity(spans.len());
    let mut reader = io::BufReader::with_capacity(1 << 20, &file);
    let mut next = 0u64;
    for &(key, (at, n, bytes)) in &spans {
        // A coded leaf takes a byte or more, and (rows and ids) at most 25 bytes a triangle
        // and the ids' 15 bytes of head and count.
        if !hierarchy.mesh.is_leaf(key)
            || !seen.insert(key)
            || at != next
            || bytes == 0
            || bytes > n.saturating_mul(25).saturating_add(15)
            || bytes > len - at.min(len)
        {
            return Err(not_ours());
        }
        let mut coded = vec![0u8; bytes as usize];
        io::Read::read_exact(&mut reader, &mut coded)?;
        decode_corners(&coded, n as usize, vertices as u64).map_err(|_| not_ours())?;
        index.push((key, (at, n as u32, bytes)));
        next = at + bytes;
    }
    if next != len {
        return Err(invalid("the leaves' triangles: trailing bytes"));
    }
    drop(reader);
    Ok(LeafCorners {
        spool: LeafListSpool::in_file(file, index)?,
    })
}

pub(super) fn invalid(what: impl Into<String>) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, what.into())
}

pub(super) fn write_file(
    checkpoint: &Checkpoint,
    name: &str,
    bytes: &[u8],
) -> io::Result<FileRecord> {
    super::bytes::write_atomic(&checkpoint.path(name), bytes)?;
    Ok(FileRecord {
        name: name.into(),
        bytes: bytes.len() as u64,
        crc32: crc32fast::hash(bytes),
        sparse: false,
    })
}

/// `write_file` of what `encode` streams (never all in memory at once).
pub(super) fn write_streamed(
    checkpoint: &Checkpoint,
    name: &str,
    encode: impl FnOnce(&mut Enc) -> io::Result<()>,
) -> io::Result<FileRecord> {
    let (bytes, crc32) = super::bytes::write_atomic_with(&checkpoint.path(name), encode)?;
    Ok(FileRecord {
        name: name.into(),
        bytes,
        crc32,
        sparse: false,
    })
}

pub(super) fn encode_hierarchy(h: &Hierarchy) -> Vec<u8> {
    let mut e = Enc::default();
    let f = &h.frame;
    e.u8(f.dim);
    f.model_origin.iter().for_each(|&x| e.f64(x));
    f.origin.iter().for_each(|&x| e.f64(x));
    e.f64(f.unit);
    e.u32(f.bits);
    e.u32(f.headroom);
    e.list(&h.diamonds, |e, d| d.id.iter().for_each(|&x| e.i32(x)));
    e.into_bytes()
}

/// The hierarchy whose split diamonds `encode_hierarchy` listed: split again in their (level,
/// id) order, parents before children, giving the same mesh and diamonds.
pub(super) fn decode_hierarchy(bytes: &[u8]) -> io::Result<Hierarchy> {
    let mut d = Dec::new(bytes);
    let dim = d.u8()?;
    let model_origin = [d.f64()?, d.f64()?, d.f64()?];
    let origin = [d.f64()?, d.f64()?, d.f64()?];
    let unit = d.f64()?;
    let bits = d.u32()?;
    let headroom = d.u32()?;
    let ids = d.list(12, |d| Ok([d.i32()?, d.i32()?, d.i32()?]))?;
    d.finish()?;
    if !(dim == 2 || dim == 3) || !(4..=30).contains(&bits) || headroom >= bits {
        return Err(invalid("hierarchy: bad frame"));
    }
    let mut mesh = ConformingMesh::new(dim, bits);
    let mut diamonds: Vec<SplitDiamond> = Vec::with_capacity(ids.len());
    for &id in &ids {
        if !mesh.split(id, &mut |d: &Diamond| diamonds.push(SplitDiamond::of(d))) {
            return Err(invalid("hierarchy: a diamond below the lattice"));
        }
    }
    diamonds.sort_unstable_by_key(|d| (d.level, d.id));
    if diamonds.len() != ids.len() || diamonds.iter().zip(&ids).any(|(d, id)| d.id != *id) {
        return Err(invalid("hierarchy: the split diamonds do not close"));
    }
    Ok(Hierarchy {
        frame: LatticeFrame {
            dim,
            model_origin,
            origin,
            unit,
            bits,
            headroom,
        },
        mesh,
        diamonds,
        leaf_triangles: Default::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::{build_hierarchy, Construction};

    #[test]
    fn a_hierarchy_comes_back_from_its_split_diamonds_and_damage_is_an_error() {
        for dim in [2u8, 3] {
            let frame = LatticeFrame::around_box([0.0; 3], [1.0, 2.0, 0.5], 12, dim);
            // Barycentres clustered towards one corner: an adaptive, uneven hierarchy.
            let mut x = 0x2545_f491_4f6c_dd1du64;
            let mut next = || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 11) as f64 / (1u64 << 53) as f64
            };
            let side = (1u32 << 12) as f64;
            let points: Vec<[f64; 3]> = (0..20_000)
                .map(|_| [0; 3].map(|_| next().powi(3) * side))
                .map(|p| if dim == 2 { [p[0], p[1], 0.0] } else { p })
                .collect();
            let h = build_hierarchy(frame, &points, Construction::LeafTriangles(64));
            assert!(h.diamonds.len() > 50, "{}", h.diamonds.len());
            let bytes = encode_hierarchy(&h);
            let back = decode_hierarchy(&bytes).unwrap();
            assert_eq!(back.diamonds, h.diamonds);
            assert_eq!(back.frame, h.frame);
            let mut leaves: Vec<_> = h.mesh.leaves().map(|s| s.key).collect();
            let mut back_leaves: Vec<_> = back.mesh.leaves().map(|s| s.key).collect();
            leaves.sort_unstable();
            back_leaves.sort_unstable();
            assert_eq!(back_leaves, leaves);
            // A diamond list that is not closed (a parent left out), or cut short: an error.
            let mut e = Enc::default();
            e.bytes(&bytes[..1 + 7 * 8 + 4]);
            e.list(&h.diamonds[1..], |e, d| d.id.iter().for_each(|&x| e.i32(x)));
            assert!(decode_hierarchy(&e.into_bytes()).is_err());
            assert!(decode_hierarchy(&bytes[..bytes.len() - 3]).is_err());

            // The leaves' triangles (triangle t: vertices 3t, 3t + 1, 3t + 2): back from their
            // file as written; damage is an error.
            let dir = tempfile::tempdir().unwrap();
            let corners = |map: &rustc_hash::FxHashMap<_, Vec<u32>>| {
                let map = map
                    .iter()
                    .map(|(k, list)| (*k, list.iter().map(|&t| [3 * t, 3 * t + 1, 3 * t + 2])))
                    .map(|(k, t)| (k, t.collect()))
                    .collect();
                LeafCorners::from_map(&map, dir.path()).unwrap()
            };
            let mut spool = corners(&h.leaf_triangles);
            let paths = (dir.path().join(LEAF_TRIANGLES), dir.path().join(LEAF_INDEX));
            let vertices = 3 * points.len();
            let write_index = |spool: &LeafCorners| {
                let index = |e: &mut Enc| {
                    encode_leaf_index(e, &spool.spool);
                    Ok(())
                };
                super::super::bytes::write_atomic_with(&paths.1, index).unwrap();
            };
            spool.spool.keep_at(&paths.0).unwrap();
            write_index(&spool);
            let open = |vertices: usize| open_leaf_lists(paths.clone(), &h, vertices);
            let back = open(vertices).unwrap();
            for (i, (key, n)) in back.leaves().enumerate() {
                let expected: Vec<[u32; 3]> = h.leaf_triangles[&key]
                    .iter()
                    .map(|&t| [3 * t, 3 * t + 1, 3 * t + 2])
                    .collect();
                assert_eq!(n, expected.len());
                assert_eq!(back.triangles_of(i).unwrap().0, expected);
            }
            assert!(open(vertices - 1).is_err(), "a vertex out of range");
            let bytes = std::fs::read(&paths.1).unwrap();
            for cut in [7, 8 + 21, bytes.len() - 1] {
                std::fs::write(&paths.1, &bytes[..cut]).unwrap();
                assert!(open(vertices).is_err(), "index cut at {cut}");
            }
            std::fs::write(&paths.1, &bytes).unwrap();
            let data = std::fs::read(&paths.0).unwrap();
            std::fs::write(&paths.0, &data[..data.len() - 1]).unwrap();
            assert!(open(vertices).is_err(), "the triangles cut short");
            let mut longer = data.clone();
            longer.extend_from_slice(&[0; 4]);
            std::fs::write(&paths.0, &longer).unwrap();
            assert!(open(vertices).is_err(), "trailing bytes");
            std::fs::write(&paths.0, &data).unwrap();
            assert!(open(vertices).is_ok());
            // One leaf fewer (count and entry gone): not the hierarchy's.
            let mut fewer = h.leaf_triangles.clone();
            let gone = *fewer.keys().next().unwrap();
            fewer.remove(&gone);
            let mut spool = corners(&fewer);
            spool.spool.keep_at(&paths.0).unwrap();
            write_index(&spool);
            assert!(open(vertices).is_err(), "a leaf missing");
        }
    }
}
