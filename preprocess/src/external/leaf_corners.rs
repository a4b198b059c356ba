//! The leaves' triangles read out of the staged triangle file once the hierarchy is built
//! (issue 12): each leaf's triangles, in the hierarchy's order, coded as rows of its sorted
//! vertex ids (`hierarchy::encode_corners`, about five bytes a triangle). The staged triangle
//! file (twelve bytes a triangle, in the input's order) then goes: it would otherwise stay on
//! disk beside the leaves' live patches until the leaves' commit, the build's temporary peak.

use std::io;
use std::path::Path;

use rayon::prelude::*;
use tessera_core::leb::SimplexKey;

use super::cursor::{in_passes, Cursor};
use super::fallible::check;
use super::staged::RecordFile;
use crate::hierarchy::{encode_corners, LeafCorners, LeafListSpool, LeafListWriter};

/// The triangles `lists` names (indices into `triangles`), a leaf at a time in key order, in
/// a new spool in `dir`: a group of leaves of about `max_triangles` triangles costs one pass
/// over the triangle file (up to the group's last triangle; a few passes side by side, each
/// over its own range of triangles).
pub fn leaf_corners(
    triangles: &RecordFile<[u32; 3]>,
    lists: LeafListSpool,
    max_triangles: usize,
    dir: &Path,
) -> io::Result<LeafCorners> {
    let mut writer = LeafListWriter::new(dir)?;
    let leaves = lists.leaves().len();
    let mut start = 0;
    // The passes' cursor blocks, kept from group to group.
    let mut blocks: Vec<Vec<[u32; 3]>> = Vec::new();
    while start < leaves {
        let mut end = start;
        let mut n = 0;
        while end < leaves && (end == start || n < max_triangles.max(1)) {
            n += lists.leaf(end).1;
            end += 1;
        }
        // The group's lists, read and checked side by side.
        let group_lists: Vec<Vec<u32>> = (start..end)
            .into_par_iter()
            .map(|leaf| {
                let list = lists.list(leaf)?;
                if !list.windows(2).all(|w| w[0] < w[1]) {
                    return Err(io::Error::other(format!(
                        "leaf {:?} lists its triangles out of order",
                        lists.leaf(leaf).0
                    )));
                }
                Ok(list)
            })
            .collect::<io::Result<_>>()?;
        // (triangle, leaf in the group), by triangle. A leaf lists its triangles in ascending
        // order (both constructions keep the input's), so taking them in file order keeps it.
        let mut wanted: Vec<(u32, u32)> = Vec::with_capacity(n);
        let mut group: Vec<Vec<[u32; 3]>> = Vec::with_capacity(end - start);
        for (i, list) in group_lists.into_iter().enumerate() {
            group.push(Vec::with_capacity(list.len()));
            wanted.extend(list.into_iter().map(|t| (t, i as u32)));
        }
        wanted.par_sort_unstable();
        let mut corners = vec![[0u32; 3]; wanted.len()];
        in_passes(&wanted, &mut corners, &mut blocks, |wanted, out, block| {
            let mut file = Cursor::reusing(triangles, std::mem::take(block))?;
            for (c, &(t, _)) in out.iter_mut().zip(wanted) {
                *c = file.at(t);
            }
            *block = std::mem::take(&mut file.block);
            check(file.error.take())
        })?;
        for (&(_, leaf), c) in wanted.iter().zip(corners) {
            group[leaf as usize].push(c);
        }
        drop(wanted);
        let coded: Vec<Vec<u8>> = group
            .par_iter()
            .map(|triangles| {
                let mut out = Vec::new();
                encode_corners(&mut out, triangles);
                out
            })
            .collect();
        for (i, (bytes, triangles)) in coded.iter().zip(&group).enumerate() {
            writer.write_coded(lists.leaf(start + i).0, triangles.len(), bytes)?;
        }
        start = end;
    }
    let keys: Vec<SimplexKey> = lists.leaves().map(|(k, _)| k).collect();
    drop(lists);
    Ok(LeafCorners {
        spool: writer.finish(keys.into_iter())?,
    })
}
