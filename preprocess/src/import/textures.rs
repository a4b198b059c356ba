//! The importers' side of textures (`texture_input.rs`): each material of a textured input
//! gets a *band* of `v` (`tessera_core::texture::Band`), and its corners' coordinates are moved
//! into it. Bands are laid out from `v = 0` up, one a textured material in the order the
//! importer lists them, then one shared by every material without a texture (its corners take
//! `(0, start + 0.5)`). A v-up format (OBJ, PLY) stores `shift − v`, a v-down one (glTF)
//! `v + shift`, so the texture is sampled at `(u, stored v − shift)` with row 0 at the top.
//!
//! A stored `v` is an f32: `shift ± v` rounds to its nearest f32, so `stored − shift` equals the
//! input's (negated) `v` to within half an ulp of the stored value (2^-23 relative), and a
//! value that rounds onto the band's upper integer is put back just below it, so every stored
//! `v` lies inside its band. A non-finite input `v` counts as 0.

use rustc_hash::FxHashMap;
use tessera_core::texture::{Band, NO_TEXTURE};

use super::error::{ImportErrorKind as K, Location};
use super::sink::MeshSink;
use super::RawMesh;
use crate::external::RawVertex;
use crate::texture_input::{MeshTextures, TextureInput};

/// What an importer found of an input's textures.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct FoundTextures {
    /// The textures and bands the coordinates were moved into; `None` for an input without
    /// textures (its coordinates as read).
    pub textures: Option<MeshTextures>,
    /// Texture files the input names that do not exist: their materials are untextured.
    pub missing: Vec<String>,
}

/// Which way a format's `v` grows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Orientation {
    /// `v = 0` at the image's bottom (OBJ, PLY): stored as `shift − v`.
    Up,
    /// `v = 0` at the image's top (glTF): stored as `v + shift`.
    Down,
}

/// How one material's coordinates reach its band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Placement {
    pub band: Band,
    /// `None` for an untextured material: its corners take `(0, band.start + 0.5)`.
    pub orientation: Option<Orientation>,
}

/// A non-finite coordinate as 0.
fn finite(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

impl Placement {
    /// `uv` moved into the band.
    pub fn place(&self, uv: [f32; 2]) -> [f32; 2] {
        let band = &self.band;
        let v = match self.orientation {
            None => return [0.0, band.start as f32 + 0.5],
            Some(Orientation::Up) => band.shift as f32 - finite(uv[1]),
            Some(Orientation::Down) => finite(uv[1]) + band.shift as f32,
        };
        let low = band.start as f32;
        let high = (i64::from(band.start) + i64::from(band.span)) as f32;
        // `high` > 0 (bands start at 0): the f32 just below it.
        let below_high = f32::from_bits(high.to_bits() - 1);
        [uv[0], v.clamp(low, below_high)]
    }
}

/// The range of a material's input `v` (non-finite values as 0), grown by `v`.
pub(crate) fn grow(range: &mut Option<(f32, f32)>, v: f32) {
    let v = finite(v);
    *range = Some(match *range {
        None => (v, v),
        Some((lo, hi)) => (lo.min(v), hi.max(v)),
    });
}

/// A material's texture (an index into the textures, or `None`) and the range of its input
/// `v` (`None`: no corner).
pub(crate) type MaterialRange = (Option<u32>, Option<(f32, f32)>);

/// The bands of materials, in order: `materials[m]` is the material's texture (an index into
/// the textures, or `None`) and the range of its input `v` (`None`: no corner, a band
/// anyway). Textured materials take consecutive bands from 0, the untextured ones share one
/// after them. An error if a band would not fit i32.
pub(crate) fn place_materials(
    materials: &[MaterialRange],
    orientation: Orientation,
) -> Result<(Vec<Band>, Vec<Placement>), K> {
    let too_large = || K::TooLarge {
        at: Location::None,
        msg: "texture coordinates too far apart for one band of v each".into(),
    };
    let mut bands = Vec::new();
    let mut placements = vec![None; materials.len()];
    let mut start = 0i32;
    for (m, &(texture, range)) in materials.iter().enumerate() {
        let Some(texture) = texture else { continue };
        let (lo, hi) = range.unwrap_or((0.0, 0.0));
        let (lo, hi) = match orientation {
            Orientation::Up => (-hi, -lo),
            Orientation::Down => (lo, hi),
        };
        let band = Band::covering(start, lo, hi, texture).ok_or_else(too_large)?;
        start = start
            .checked_add_unsigned(band.span)
            .ok_or_else(too_large)?;
        bands.push(band);
        placements[m] = Some(Placement {
            band,
            orientation: Some(orientation),
        });
    }
    if materials.iter().any(|(texture, _)| texture.is_none()) {
        let band = Band::covering(start, 0.0, 0.0, NO_TEXTURE).ok_or_else(too_large)?;
        bands.push(band);
        for (m, (texture, _)) in materials.iter().enumerate() {
            if texture.is_none() {
                placements[m] = Some(Placement {
                    band,
                    orientation: None,
                });
            }
        }
    }
    let placements = placements
        .into_iter()
        .map(|p| p.expect("every material placed"))
        .collect();
    Ok((bands, placements))
}

/// Moves each triangle's corners into the band of its material (`material_of[t]`, an index
/// into `placements`): a raw vertex used by triangles of several materials is copied for each
/// further one (a material border is a seam). A mesh without coordinates gets them (0, 0)
/// first.
pub(crate) fn place_corners(
    mesh: &mut RawMesh,
    material_of: &[u32],
    placements: &[Placement],
) -> Result<(), K> {
    assert_eq!(
        material_of.len(),
        mesh.triangles.len(),
        "a material a triangle"
    );
    let n = mesh.positions.len();
    mesh.uvs.get_or_insert_with(|| vec![[0.0; 2]; n]);
    let mut owner = vec![u32::MAX; n];
    let mut copies: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    for (t, &m) in mesh.triangles.iter_mut().zip(material_of) {
        for v in t.iter_mut() {
            let o = &mut owner[*v as usize];
            if *o == u32::MAX {
                *o = m;
            }
            if *o == m {
                continue;
            }
            let next = u32::try_from(mesh.positions.len())
                .ok()
                .filter(|&next| next < u32::MAX)
                .ok_or_else(|| K::TooLarge {
                    at: Location::None,
                    msg: "more than 4294967295 vertices once material borders are split".into(),
                })?;
            let at = *copies.entry((*v, m)).or_insert(next);
            if at == next {
                let i = *v as usize;
                mesh.positions.push(mesh.positions[i]);
                if let Some(a) = &mut mesh.normals {
                    a.push(a[i]);
                }
                if let Some(a) = &mut mesh.colors {
                    a.push(a[i]);
                }
                if let Some(a) = &mut mesh.uvs {
                    a.push(a[i]);
                }
                owner.push(m);
            }
            *v = at;
        }
    }
    let uvs = mesh.uvs.as_mut().expect("made above");
    for (uv, &m) in uvs.iter_mut().zip(&owner) {
        if m != u32::MAX {
            *uv = placements[m as usize].place(*uv);
        }
    }
    Ok(())
}

/// A sink that keeps only the range of its vertices' `v` (a first pass over a file).
#[derive(Default)]
pub(crate) struct VRange {
    pub range: Option<(f32, f32)>,
}

impl MeshSink for VRange {
    fn vertex(&mut self, v: &RawVertex) -> Result<(), K> {
        grow(&mut self.range, v.uv[1]);
        Ok(())
    }
    fn triangles(&mut self, _: &[[u32; 3]]) -> Result<(), K> {
        Ok(())
    }
    fn forget_colors(&mut self) {}
    fn face_color(&mut self, _: usize, _: [u8; 4]) -> Result<(), K> {
        Ok(())
    }
}

/// Textures listed once each: the index of `texture` among `list`, appended if new (two
/// materials naming one file share it).
pub(crate) fn texture_index(list: &mut Vec<TextureInput>, texture: TextureInput) -> u32 {
    match list.iter().position(|t| *t == texture) {
        Some(i) => i as u32,
        None => {
            list.push(texture);
            (list.len() - 1) as u32
        }
    }
}

/// The name of a texture file for messages (its file name, or the path).
pub(crate) fn file_name(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::texture::bands_valid;

    #[test]
    fn textured_materials_take_bands_from_zero_and_untextured_share_one() {
        let materials = [
            (Some(0), Some((-0.49, 1.48))),
            (None, Some((0.2, 0.3))),
            (Some(1), Some((1e-9, 1e-9))),
            (None, None),
        ];
        let (bands, placements) = place_materials(&materials, Orientation::Up).unwrap();
        assert!(bands_valid(&bands, 2));
        assert_eq!(bands.len(), 3);
        // −v in [−1.48, 0.49]: floor from −2 to 0, three integers.
        assert_eq!((bands[0].start, bands[0].span, bands[0].shift), (0, 3, 2));
        assert_eq!((bands[1].start, bands[1].span), (3, 1));
        assert_eq!((bands[2].start, bands[2].texture), (4, NO_TEXTURE));
        assert_eq!(placements[1], placements[3]);
        assert_eq!(placements[0].place([0.25, 1.48]), [0.25, 2.0 - 1.48]);
        assert_eq!(placements[3].place([7.0, 9.0]), [0.0, 4.5]);
        // 4 − 1e-9 rounds to 4, the band's end: put back just below it.
        let top = placements[2].place([0.0, 1e-9]);
        assert!(bands[1].contains(top[1]) && top[1] < 4.0, "{top:?}");
        let (down, p) = place_materials(&materials[..1], Orientation::Down).unwrap();
        assert_eq!(
            (down[0].shift, p[0].place([0.0, -0.49])[1]),
            (1, 1.0 - 0.49)
        );
    }

    #[test]
    fn corners_shared_by_two_materials_are_copied() {
        let mut mesh = RawMesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2], [1, 3, 2]],
            uvs: Some(vec![[0.0, 0.25]; 4]),
            ..Default::default()
        };
        let (_, placements) = place_materials(
            &[(Some(0), Some((0.25, 0.25))), (None, None)],
            Orientation::Up,
        )
        .unwrap();
        place_corners(&mut mesh, &[0, 1], &placements).unwrap();
        assert_eq!(
            mesh.positions.len(),
            6,
            "vertices 1 and 2 copied for material 1"
        );
        assert_eq!(mesh.triangles[1], [4, 3, 5]);
        let uvs = mesh.uvs.unwrap();
        assert_eq!(uvs[0], [0.0, 0.75]);
        assert_eq!(uvs[3], [0.0, 1.5]);
        assert_eq!(uvs[4], [0.0, 1.5]);
    }
}
