//! Units of residency: R(D), the patches that splitting diamond D creates.
//!
//! A diamond D's split replaces D's simplices by their children; R(D) is the set of those
//! children's patches. D may refine only when R(D) is resident (and every parent of D may
//! refine), so the unit is what the loader reads, uploads and evicts as one. The roots'
//! patches belong to no unit: they are pinned.
//!
//! The tables here are derived once from the directory, in O(tets + diamonds) time and memory:
//! per diamond its DAG edges, unit bytes and level, and the simplex ids of each unit (4 bytes
//! per simplex) — ids only, no copy of the records, which are read through the map. (On the
//! GPU the directory is paged with the units: `gpu::records`. These CPU tables, with the
//! residency's per-diamond state, are what still grows with the model in the process: by
//! their element sizes, 4 bytes per simplex of unit rows and roughly 80–110 bytes per
//! diamond together — about 1.2 MB and 2–3 MB for the 20 M-triangle repository's 294,198
//! simplices and 27,532 diamonds; computed, not measured.)

use tessera_core::repository::format::{DiamondRecord, TetRecord, NO_INDEX};
use tessera_core::repository::patch::drawn_patch_bytes;
use tessera_core::repository::reader::Repository;

/// A pass over (row, item) pairs: calls its visitor once per pair.
type PairScan<'a> = &'a dyn Fn(&mut dyn FnMut(u32, u32));
/// A pass over the diamond table: calls its visitor once per record, in order.
type DiamondScan<'a> = &'a dyn Fn(&mut dyn FnMut(usize, &DiamondRecord));

/// Compressed rows: row `r` is `items[starts[r]..starts[r + 1]]`.
#[derive(Clone, Debug, Default)]
struct Rows {
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl Rows {
    /// Rows from (row, item) pairs; rows keep the pairs' order.
    fn from_pairs(row_count: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Rows {
        let mut starts = vec![0u32; row_count + 1];
        for (r, _) in pairs.clone() {
            starts[r as usize + 1] += 1;
        }
        for r in 0..row_count {
            starts[r + 1] += starts[r];
        }
        let mut fill = starts.clone();
        let mut items = vec![0u32; starts[row_count] as usize];
        for (r, item) in pairs {
            items[fill[r as usize] as usize] = item;
            fill[r as usize] += 1;
        }
        Rows { starts, items }
    }

    /// Rows from the (row, item) pairs that `scan` hands to its visitor, in two scans (count,
    /// then fill); rows keep the pairs' order.
    fn from_scan(row_count: usize, scan: PairScan) -> Rows {
        let mut starts = vec![0u32; row_count + 1];
        scan(&mut |r, _| starts[r as usize + 1] += 1);
        for r in 0..row_count {
            starts[r + 1] += starts[r];
        }
        let mut fill = starts.clone();
        let mut items = vec![0u32; starts[row_count] as usize];
        scan(&mut |r, item| {
            items[fill[r as usize] as usize] = item;
            fill[r as usize] += 1;
        });
        Rows { starts, items }
    }

    fn row(&self, r: usize) -> &[u32] {
        &self.items[self.starts[r] as usize..self.starts[r + 1] as usize]
    }
}

/// The units of a repository and the diamond DAG's edges both ways.
#[derive(Clone, Debug)]
pub struct UnitTable {
    /// Per diamond: the simplices its split creates (its unit's patches).
    created: Rows,
    /// Per diamond: the diamonds that list it as a parent.
    children: Rows,
    /// Per diamond: its parents (copied out of the records for locality).
    parents: Rows,
    /// Per diamond: bytes of its unit's patches.
    unit_bytes: Vec<u64>,
    /// Per diamond: LEB level.
    levels: Vec<u32>,
    /// Bytes of the roots' patches (pinned).
    root_bytes: u64,
    /// The roots.
    roots: Vec<u32>,
}

impl UnitTable {
    /// Derives the units from a validated directory (`Repository::diamonds`, `tets`).
    /// `drawn`: a patch's size on the GPU (`patch::drawn_patch_bytes` with the repository's
    /// attributes).
    pub fn new(
        diamonds: &[DiamondRecord],
        tets: &[TetRecord],
        root_count: usize,
        drawn: &dyn Fn(&TetRecord) -> u64,
    ) -> UnitTable {
        let created = Rows::from_pairs(
            diamonds.len(),
            tets.iter().enumerate().filter_map(|(i, t)| {
                (t.parent_diamond != NO_INDEX).then_some((t.parent_diamond, i as u32))
            }),
        );
        let unit_bytes = (0..diamonds.len())
            .map(|d| {
                created
                    .row(d)
                    .iter()
                    .map(|&t| drawn(&tets[t as usize]))
                    .sum()
            })
            .collect();
        let root_bytes = (0..root_count).map(|t| drawn(&tets[t])).sum();
        let scan = |visit: &mut dyn FnMut(usize, &DiamondRecord)| {
            for (i, d) in diamonds.iter().enumerate() {
                visit(i, d);
            }
        };
        Self::with_created(
            diamonds.len(),
            &scan,
            created,
            unit_bytes,
            root_count,
            root_bytes,
        )
    }

    /// The same table as `new` for an open repository, its tet table read in two passes that
    /// drop its pages behind them (`Repository::scan_tets`): the process never holds the
    /// whole directory, nor a list of (diamond, simplex) pairs.
    pub fn from_repository(repo: &Repository) -> UnitTable {
        let diamonds = repo.diamonds();
        let root_count = repo.header().root_tet_count as usize;
        let mut starts = vec![0u32; diamonds.len() + 1];
        let mut unit_bytes = vec![0u64; diamonds.len()];
        let mut root_bytes = 0;
        let attributes = repo.header().attributes;
        repo.scan_tets(|i, t| {
            let drawn = drawn_patch_bytes(t, attributes);
            if t.parent_diamond != NO_INDEX {
                starts[t.parent_diamond as usize + 1] += 1;
                unit_bytes[t.parent_diamond as usize] += drawn;
            }
            if i < root_count {
                root_bytes += drawn;
            }
        });
        for r in 0..diamonds.len() {
            starts[r + 1] += starts[r];
        }
        let mut fill = starts.clone();
        let mut items = vec![0u32; starts[diamonds.len()] as usize];
        repo.scan_tets(|i, t| {
            if t.parent_diamond != NO_INDEX {
                let slot = &mut fill[t.parent_diamond as usize];
                items[*slot as usize] = i as u32;
                *slot += 1;
            }
        });
        let created = Rows { starts, items };
        // The diamond table through the map too, its pages dropped behind each pass.
        let scan = |visit: &mut dyn FnMut(usize, &DiamondRecord)| repo.scan_diamonds(visit);
        Self::with_created(
            diamonds.len(),
            &scan,
            created,
            unit_bytes,
            root_count,
            root_bytes,
        )
    }

    /// The rest of the table from the diamond table (`scan` visits every record in order)
    /// and the units' rows and bytes.
    fn with_created(
        diamond_count: usize,
        scan: DiamondScan,
        created: Rows,
        unit_bytes: Vec<u64>,
        root_count: usize,
        root_bytes: u64,
    ) -> UnitTable {
        // Edges (parent, child) of the diamond DAG, visited from the child's record.
        let edges = |child_major: bool| {
            move |visit: &mut dyn FnMut(u32, u32)| {
                scan(&mut |i, d| {
                    for &p in d.parents() {
                        if child_major {
                            visit(i as u32, p);
                        } else {
                            visit(p, i as u32);
                        }
                    }
                })
            }
        };
        let children = Rows::from_scan(diamond_count, &edges(false));
        let parents = Rows::from_scan(diamond_count, &edges(true));
        let mut levels = vec![0u32; diamond_count];
        scan(&mut |i, d| levels[i] = d.level);
        UnitTable {
            created,
            children,
            parents,
            unit_bytes,
            levels,
            root_bytes,
            roots: (0..root_count as u32).collect(),
        }
    }

    /// Number of units (one per diamond).
    pub fn len(&self) -> usize {
        self.unit_bytes.len()
    }

    /// True for a repository with no split diamond (only roots).
    pub fn is_empty(&self) -> bool {
        self.unit_bytes.is_empty()
    }

    /// The simplices whose patches unit `d` holds.
    pub fn simplices(&self, d: u32) -> &[u32] {
        self.created.row(d as usize)
    }

    /// Bytes of unit `d`'s patches.
    pub fn bytes(&self, d: u32) -> u64 {
        self.unit_bytes[d as usize]
    }

    /// Diamonds that list `d` as a parent.
    pub fn children(&self, d: u32) -> &[u32] {
        self.children.row(d as usize)
    }

    /// `d`'s parents.
    pub fn parents(&self, d: u32) -> &[u32] {
        self.parents.row(d as usize)
    }

    /// `d`'s LEB level.
    pub fn level(&self, d: u32) -> u32 {
        self.levels[d as usize]
    }

    /// The root simplices, whose patches are pinned.
    pub fn roots(&self) -> &[u32] {
        &self.roots
    }

    /// Bytes of the roots' patches.
    pub fn root_bytes(&self) -> u64 {
        self.root_bytes
    }
}
