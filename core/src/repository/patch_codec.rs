//! How a repository stores its patches: the codec a patch blob's section kind names.

use super::format::{
    SECTION_CODED_STRIPS, SECTION_PACKED_PATCHES, SECTION_PACKED_STRIPS, SECTION_PATCHES,
};

/// How a repository stores its patches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PatchCodec {
    /// As drawn: `SECTION_PATCHES`, each patch exactly `patch::patch_bytes(..)`.
    Raw,
    /// Packed: `SECTION_PACKED_STRIPS` (`packed.rs`, strips by `strip_codec.rs`), decoded
    /// when loaded; the default from commit 4fa9fc2 (2026-12-03) to issue 49.
    Packed,
    /// Packed as before commit 4fa9fc2 (2026-12-03): `SECTION_PACKED_PATCHES`, strips by
    /// meshoptimizer's index-sequence codec. Read (and written by tests, to prove it).
    PackedV1,
    /// Entropy-coded: `SECTION_CODED_STRIPS` (`coded.rs`), decoded when loaded.
    #[default]
    Coded,
}

impl PatchCodec {
    /// Its name in messages and JSON: `"raw"`, `"packed"`, `"packed-v1"` or `"coded"`.
    pub fn name(self) -> &'static str {
        match self {
            PatchCodec::Raw => "raw",
            PatchCodec::Packed => "packed",
            PatchCodec::PackedV1 => "packed-v1",
            PatchCodec::Coded => "coded",
        }
    }

    /// The section kind of this codec's patch blob.
    pub fn section_kind(self) -> u32 {
        match self {
            PatchCodec::Raw => SECTION_PATCHES,
            PatchCodec::Packed => SECTION_PACKED_STRIPS,
            PatchCodec::PackedV1 => SECTION_PACKED_PATCHES,
            PatchCodec::Coded => SECTION_CODED_STRIPS,
        }
    }

    /// The codec of a patch blob section of kind `kind`.
    pub fn of_section(kind: u32) -> Option<PatchCodec> {
        match kind {
            SECTION_PATCHES => Some(PatchCodec::Raw),
            SECTION_PACKED_STRIPS => Some(PatchCodec::Packed),
            SECTION_PACKED_PATCHES => Some(PatchCodec::PackedV1),
            SECTION_CODED_STRIPS => Some(PatchCodec::Coded),
            _ => None,
        }
    }
}
