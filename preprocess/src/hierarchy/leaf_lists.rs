//! Each leaf's input triangles, on disk (issue 12): at 100 M triangles the lists are 400 MB
//! and more as u32s, which an out-of-core build may not hold. The bucketed construction writes
//! each leaf's list to one unnamed temporary file as soon as it is final and keeps only where
//! it is (a few dozen bytes per leaf, some 125 triangles); the leaves' patches are then made
//! from it a group at a time (`external::LeafGroups`), in key order.
//!
//! A list is stored as varints: its first index, then each index's difference from the one
//! before (zigzagged; a list is ascending, so about a byte a triangle where the input's
//! neighbours follow each other).

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::os::unix::fs::FileExt;
use std::path::Path;

use rustc_hash::FxHashMap as HashMap;

use tessera_core::leb::SimplexKey;

use crate::external::packed_columns;
use crate::external::temp_usage::{Charge, TempKind};
use crate::external::varint;

/// Where a leaf's list is in its file: offset, triangles, bytes.
pub(crate) type ListSpan = (u64, u32, u64);

/// Appends `list` coded (see the module's doc).
pub(crate) fn encode_list(out: &mut Vec<u8>, list: &[u32]) {
    let mut previous = 0i64;
    for &t in list {
        varint::put(out, varint::zigzag(t as i64 - previous));
        previous = t as i64;
    }
}

/// The `n` indices coded in `bytes`, which must hold exactly them, each below `below`.
pub(crate) fn decode_list(bytes: &[u8], n: usize, below: u64) -> io::Result<Vec<u32>> {
    let corrupt = || {
        io::Error::new(
            io::ErrorKind::InvalidData,
            "a leaf's triangle list is corrupt",
        )
    };
    let mut list = Vec::with_capacity(n.min(bytes.len()));
    let (mut at, mut previous) = (0usize, 0i64);
    for _ in 0..n {
        let d = varint::get(bytes, &mut at).ok_or_else(corrupt)?;
        let t = previous.wrapping_add(varint::unzigzag(d));
        if !(0..below.min(1 << 32) as i64).contains(&t) {
            return Err(corrupt());
        }
        list.push(t as u32);
        previous = t;
    }
    if at != bytes.len() {
        return Err(corrupt());
    }
    Ok(list)
}

/// Appends `triangles` (global vertex ids) coded: the count of distinct ids as a varint, each
/// corner as a row of the sorted ids, then the ids (`external::packed_columns`): about five
/// bytes a triangle at any vertex order, where the staged triangle file takes twelve.
pub(crate) fn encode_corners(out: &mut Vec<u8>, triangles: &[[u32; 3]]) {
    let mut ids: Vec<u32> = triangles.iter().flatten().copied().collect();
    ids.sort_unstable();
    ids.dedup();
    varint::put(out, ids.len() as u64);
    if ids.is_empty() {
        return;
    }
    let rows: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|v| ids.binary_search(&v).expect("a corner among the ids") as u32))
        .collect();
    packed_columns::put_rows(&rows, ids.len(), out);
    packed_columns::put_ids(&ids, out);
}

/// The `n` triangles coded in `bytes` (`encode_corners`), every id below `vertices`.
pub(crate) fn decode_corners(bytes: &[u8], n: usize, vertices: u64) -> io::Result<Vec<[u32; 3]>> {
    decode_corners_and_ids(bytes, n, vertices).map(|(triangles, _)| triangles)
}

/// `decode_corners`, with the triangles' distinct ids, ascending (as they are stored).
fn decode_corners_and_ids(
    bytes: &[u8],
    n: usize,
    vertices: u64,
) -> io::Result<(Vec<[u32; 3]>, Vec<u32>)> {
    let corrupt = || io::Error::new(io::ErrorKind::InvalidData, "a leaf's triangles are corrupt");
    let mut at = 0;
    let v = varint::get(bytes, &mut at).ok_or_else(corrupt)?;
    if v == 0 {
        return if n == 0 && at == bytes.len() {
            Ok((Vec::new(), Vec::new()))
        } else {
            Err(corrupt())
        };
    }
    // Every id is a corner: at most three a triangle.
    if v > 3 * n as u64 {
        return Err(corrupt());
    }
    let v = v as usize;
    let ids_at = at + packed_columns::rows_bytes(n, v);
    if ids_at > bytes.len() {
        return Err(corrupt());
    }
    let rows = packed_columns::get_rows(&bytes[at..ids_at], n, v)?;
    let ids = packed_columns::get_ids(&bytes[ids_at..], v)?;
    if ids.last().is_some_and(|&last| last as u64 >= vertices) {
        return Err(corrupt());
    }
    let triangles = rows.iter().map(|r| r.map(|i| ids[i as usize])).collect();
    Ok((triangles, ids))
}

/// Each leaf's triangle indices (ascending, as both constructions keep the input's order), in
/// a file, with an index by leaf key; or, once the staged triangles are read into it
/// (`external::leaf_corners`), each leaf's triangles themselves (`LeafCorners`).
#[derive(Debug)]
pub struct LeafListSpool {
    file: File,
    /// Every leaf (empty ones too), by key, with where its list is.
    index: Vec<(SimplexKey, ListSpan)>,
    /// The file's bytes, in the build's temporary totals (none for a checkpoint's own file).
    charge: Charge,
}

impl LeafListSpool {
    /// The leaves, in key order, with their triangle counts.
    pub fn leaves(&self) -> impl ExactSizeIterator<Item = (SimplexKey, usize)> + '_ {
        self.index.iter().map(|&(k, (_, n, _))| (k, n as usize))
    }

    /// The `i`th leaf in key order, with its triangle count.
    pub fn leaf(&self, i: usize) -> (SimplexKey, usize) {
        let (k, (_, n, _)) = self.index[i];
        (k, n as usize)
    }

    /// The leaves' triangles in all.
    pub fn triangles(&self) -> u64 {
        self.index.iter().map(|&(_, (_, n, _))| n as u64).sum()
    }

    /// The list of the `i`th leaf in key order.
    pub fn list(&self, i: usize) -> io::Result<Vec<u32>> {
        let (n, coded) = self.coded(i)?;
        decode_list(&coded, n as usize, u64::MAX)
    }

    /// The `i`th leaf's list as stored (`encode_list`), with its triangle count.
    pub(crate) fn coded(&self, i: usize) -> io::Result<(u32, Vec<u8>)> {
        let (_, (at, n, bytes)) = self.index[i];
        let mut coded = vec![0u8; bytes as usize];
        self.file.read_exact_at(&mut coded, at)?;
        Ok((n, coded))
    }

    /// Every list, in memory (for `Hierarchy::leaf_triangles` and the tests).
    pub fn into_map(self) -> io::Result<HashMap<SimplexKey, Vec<u32>>> {
        (0..self.index.len())
            .map(|i| Ok((self.index[i].0, self.list(i)?)))
            .collect()
    }

    /// Where each leaf's coded items are in the file (key order).
    pub(crate) fn spans(&self) -> &[(SimplexKey, ListSpan)] {
        &self.index
    }

    /// Gives the file the name `path` (a checkpoint's): linked where the file system allows
    /// it (`O_TMPFILE`), so its bytes are on disk once, else copied; its bytes are then the
    /// checkpoint's, not this spool's. Returns its length and CRC-32.
    pub(crate) fn keep_at(&mut self, path: &Path) -> io::Result<(u64, u32)> {
        let len = self.file.metadata()?.len();
        let (crc32, copy) = crate::external::file_io::keep_unnamed_at(&self.file, len, path)?;
        if let Some(copy) = copy {
            self.file = copy;
        }
        self.charge.release();
        Ok((len, crc32))
    }

    /// The lists of `map` spooled to an unnamed file in `dir`.
    pub fn from_map(map: &HashMap<SimplexKey, Vec<u32>>, dir: &Path) -> io::Result<Self> {
        let mut writer = LeafListWriter::new(dir)?;
        for (&key, list) in map {
            writer.write(key, list)?;
        }
        writer.finish(map.keys().copied())
    }

    /// Lists already in a file (a checkpoint's), at the given places: `index` is sorted by
    /// key here, and every list must lie inside the file.
    pub(crate) fn in_file(
        file: File,
        mut index: Vec<(SimplexKey, ListSpan)>,
    ) -> io::Result<LeafListSpool> {
        let len = file.metadata()?.len();
        if index
            .iter()
            .any(|&(_, (at, _, bytes))| at.checked_add(bytes).is_none_or(|end| end > len))
        {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "a leaf's triangle list lies outside its file",
            ));
        }
        index.sort_unstable_by_key(|&(k, _)| k);
        Ok(LeafListSpool {
            file,
            index,
            charge: Charge::new(TempKind::LeafLists),
        })
    }
}

/// Each leaf's triangles (global vertex ids, in the hierarchy's order), coded
/// (`encode_corners`) in a `LeafListSpool`'s file: what the leaves' patches are made from
/// once the staged triangle file is gone (`external::leaf_corners`).
#[derive(Debug)]
pub struct LeafCorners {
    pub(crate) spool: LeafListSpool,
}

impl LeafCorners {
    /// The leaves, in key order, with their triangle counts.
    pub fn leaves(&self) -> impl ExactSizeIterator<Item = (SimplexKey, usize)> + '_ {
        self.spool.leaves()
    }

    /// The `i`th leaf in key order, with its triangle count.
    pub fn leaf(&self, i: usize) -> (SimplexKey, usize) {
        self.spool.leaf(i)
    }

    /// The triangles of the `i`th leaf in key order, and their distinct vertex ids ascending.
    pub fn triangles_of(&self, i: usize) -> io::Result<(Vec<[u32; 3]>, Vec<u32>)> {
        let (n, coded) = self.spool.coded(i)?;
        decode_corners_and_ids(&coded, n as usize, u64::MAX)
    }

    /// The triangles of `map` spooled to an unnamed file in `dir`, in key order (as
    /// `external::leaf_corners` writes them).
    pub fn from_map(map: &HashMap<SimplexKey, Vec<[u32; 3]>>, dir: &Path) -> io::Result<Self> {
        let mut writer = LeafListWriter::new(dir)?;
        let mut coded = Vec::new();
        let mut keys: Vec<SimplexKey> = map.keys().copied().collect();
        keys.sort_unstable();
        for key in keys {
            let triangles = &map[&key];
            coded.clear();
            encode_corners(&mut coded, triangles);
            writer.write_coded(key, triangles.len(), &coded)?;
        }
        Ok(LeafCorners {
            spool: writer.finish(map.keys().copied())?,
        })
    }
}

/// Writes leaves' lists to an unnamed temporary file as they become final. A leaf written
/// again (its earlier list made stale by a later split) keeps its latest list; a forgotten
/// one (split since) has none.
pub struct LeafListWriter {
    file: BufWriter<File>,
    end: u64,
    spans: HashMap<SimplexKey, ListSpan>,
    charge: Charge,
    coded: Vec<u8>,
}

impl LeafListWriter {
    /// A writer whose file (no name: gone when dropped or the process dies) lies in `dir`.
    pub fn new(dir: &Path) -> io::Result<Self> {
        Ok(LeafListWriter {
            file: BufWriter::with_capacity(1 << 20, tempfile::tempfile_in(dir)?),
            end: 0,
            spans: HashMap::default(),
            charge: Charge::new(TempKind::LeafLists),
            coded: Vec::new(),
        })
    }

    pub fn write(&mut self, key: SimplexKey, list: &[u32]) -> io::Result<()> {
        self.coded.clear();
        encode_list(&mut self.coded, list);
        let coded = std::mem::take(&mut self.coded);
        let written = self.write_coded(key, list.len(), &coded);
        self.coded = coded;
        written
    }

    /// Writes a leaf's `n` items already coded.
    pub(crate) fn write_coded(
        &mut self,
        key: SimplexKey,
        n: usize,
        coded: &[u8],
    ) -> io::Result<()> {
        self.file.write_all(coded)?;
        let bytes = coded.len() as u64;
        self.spans.insert(key, (self.end, n as u32, bytes));
        self.end += bytes;
        self.charge.grow(bytes);
        Ok(())
    }

    /// Takes `key`'s list out, if written (the leaf was split): where it is, for `read`.
    pub fn take(&mut self, key: SimplexKey) -> Option<ListSpan> {
        self.spans.remove(&key)
    }

    /// A list written earlier, at `span` (each index below `below`).
    pub fn read(&mut self, span: ListSpan, below: u64) -> io::Result<Vec<u32>> {
        self.file.flush()?;
        let (offset, n, bytes) = span;
        let mut coded = vec![0u8; bytes as usize];
        self.file.get_ref().read_exact_at(&mut coded, offset)?;
        decode_list(&coded, n as usize, below)
    }

    /// The spool of `leaves` (each with its latest list; one never written has none). A list
    /// written for a key not among `leaves` is an error: a leaf the hierarchy no longer has.
    pub fn finish(mut self, leaves: impl Iterator<Item = SimplexKey>) -> io::Result<LeafListSpool> {
        self.file.flush()?;
        let mut index: Vec<(SimplexKey, ListSpan)> = leaves
            .map(|k| (k, self.spans.remove(&k).unwrap_or((0, 0, 0))))
            .collect();
        if let Some(key) = self.spans.keys().next() {
            return Err(io::Error::other(format!(
                "leaf lists: {key:?} has a list but is not a leaf"
            )));
        }
        index.sort_unstable_by_key(|&(k, _)| k);
        let file = self.file.into_inner().map_err(|e| e.into_error())?;
        Ok(LeafListSpool {
            file,
            index,
            charge: self.charge,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(path: u128) -> SimplexKey {
        SimplexKey {
            root: 0,
            level: 3,
            path,
        }
    }

    #[test]
    fn lists_come_back_by_key_the_latest_written_and_taken_ones_gone() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = LeafListWriter::new(dir.path()).unwrap();
        w.write(key(5), &[1, 2, 3]).unwrap();
        w.write(key(2), &[9]).unwrap();
        w.write(key(7), &[4, 8]).unwrap();
        w.write(key(5), &[10, 11]).unwrap(); // rewritten: the latest counts
        let taken = w.take(key(7)).unwrap();
        assert!(w.take(key(7)).is_none(), "taken once");
        assert_eq!(w.read(taken, 9).unwrap(), [4, 8], "a taken list reads back");
        assert!(w.read(taken, 8).is_err(), "an index past the bound");
        w.write(key(3), &[5]).unwrap(); // written after a read: the file goes on
        let spool = w
            .finish([key(2), key(3), key(5), key(6)].into_iter())
            .unwrap();
        let leaves: Vec<_> = spool.leaves().collect();
        assert_eq!(leaves, [(key(2), 1), (key(3), 1), (key(5), 2), (key(6), 0)]);
        assert_eq!(spool.list(0).unwrap(), [9]);
        assert_eq!(spool.list(1).unwrap(), [5]);
        assert_eq!(spool.list(2).unwrap(), [10, 11]);
        assert!(spool.list(3).unwrap().is_empty());
        assert_eq!(spool.triangles(), 4);
        let map = spool.into_map().unwrap();
        assert_eq!(map.len(), 4);
        assert_eq!(map[&key(5)], [10, 11]);
    }

    #[test]
    fn a_list_for_a_key_that_is_no_leaf_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = LeafListWriter::new(dir.path()).unwrap();
        w.write(key(1), &[1]).unwrap();
        assert!(w.finish([key(2)].into_iter()).is_err());
    }

    #[test]
    fn lists_outside_their_file_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lists.bin");
        std::fs::write(&path, [0u8; 12]).unwrap();
        let open = || File::open(&path).unwrap();
        assert!(LeafListSpool::in_file(open(), vec![(key(1), (4, 8, 8))]).is_ok());
        assert!(LeafListSpool::in_file(open(), vec![(key(1), (4, 9, 9))]).is_err());
        assert!(LeafListSpool::in_file(open(), vec![(key(1), (u64::MAX, 1, 1))]).is_err());
    }

    #[test]
    fn corners_come_back_in_order_and_damage_is_refused() {
        let sets: [Vec<[u32; 3]>; 3] = [
            vec![],
            vec![[7, 3, 9]],
            // A strip over scattered ids: two triangles a vertex, as in a mesh.
            (0..500u32)
                .map(|i| [i, i + 1, i + 2].map(|j| j * 7919 % 100_003))
                .collect(),
        ];
        for triangles in &sets {
            let mut coded = Vec::new();
            encode_corners(&mut coded, triangles);
            let n = triangles.len();
            assert_eq!(decode_corners(&coded, n, 100_003).unwrap(), *triangles);
            if !triangles.is_empty() {
                // A cut, a wrong count: refused.
                assert!(decode_corners(&coded[..coded.len() - 1], n, 100_003).is_err());
                assert!(decode_corners(&coded, n + 1, 100_003).is_err());
            }
        }
        let mut coded = Vec::new();
        encode_corners(&mut coded, &sets[2]);
        assert!(coded.len() < 6 * 500, "{} bytes", coded.len());
        // An id at the bound: refused.
        let last = *sets[2].iter().flatten().max().unwrap() as u64;
        assert!(decode_corners(&coded, 500, last).is_err());
        assert!(decode_corners(&coded, 500, last + 1).is_ok());
        let mut coded = Vec::new();
        encode_corners(&mut coded, &sets[1]);
        assert!(decode_corners(&coded, 1, 9).is_err());
        assert!(decode_corners(&coded, 1, 10).is_ok());
    }

    #[test]
    fn lists_are_coded_in_about_a_byte_a_neighbour_and_come_back() {
        let lists: [Vec<u32>; 5] = [
            vec![],
            vec![0],
            vec![u32::MAX],
            (1_000_000..1_001_000).collect(),
            vec![5, 3, u32::MAX, 0, 7],
        ];
        for list in &lists {
            let mut coded = Vec::new();
            encode_list(&mut coded, list);
            assert_eq!(decode_list(&coded, list.len(), u64::MAX).unwrap(), *list);
            // One fewer, one more, a byte too many: refused.
            if !list.is_empty() {
                assert!(decode_list(&coded, list.len() - 1, u64::MAX).is_err());
            }
            assert!(decode_list(&coded, list.len() + 1, u64::MAX).is_err());
            let mut longer = coded.clone();
            longer.push(0);
            assert!(decode_list(&longer, list.len(), u64::MAX).is_err());
        }
        let mut coded = Vec::new();
        encode_list(&mut coded, &lists[3]);
        assert!(coded.len() <= 3 + 999, "{} bytes", coded.len());
        // An index at or over the bound is refused.
        assert!(decode_list(&coded, 1000, 1_000_999).is_err());
        assert!(decode_list(&coded, 1000, 1_001_000).is_ok());
    }
}
