//! Stages `leaves` and `level-N`: the simplification's state before its first level and after
//! each. Files: `hierarchy.bin` (the frame and the split diamonds, written once: the hierarchy
//! is rebuilt by splitting them again in (level, id) order), `state-N.bin` (the use counts,
//! the live simplices and the indexes of the live and finished patches, `LevelState::encode`),
//! and the append-only files those indexes point into (`live-G.bin`, `finished-*.bin`),
//! recorded at their length and CRC-32 when the stage was committed. What the build knew of its
//! input (bounding box, counts, attributes) is in the stage's values.

use std::collections::BTreeMap;
use std::io;

use tessera_core::leb::{ConformingMesh, Diamond};

use super::{Checkpoint, Dec, Enc, FileRecord, StageRecord};
use crate::finished_patches::FinishedPatches;
use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::simplify::LevelState;

const HIERARCHY: &str = "hierarchy.bin";

/// What the build knew of its input when it started simplifying.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct InputFacts {
    pub bbox: ([f64; 3], [f64; 3]),
    pub vertices: usize,
    pub triangles: usize,
    pub attributes: u32,
}

/// A build's state between two levels, read back from its checkpoint.
pub(crate) struct LevelsCheckpoint {
    pub facts: InputFacts,
    pub hierarchy: Hierarchy,
    pub state: LevelState,
    pub finished: FinishedPatches,
}

fn invalid(what: impl Into<String>) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, what.into())
}

/// Saves the state after `state.levels_done()` levels and commits stage `leaves` (none yet)
/// or `level-N` — after a level only when one is due (`Checkpoint::level_due`): levels
/// merged since the last checkpoint are merged again by a resumed build.
pub(crate) fn save_levels(
    checkpoint: &mut Checkpoint,
    facts: &InputFacts,
    hierarchy: &Hierarchy,
    state: &LevelState,
    finished: &mut FinishedPatches,
) -> io::Result<()> {
    if state.levels_done() > 0 && !checkpoint.level_due() {
        return Ok(());
    }
    let start = std::time::Instant::now();
    let mut files = Vec::new();
    // The hierarchy once; later stages name the same file.
    let written = checkpoint
        .last_stage()
        .and_then(|s| s.files.iter().find(|f| f.name == HIERARCHY))
        .cloned();
    files.push(match written {
        Some(record) => record,
        None => write_file(checkpoint, HIERARCHY, &encode_hierarchy(hierarchy))?,
    });
    let mut e = Enc::default();
    state.encode(&mut e)?;
    files.extend(finished.encode_checkpoint(&mut e)?);
    let (name, bytes, crc32) = state
        .store_file()
        .ok_or_else(|| io::Error::other("the live patches are not in the checkpoint"))?;
    files.push(FileRecord { name, bytes, crc32 });
    let done = state.levels_done();
    files.push(write_file(checkpoint, &format!("state-{done}.bin"), &e.0)?);
    let mut values = BTreeMap::new();
    for i in 0..3 {
        values.insert(format!("bbox_min_{i}_bits"), facts.bbox.0[i].to_bits());
        values.insert(format!("bbox_max_{i}_bits"), facts.bbox.1[i].to_bits());
    }
    values.insert("input_vertices".into(), facts.vertices as u64);
    values.insert("input_triangles".into(), facts.triangles as u64);
    values.insert("attributes".into(), facts.attributes as u64);
    values.insert("levels_done".into(), done as u64);
    checkpoint.level_saved(start);
    checkpoint.commit(StageRecord {
        name: if done == 0 {
            "leaves".into()
        } else {
            format!("level-{done}")
        },
        files,
        values,
    })
}

/// The state of a checkpoint whose last stage is `leaves` or `level-N`.
pub(crate) fn load_levels(checkpoint: &Checkpoint) -> io::Result<Option<LevelsCheckpoint>> {
    let Some(stage) = checkpoint
        .last_stage()
        .filter(|s| s.name == "leaves" || s.name.starts_with("level-"))
    else {
        return Ok(None);
    };
    let value = |k: &str| {
        stage
            .values
            .get(k)
            .copied()
            .ok_or_else(|| invalid(format!("no {k}")))
    };
    let mut bbox = ([0.0; 3], [0.0; 3]);
    for i in 0..3 {
        bbox.0[i] = f64::from_bits(value(&format!("bbox_min_{i}_bits"))?);
        bbox.1[i] = f64::from_bits(value(&format!("bbox_max_{i}_bits"))?);
    }
    let facts = InputFacts {
        bbox,
        vertices: value("input_vertices")? as usize,
        triangles: value("input_triangles")? as usize,
        attributes: value("attributes")? as u32,
    };
    let done = value("levels_done")?;
    let hierarchy = decode_hierarchy(&std::fs::read(checkpoint.path(HIERARCHY))?)?;
    let bytes = std::fs::read(checkpoint.path(&format!("state-{done}.bin")))?;
    let mut d = Dec::new(&bytes);
    let state = LevelState::decode(&mut d, checkpoint.dir())?;
    let finished = FinishedPatches::decode_checkpoint(&mut d, checkpoint.dir(), &stage.files)?;
    d.finish()?;
    if state.levels_done() as u64 != done {
        return Err(invalid("the state is not the stage's"));
    }
    Ok(Some(LevelsCheckpoint {
        facts,
        hierarchy,
        state,
        finished,
    }))
}

fn write_file(checkpoint: &Checkpoint, name: &str, bytes: &[u8]) -> io::Result<FileRecord> {
    super::bytes::write_atomic(&checkpoint.path(name), bytes)?;
    Ok(FileRecord {
        name: name.into(),
        bytes: bytes.len() as u64,
        crc32: crc32fast::hash(bytes),
    })
}

fn encode_hierarchy(h: &Hierarchy) -> Vec<u8> {
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
fn decode_hierarchy(bytes: &[u8]) -> io::Result<Hierarchy> {
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
