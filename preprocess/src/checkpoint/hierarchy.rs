//! Stage `hierarchy`: the hierarchy (`hierarchy.bin`: the frame and the split diamonds, rebuilt
//! by splitting them again in (level, id) order), each leaf's input triangles
//! (`leaf-triangles.bin`) and the use counts (`counts.bin`), with what the build knew of its
//! input (bounding box, counts, attributes) in the stage's values. The staged mesh's files stay
//! listed: the leaves are made from them.

use std::collections::BTreeMap;
use std::io;

use tessera_core::leb::{ConformingMesh, Diamond};

use super::{Checkpoint, Dec, Enc, FileRecord, StageRecord};
use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::simplify::CurrentMesh;

pub(super) const HIERARCHY: &str = "hierarchy.bin";
const LEAF_TRIANGLES: &str = "leaf-triangles.bin";
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

/// A build's hierarchy and use counts, read back from its checkpoint.
pub(crate) struct HierarchyCheckpoint {
    pub facts: InputFacts,
    pub hierarchy: Hierarchy,
    pub current: CurrentMesh,
}

/// Saves the hierarchy (with its leaves' triangle lists) and the use counts, and commits stage
/// `hierarchy` (the staged mesh's files stay: the leaves are made from them).
pub(crate) fn save_hierarchy(
    checkpoint: &mut Checkpoint,
    facts: &InputFacts,
    hierarchy: &Hierarchy,
    current: &CurrentMesh,
) -> io::Result<()> {
    let mut lists: Vec<_> = hierarchy.leaf_triangles.iter().collect();
    lists.sort_unstable_by_key(|(k, _)| **k);
    let mut leaves = Enc::default();
    leaves.list(&lists, |e, (k, list)| {
        e.key(**k);
        e.list(list, |e, &t| e.u32(t));
    });
    let mut counts = Enc::default();
    current.encode(&mut counts);
    let files = vec![
        write_file(checkpoint, HIERARCHY, &encode_hierarchy(hierarchy))?,
        write_file(checkpoint, LEAF_TRIANGLES, &leaves.0)?,
        write_file(checkpoint, COUNTS, &counts.0)?,
    ];
    checkpoint.commit_keeping(
        StageRecord {
            name: "hierarchy".into(),
            files,
            values: facts.values(),
        },
        true,
    )
}

/// The hierarchy and counts of a checkpoint whose last stage is `hierarchy`.
pub(crate) fn load_hierarchy(checkpoint: &Checkpoint) -> io::Result<Option<HierarchyCheckpoint>> {
    let Some(stage) = checkpoint.last_stage().filter(|s| s.name == "hierarchy") else {
        return Ok(None);
    };
    let facts = InputFacts::from_values(&stage.values)?;
    let mut hierarchy = decode_hierarchy(&std::fs::read(checkpoint.path(HIERARCHY))?)?;
    let bytes = std::fs::read(checkpoint.path(LEAF_TRIANGLES))?;
    let mut d = Dec::new(&bytes);
    let lists = d.list(29, |d| Ok((d.key()?, d.list(4, |d| d.u32())?)))?;
    d.finish()?;
    let complete = lists.len() == hierarchy.mesh.leaf_count()
        && lists.iter().all(|(k, _)| hierarchy.mesh.is_leaf(*k));
    let in_range = lists
        .iter()
        .flat_map(|(_, l)| l)
        .all(|&t| (t as usize) < facts.triangles);
    if !complete || !in_range {
        return Err(invalid("the leaves' triangles are not the hierarchy's"));
    }
    hierarchy.leaf_triangles = lists.into_iter().collect();
    let bytes = std::fs::read(checkpoint.path(COUNTS))?;
    let mut d = Dec::new(&bytes);
    let current = CurrentMesh::decode(&mut d, facts.vertices)?;
    d.finish()?;
    Ok(Some(HierarchyCheckpoint {
        facts,
        hierarchy,
        current,
    }))
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
    e.list(&h.diamonds, |e, d| d.id.iter().for_each(|&x| e.i32(x)));
    e.0
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
    let ids = d.list(12, |d| Ok([d.i32()?, d.i32()?, d.i32()?]))?;
    d.finish()?;
    if !(dim == 2 || dim == 3) || !(4..=30).contains(&bits) {
        return Err(invalid("hierarchy: bad frame"));
    }
    let mut mesh = ConformingMesh::new(dim, bits);
    let mut diamonds: Vec<Diamond> = Vec::with_capacity(ids.len());
    for &id in &ids {
        if !mesh.split(id, &mut |d: &Diamond| diamonds.push(d.clone())) {
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
            e.0.extend_from_slice(&bytes[..1 + 7 * 8 + 4]);
            e.list(&h.diamonds[1..], |e, d| d.id.iter().for_each(|&x| e.i32(x)));
            assert!(decode_hierarchy(&e.0).is_err());
            assert!(decode_hierarchy(&bytes[..bytes.len() - 3]).is_err());
        }
    }
}
