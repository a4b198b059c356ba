//! Packed repositories (today's strip coding and the one before it, which older files hold):
//! every patch decodes to exactly the raw repository's bytes, and a packed patch that is
//! damaged behind a valid checksum is an error naming its tet, never a panic.
mod common;

use common::contents;
use tessera_core::repository::format::{
    PatchCodec, ATTR_ALL, SECTION_PACKED_PATCHES, SECTION_PACKED_STRIPS, SECTION_PATCHES,
};
use tessera_core::repository::packed::pack_contents;
use tessera_core::repository::{write_repository, Repository, RepositoryError};

fn open(contents: &tessera_core::repository::RepositoryContents) -> Repository {
    let mut bytes = Vec::new();
    write_repository(&mut bytes, contents).unwrap();
    Repository::from_bytes(bytes).unwrap()
}

#[test]
fn packed_patches_decode_to_the_raw_bytes() {
    for (dimension, attributes, big) in (0..=ATTR_ALL)
        .flat_map(|a| [(2, a, false), (3, a, false)])
        .chain([(3, ATTR_ALL, true), (2, 0, true)])
    {
        let (raw, patches) = contents(dimension, attributes, big);
        for (codec, kind) in [
            (PatchCodec::Packed, SECTION_PACKED_STRIPS),
            (PatchCodec::PackedV1, SECTION_PACKED_PATCHES),
        ] {
            let packed = pack_contents(&raw, codec);
            let (raw_repo, packed_repo) = (open(&raw), open(&packed));
            assert_eq!(raw_repo.codec(), PatchCodec::Raw);
            assert_eq!(packed_repo.codec(), codec);
            let kinds: Vec<u32> = packed_repo.sections().iter().map(|e| e.kind).collect();
            assert!(kinds.contains(&kind) && !kinds.contains(&SECTION_PATCHES));
            assert_eq!(
                kinds
                    .iter()
                    .filter(|k| [SECTION_PACKED_STRIPS, SECTION_PACKED_PATCHES].contains(k))
                    .count(),
                1
            );
            assert!(packed_repo.patch_blob().len() < raw_repo.patch_blob().len());
            for (i, original) in patches.iter().enumerate() {
                let size = packed_repo.decoded_patch_bytes(i).unwrap();
                assert_eq!(size, raw_repo.patch_bytes(i).unwrap().len());
                let mut decoded = vec![0xEE; size];
                packed_repo.read_patch(i, &mut decoded).unwrap();
                assert!(decoded == raw_repo.patch_bytes(i).unwrap(), "tet {i}");
                let patch = packed_repo.patch(i).unwrap();
                assert_eq!(patch.view().to_patch_data(), *original, "tet {i}");
                assert_eq!(patch.view().bytes(), raw_repo.patch_bytes(i).unwrap());
                // The raw repository reads the same through the same calls.
                let mut copied = vec![0; size];
                raw_repo.read_patch(i, &mut copied).unwrap();
                assert_eq!(copied, decoded);
            }
            packed_repo.validate_patches().unwrap();
            // A destination of the wrong size is an error, not a panic.
            assert!(packed_repo.read_patch(0, &mut [0; 3]).is_err());
        }
    }
}

#[test]
fn damaged_packed_patches_behind_valid_checksums_are_errors() {
    let (raw, _) = contents(3, ATTR_ALL, false);
    let packed = pack_contents(&raw, PatchCodec::Packed);
    let mut damaged_any = 0;
    for tet in 0..packed.tets.len() {
        let t = packed.tets[tet];
        if t.patch_bytes == 0 {
            continue;
        }
        for at in (0..t.patch_bytes as usize).step_by(3) {
            let mut bad = packed.clone();
            bad.patch_blob[t.patch_offset as usize + at] ^= 0x5A;
            // The writer computes the checksums of what it is given: the file is sealed.
            let repo = open(&bad);
            let size = repo.decoded_patch_bytes(tet).unwrap();
            match repo.read_patch(tet, &mut vec![0; size]) {
                Err(RepositoryError::Corrupt(message)) => {
                    assert!(message.contains(&format!("tet {tet}")), "{message}");
                    damaged_any += 1;
                }
                Err(other) => panic!("tet {tet} byte {at}: {other}"),
                // Damage the decoders cannot see (a value changed in range) decodes to
                // another valid patch; `patch` still validates its strip.
                Ok(()) => {
                    let _ = repo.patch(tet);
                }
            }
        }
    }
    assert!(damaged_any > 0, "no damage was ever detected");
}
