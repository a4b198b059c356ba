//! The streaming writer (`write_repository_streamed`): the same bytes as the whole-contents
//! writer, and a fed patch that does not match its directory never reaches the path.

mod common;

use std::io;
use std::path::Path;

use common::contents;
use tessera_core::repository::format::{patch_checksum, ATTR_ALL};
use tessera_core::repository::{
    write_repository_file, write_repository_streamed, BlobFeed, Repository, RepositoryContents,
    RepositoryDirectory, RepositoryError,
};

/// Feeds the blobs of `contents`, optionally flipping one byte of one tet's patch.
struct FromContents<'a> {
    contents: &'a RepositoryContents,
    corrupt_patch_of: Option<usize>,
}

impl BlobFeed for FromContents<'_> {
    fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        let t = &self.contents.tets[tet];
        let at = t.patch_offset as usize;
        let start = out.len();
        out.extend_from_slice(&self.contents.patch_blob[at..at + t.patch_bytes as usize]);
        if self.corrupt_patch_of == Some(tet) {
            out[start] ^= 1;
        }
        Ok(())
    }

    fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        let t = &self.contents.tets[tet];
        let at = t.id_offset as usize;
        out.extend_from_slice(&self.contents.id_blob[at..at + t.id_bytes as usize]);
        Ok(())
    }
}

/// The directory of `contents` with every patch checksum filled, as a build gives it.
fn directory(contents: &RepositoryContents) -> RepositoryDirectory {
    let mut tets = contents.tets.clone();
    for t in &mut tets {
        let at = t.patch_offset as usize;
        t.patch_checksum = patch_checksum(&contents.patch_blob[at..at + t.patch_bytes as usize]);
    }
    RepositoryDirectory {
        header: contents.header,
        diamonds: contents.diamonds.clone(),
        tets,
        codec: contents.codec,
        attribute_errors: contents.attribute_errors.clone(),
        textures: None,
    }
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn streamed_bytes_equal_the_whole_contents_writer() {
    let dir = tempfile::tempdir().unwrap();
    for dimension in [2, 3] {
        for attributes in 0..=ATTR_ALL {
            for big in [false, true] {
                let (contents, _) = contents(dimension, attributes, big);
                let whole = dir.path().join("whole.tsr");
                let streamed = dir.path().join("streamed.tsr");
                let n = write_repository_file(&whole, &contents).unwrap();
                let mut feed = FromContents {
                    contents: &contents,
                    corrupt_patch_of: None,
                };
                let m =
                    write_repository_streamed(&streamed, &directory(&contents), &mut feed).unwrap();
                assert_eq!(n, m);
                assert_eq!(
                    std::fs::read(&whole).unwrap(),
                    std::fs::read(&streamed).unwrap(),
                    "dimension {dimension}, attributes {attributes}, big {big}"
                );
                Repository::open(&streamed)
                    .unwrap()
                    .validate_patches()
                    .unwrap();
            }
        }
    }
}

#[test]
fn a_patch_that_does_not_match_its_record_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (contents, _) = contents(3, ATTR_ALL, false);
    let path = dir.path().join("bad.tsr");
    for tet in [1, contents.tets.len() - 1] {
        let mut feed = FromContents {
            contents: &contents,
            corrupt_patch_of: Some(tet),
        };
        let error = write_repository_streamed(&path, &directory(&contents), &mut feed)
            .expect_err("a corrupted patch was written");
        let message = error.to_string();
        assert!(
            message.contains(&format!("tet {tet}")) && message.contains("checksum"),
            "{message}"
        );
        assert!(
            leftovers(dir.path()).is_empty(),
            "{:?}",
            leftovers(dir.path())
        );
    }
}

#[test]
fn blobs_out_of_table_order_are_refused_before_any_file() {
    let dir = tempfile::tempdir().unwrap();
    let (contents, _) = contents(3, 0, false);
    let mut directory = directory(&contents);
    directory.tets.swap(2, 3);
    let path = dir.path().join("unordered.tsr");
    let mut feed = FromContents {
        contents: &contents,
        corrupt_patch_of: None,
    };
    match write_repository_streamed(&path, &directory, &mut feed) {
        Err(RepositoryError::Corrupt(message)) => {
            assert!(message.contains("table order"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    assert!(leftovers(dir.path()).is_empty());
}
