//! The textures an input names, as importers find them and the build writes them: each
//! material's base-colour image (OBJ `map_Kd`, glTF `baseColorTexture`, PLY
//! `comment TextureFile`) and the *bands* that tell which wedge samples which texture
//! (`tessera_core::texture`). An input with no texture has none of this
//! (`ImportReport::textures` = `None`), and its repository is what it was before textures.
//!
//! A stored `v` grows down the image, row 0 at `v = 0` (glTF's convention): importers of
//! v-up formats (OBJ, PLY) store `−v` before shifting it into its band, and only for an input
//! with textures (an input whose coordinates name no image keeps them as they are).

use std::path::PathBuf;

use tessera_core::texture::{Band, Wrap};

/// Where a texture's encoded image (PNG or JPEG) is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TextureSource {
    /// A file, resolved against the mesh's directory by the importer.
    File(PathBuf),
    /// Bytes the mesh file holds itself (a GLB buffer view, a data URI), with the MIME type
    /// it declares, if any.
    Encoded {
        bytes: Vec<u8>,
        mime: Option<String>,
    },
}

/// One texture of the input.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TextureInput {
    /// A name for messages and `info`: the file name or the material's.
    pub name: String,
    pub source: TextureSource,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
}

/// An input's textures and the bands its wedges' `v` was shifted into. Invariant (checked by
/// the build, `tessera_core::texture::bands_valid`): bands disjoint, each naming a texture of
/// `textures` or `NO_TEXTURE`, and every wedge's `v` inside one band.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshTextures {
    pub textures: Vec<TextureInput>,
    pub bands: Vec<Band>,
}
