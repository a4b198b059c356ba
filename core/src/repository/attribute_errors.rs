//! The attribute error table (`SECTION_ATTRIBUTE_ERRORS`, optional): how far each diamond's
//! patches stray in appearance from what they replace, beside the geometric error of its
//! `DiamondRecord`.
//!
//! ```text
//! SECTION_ATTRIBUTE_ERRORS   AttributeErrorRecord × diamond_count   (16 bytes each)
//!                            in diamond table order; flags SECTION_FLAG_OPTIONAL;
//!                            its CRC-32 in the section table, checked on open
//! ```
//!
//! Written by a build whose input has colours or texture coordinates, and only then, so a
//! repository of an input without them has the bytes it had before the table existed. The
//! table is optional: a tessera that predates it skips it, and a repository without it opens
//! with `Repository::attribute_errors` = `None`.
//!
//! Each record holds the *saturated* errors: a diamond's own error (what its simplification
//! lost, measured by the builder: `preprocess/src/simplify/attribute_error.rs`) and the maximum
//! over its children's, so a parent's error is at least each child's, as for the geometric
//! error. An attribute the input does not have is stored as 0.

use bytemuck::{Pod, Zeroable};

use super::reader::{corrupt, RepositoryError};

/// One diamond's saturated attribute errors. Every field is finite and ≥ 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AttributeErrorRecord {
    /// f32: the largest colour distance, Euclidean over R, G and B in 8-bit units (0..=441.7).
    pub colour: f32,
    /// f32: the largest angle between a normal and the one the kept patch has there, degrees
    /// (0..=180).
    pub normal_degrees: f32,
    /// f32: the largest texture-coordinate deviation, Euclidean in UV units (texels once a
    /// texture's size is known: multiply by it).
    pub uv: f32,
    /// f32: 0 (reserved for a later error; a reader refuses anything else).
    pub reserved: f32,
}

/// Size of one attribute error record on disk, in bytes.
pub const ATTRIBUTE_ERROR_RECORD_SIZE: usize = std::mem::size_of::<AttributeErrorRecord>();
const _: () = assert!(ATTRIBUTE_ERROR_RECORD_SIZE == 16);

impl AttributeErrorRecord {
    /// The largest of each field over `records` (zero for none).
    pub fn max_of<'a>(records: impl IntoIterator<Item = &'a AttributeErrorRecord>) -> Self {
        records
            .into_iter()
            .fold(AttributeErrorRecord::default(), |m, r| {
                AttributeErrorRecord {
                    colour: m.colour.max(r.colour),
                    normal_degrees: m.normal_degrees.max(r.normal_degrees),
                    uv: m.uv.max(r.uv),
                    reserved: 0.0,
                }
            })
    }
}

/// Checks an attribute error table against the diamond table's length: one record a diamond,
/// every error finite and ≥ 0, every reserved field 0. Shared by the reader and the writers.
pub(crate) fn check_attribute_errors(
    records: &[AttributeErrorRecord],
    diamond_count: usize,
) -> Result<(), RepositoryError> {
    if records.len() != diamond_count {
        return Err(corrupt(format!(
            "attribute error table has {} records for {diamond_count} diamonds",
            records.len()
        )));
    }
    for (i, r) in records.iter().enumerate() {
        let errors = [r.colour, r.normal_degrees, r.uv];
        if !errors.iter().all(|e| e.is_finite() && *e >= 0.0) || r.reserved != 0.0 {
            return Err(corrupt(format!(
                "diamond {i}: attribute errors (colour {}, normal {} degrees, uv {}) are not all \
                 finite and non-negative, or reserved field {} is not 0",
                r.colour, r.normal_degrees, r.uv, r.reserved
            )));
        }
    }
    Ok(())
}
