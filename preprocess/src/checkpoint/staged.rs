//! Stage `staged`: the welded mesh's record files, handed from the import's unnamed
//! temporaries to the checkpoint (linked, so they are on disk once), with what welding
//! counted; and opened again by a resumed build, which then skips the import.

use std::collections::BTreeMap;
use std::io;

use bytemuck::Pod;

use super::{Checkpoint, FileRecord, StageRecord};
use crate::external::staged::VertexAttributes;
use crate::external::{PositionFile, RecordFile, StagedMesh};

const COUNTS: [&str; 6] = [
    "raw_vertices",
    "raw_triangles",
    "welded_vertices",
    "degenerate_triangles",
    "duplicate_triangles",
    "unreferenced_vertices",
];

/// The staged triangle file's name: stage `hierarchy` drops it (the leaves' triangles are
/// its own then).
pub(super) const TRIANGLES_FILE: &str = "staged-triangles.bin";

/// Hands `staged`'s files to the checkpoint (`RecordFile::keep_at`: `staged` reads them
/// there from then on) and commits stage `staged`.
pub fn save_staged(checkpoint: &mut Checkpoint, staged: &mut StagedMesh) -> io::Result<()> {
    fn keep<T: Pod>(
        c: &Checkpoint,
        name: &str,
        file: Option<&mut RecordFile<T>>,
        files: &mut Vec<FileRecord>,
    ) -> io::Result<()> {
        if let Some(file) = file {
            let name = format!("staged-{name}.bin");
            let crc32 = file.keep_at(&c.path(&name))?;
            files.push(FileRecord {
                name,
                bytes: file.bytes(),
                crc32,
                sparse: false,
            });
        }
        Ok(())
    }
    let mut files = Vec::new();
    let name = staged.positions.checkpoint_name();
    let crc32 = staged.positions.keep_at(&checkpoint.path(name))?;
    files.push(FileRecord {
        name: name.into(),
        bytes: staged.positions.bytes(),
        crc32,
        sparse: false,
    });
    keep(
        checkpoint,
        "triangles",
        Some(&mut staged.triangles),
        &mut files,
    )?;
    let a = &mut staged.attributes;
    keep(checkpoint, "normals", a.normals.as_mut(), &mut files)?;
    keep(checkpoint, "colors", a.colors.as_mut(), &mut files)?;
    keep(checkpoint, "uvs", a.uvs.as_mut(), &mut files)?;
    let counts = [
        staged.raw_vertices,
        staged.raw_triangles,
        staged.welded_vertices,
        staged.degenerate_triangles,
        staged.duplicate_triangles,
        staged.unreferenced_vertices,
    ];
    let values: BTreeMap<String, u64> = COUNTS
        .iter()
        .zip(counts)
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    checkpoint.commit(StageRecord {
        name: "staged".into(),
        files,
        values,
    })
}

/// The staged mesh of a checkpoint whose last stage is `staged` or `hierarchy` (its files read-only: the
/// build's `discard` leaves them to the checkpoint).
pub fn open_staged(checkpoint: &Checkpoint) -> io::Result<Option<StagedMesh>> {
    let last = checkpoint.last_stage().map(|s| s.name.as_str());
    if !matches!(last, Some("staged" | "hierarchy")) {
        return Ok(None);
    }
    let stages = &checkpoint.manifest().stages;
    let Some(stage) = stages.iter().find(|s| s.name == "staged") else {
        return Ok(None);
    };
    fn open<T: Pod>(
        c: &Checkpoint,
        stage: &StageRecord,
        name: &str,
    ) -> io::Result<Option<RecordFile<T>>> {
        let name = format!("staged-{name}.bin");
        stage
            .files
            .iter()
            .find(|f| f.name == name)
            .map(|f| RecordFile::open_kept(&c.path(&f.name), f.bytes))
            .transpose()
    }
    let missing =
        |what: &str| io::Error::new(io::ErrorKind::InvalidData, format!("no {what} file"));
    let count = |k: &str| stage.values.get(k).copied().ok_or_else(|| missing(k));
    Ok(Some(StagedMesh {
        positions: stage
            .files
            .iter()
            .find_map(|f| {
                PositionFile::open_kept(&f.name, &checkpoint.path(&f.name), f.bytes).transpose()
            })
            .transpose()?
            .ok_or_else(|| missing("positions"))?,
        triangles: match open(checkpoint, stage, "triangles")? {
            Some(file) => file,
            // After stage `hierarchy`: read into the leaves' triangles, gone from disk.
            None if last == Some("hierarchy") => RecordFile::vacant(
                count(COUNTS[1])?
                    .checked_sub(count(COUNTS[3])? + count(COUNTS[4])?)
                    .ok_or_else(|| missing("consistent triangle counts"))?,
            ),
            None => return Err(missing("triangles")),
        },
        attributes: VertexAttributes {
            normals: open(checkpoint, stage, "normals")?,
            colors: open(checkpoint, stage, "colors")?,
            uvs: open(checkpoint, stage, "uvs")?,
        },
        raw_vertices: count(COUNTS[0])?,
        raw_triangles: count(COUNTS[1])?,
        welded_vertices: count(COUNTS[2])?,
        degenerate_triangles: count(COUNTS[3])?,
        duplicate_triangles: count(COUNTS[4])?,
        unreferenced_vertices: count(COUNTS[5])?,
        textures: None,
        missing_textures: Vec::new(),
    }))
}
