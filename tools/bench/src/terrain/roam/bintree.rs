//! The triangulation ROAM edits: the bintree's triangles in a pool, neighbour links between
//! the current leaves, the classic recursive forced split, and diamond merges.
//!
//! Links (Duchaineau et al. §4; Turner's layout): each leaf knows the leaf across each of its
//! three edges — `base` across the hypotenuse, `left` across the leg apex–left, `right` across
//! apex–right — or `NONE` on the square's boundary. In a conforming triangulation the base
//! neighbour is on the same level (the two form a *diamond*, split together) or one level
//! coarser; splitting a triangle whose base neighbour is coarser first splits that neighbour,
//! recursively (the *forced split*), which is what keeps the mesh free of T-junctions. Only
//! leaves' links are kept current; an interior triangle's `base` still names its diamond
//! partner, which is all merging needs.
//!
//! Every triangle is counter-clockwise as (apex, left, right), so the triangle across an edge
//! runs it the other way: across a hypotenuse left and right swap, which fixes how children
//! link across a split diamond.

use crate::terrain::grid::{BinGrid, BinTri};

/// No node: the square's boundary, a leaf's children, a root's parent.
pub const NONE: u32 = u32::MAX;

#[derive(Clone, Debug)]
pub struct Node {
    pub tri: BinTri,
    pub parent: u32,
    /// The first of the two children (the other is `children + 1`), or `NONE` for a leaf.
    pub children: u32,
    pub base: u32,
    pub left: u32,
    pub right: u32,
    /// The split priority as ordered bits, valid in frame `key_frame` (`Roam` owns both).
    pub key: u32,
    pub key_frame: u32,
    /// Bumped whenever the node's queue membership changes (split, merged, freed, reused,
    /// mergeable or not), so queue entries pushed before are recognised as stale.
    pub gen: u32,
    /// Position in `Bintree::leaves`, or `NONE`.
    leaf_slot: u32,
    /// Position in `Bintree::mergeable` (on the diamond's canonical node), or `NONE`.
    diamond_slot: u32,
    /// Whether the triangle overlaps the real grid (it is drawn and counted).
    pub overlaps: bool,
    /// Whether both children are leaves: the interior triangles a merge can expose next,
    /// whose priorities a frame needs up front (kept here so finding them reads no other node).
    pub leaf_pair: bool,
}

/// What one split or merge changed, for the queues.
#[derive(Default)]
pub struct Changes {
    /// Nodes that became leaves (created children and merged parents).
    pub new_leaves: Vec<u32>,
    /// Canonical nodes of diamonds that became mergeable.
    pub new_mergeable: Vec<u32>,
    /// Coarser diamonds split only to keep the mesh conforming.
    pub forced: usize,
}

impl Changes {
    pub fn clear(&mut self) {
        self.new_leaves.clear();
        self.new_mergeable.clear();
        self.forced = 0;
    }
}

pub struct Bintree {
    pub nodes: Vec<Node>,
    /// First index of each free pair (children are allocated and freed in pairs).
    free: Vec<u32>,
    /// The current leaves, in no particular order.
    pub leaves: Vec<u32>,
    /// Canonical nodes of the mergeable diamonds: split diamonds whose four (or, on the
    /// square's boundary, two) children are all leaves.
    pub mergeable: Vec<u32>,
    /// Leaves that overlap the real grid.
    pub count: usize,
    /// Scratch: the nodes split by the current operation.
    split_now: Vec<u32>,
}

impl Bintree {
    /// The two roots, each other's base neighbour.
    pub fn new(grid: &BinGrid) -> Bintree {
        let mut tree = Bintree {
            nodes: Vec::new(),
            free: Vec::new(),
            leaves: Vec::new(),
            mergeable: Vec::new(),
            count: 0,
            split_now: Vec::new(),
        };
        let roots = grid.roots();
        let first = tree.alloc_pair();
        for (i, root) in roots.into_iter().enumerate() {
            let n = first + i as u32;
            tree.init(grid, n, root, NONE);
            tree.nodes[n as usize].base = first + 1 - i as u32;
            tree.add_leaf(n);
        }
        tree
    }

    pub fn node(&self, n: u32) -> &Node {
        &self.nodes[n as usize]
    }

    /// Whether pool slot `n` holds a triangle of the tree (not a freed one).
    pub fn alive(&self, n: u32) -> bool {
        n < 2 || self.node(n).parent != NONE
    }

    pub fn is_leaf(&self, n: u32) -> bool {
        self.node(n).children == NONE
    }

    /// The node of a diamond (an interior node and its base partner) that stands for it in
    /// the merge queue: the one with the smaller heap id, so the choice does not depend on
    /// the pool's history.
    pub fn canonical(&self, n: u32) -> u32 {
        let b = self.node(n).base;
        if b != NONE && self.node(b).tri.id < self.node(n).tri.id {
            b
        } else {
            n
        }
    }

    /// Whether `n`'s diamond is in the merge list.
    pub fn is_mergeable(&self, canonical: u32) -> bool {
        self.node(canonical).diamond_slot != NONE
    }

    /// Splits leaf `t` (its level must allow it), first force-splitting coarser base
    /// neighbours, and always its diamond partner with it.
    pub fn split(&mut self, grid: &BinGrid, t: u32, changes: &mut Changes) {
        debug_assert!(self.node(t).tri.can_split());
        self.split_now.clear();
        self.split_rec(grid, t, changes);
        // Diamonds: every split node's own diamond may now be mergeable (forced ones are not:
        // one of their children was split in turn), and its parent's no longer is.
        let split_now = std::mem::take(&mut self.split_now);
        for &n in &split_now {
            self.refresh_diamond(n, changes);
            let p = self.node(n).parent;
            if p != NONE {
                self.refresh_diamond(p, changes);
            }
        }
        self.split_now = split_now;
    }

    /// Merges the diamond whose canonical node is `c` (it must be mergeable): its children
    /// are freed and its one or two triangles become leaves, linked to the children's outer
    /// neighbours.
    pub fn merge(&mut self, c: u32, changes: &mut Changes) {
        debug_assert!(self.is_mergeable(c));
        self.remove_mergeable(c);
        let b = self.node(c).base;
        for x in [c, b] {
            if x == NONE {
                continue;
            }
            let k = self.node(x).children;
            let (outer_left, outer_right) = (self.node(k).base, self.node(k + 1).base);
            self.relink(outer_left, k, x);
            self.relink(outer_right, k + 1, x);
            let node = &mut self.nodes[x as usize];
            node.left = outer_left;
            node.right = outer_right;
            node.children = NONE;
            node.leaf_pair = false;
            self.remove_leaf(k);
            self.remove_leaf(k + 1);
            self.free_pair(k);
            self.add_leaf(x);
            changes.new_leaves.push(x);
        }
        for x in [c, b] {
            let p = if x == NONE { NONE } else { self.node(x).parent };
            if p != NONE {
                let k = self.node(p).children;
                self.nodes[p as usize].leaf_pair = self.is_leaf(k) && self.is_leaf(k + 1);
                self.refresh_diamond(p, changes);
            }
        }
    }

    fn split_rec(&mut self, grid: &BinGrid, t: u32, changes: &mut Changes) {
        if !self.is_leaf(t) {
            return;
        }
        let b = self.node(t).base;
        if b != NONE && self.node(b).base != t {
            // The base neighbour is one level coarser: it (and its own chain) must split
            // first, which relinks `t` to the half of it that shares t's hypotenuse.
            changes.forced += 1;
            self.split_rec(grid, b, changes);
        }
        self.split_one(grid, t, changes);
        let b = self.node(t).base;
        if b != NONE {
            if self.is_leaf(b) {
                // The partner splits too (its base is `t`, so nothing is forced) and links
                // its children across to t's.
                self.split_rec(grid, b, changes);
            } else {
                let (tk, bk) = (self.node(t).children, self.node(b).children);
                // t = (apex, l, r), b = (apex', r, l): t's left child holds l, as does b's
                // right child.
                self.nodes[tk as usize].right = bk + 1;
                self.nodes[(tk + 1) as usize].left = bk;
                self.nodes[bk as usize].right = tk + 1;
                self.nodes[(bk + 1) as usize].left = tk;
            }
        }
    }

    /// Replaces leaf `t` by its two children; links them to each other and to t's leg
    /// neighbours (the links across t's hypotenuse are set by the caller).
    fn split_one(&mut self, grid: &BinGrid, t: u32, changes: &mut Changes) {
        self.remove_leaf(t);
        let k = self.alloc_pair();
        let [tl, tr] = self.node(t).tri.children();
        let (left, right) = (self.node(t).left, self.node(t).right);
        self.init(grid, k, tl, t);
        self.init(grid, k + 1, tr, t);
        // Left child (m, apex, left): its base is t's left leg, its left leg (m–apex) is the
        // right child's right leg.
        self.nodes[k as usize].base = left;
        self.nodes[k as usize].left = k + 1;
        self.nodes[(k + 1) as usize].base = right;
        self.nodes[(k + 1) as usize].right = k;
        self.relink(left, t, k);
        self.relink(right, t, k + 1);
        let node = &mut self.nodes[t as usize];
        node.children = k;
        node.leaf_pair = true;
        node.gen = node.gen.wrapping_add(1);
        let p = node.parent;
        if p != NONE {
            self.nodes[p as usize].leaf_pair = false;
        }
        for n in [k, k + 1] {
            self.add_leaf(n);
            changes.new_leaves.push(n);
        }
        self.split_now.push(t);
    }

    /// Neighbour `n` (if any) now faces `new` where it faced `old`.
    fn relink(&mut self, n: u32, old: u32, new: u32) {
        if n == NONE {
            return;
        }
        let node = &mut self.nodes[n as usize];
        if node.base == old {
            node.base = new;
        } else if node.left == old {
            node.left = new;
        } else if node.right == old {
            node.right = new;
        } else {
            panic!("ROAM links: node {n} does not face {old}");
        }
    }

    /// Adds or removes the diamond of interior node `n` from the merge list as it now is.
    fn refresh_diamond(&mut self, n: u32, changes: &mut Changes) {
        if self.is_leaf(n) {
            return;
        }
        let c = self.canonical(n);
        let leaf_children = |x: u32| {
            x == NONE || {
                let k = self.node(x).children;
                k != NONE && self.is_leaf(k) && self.is_leaf(k + 1)
            }
        };
        let want = leaf_children(c) && leaf_children(self.node(c).base);
        match (want, self.is_mergeable(c)) {
            (true, false) => {
                self.nodes[c as usize].diamond_slot = self.mergeable.len() as u32;
                self.mergeable.push(c);
                self.bump(c);
                changes.new_mergeable.push(c);
            }
            (false, true) => self.remove_mergeable(c),
            _ => {}
        }
    }

    fn remove_mergeable(&mut self, c: u32) {
        let slot = self.node(c).diamond_slot;
        self.mergeable.swap_remove(slot as usize);
        if let Some(&moved) = self.mergeable.get(slot as usize) {
            self.nodes[moved as usize].diamond_slot = slot;
        }
        self.nodes[c as usize].diamond_slot = NONE;
        self.bump(c);
    }

    fn add_leaf(&mut self, n: u32) {
        let node = &mut self.nodes[n as usize];
        node.leaf_slot = self.leaves.len() as u32;
        node.gen = node.gen.wrapping_add(1);
        self.count += node.overlaps as usize;
        self.leaves.push(n);
    }

    fn remove_leaf(&mut self, n: u32) {
        let slot = self.node(n).leaf_slot;
        self.leaves.swap_remove(slot as usize);
        if let Some(&moved) = self.leaves.get(slot as usize) {
            self.nodes[moved as usize].leaf_slot = slot;
        }
        let node = &mut self.nodes[n as usize];
        node.leaf_slot = NONE;
        node.gen = node.gen.wrapping_add(1);
        self.count -= node.overlaps as usize;
    }

    fn bump(&mut self, n: u32) {
        let node = &mut self.nodes[n as usize];
        node.gen = node.gen.wrapping_add(1);
    }

    fn init(&mut self, grid: &BinGrid, n: u32, tri: BinTri, parent: u32) {
        let node = &mut self.nodes[n as usize];
        *node = Node {
            tri,
            parent,
            children: NONE,
            base: NONE,
            left: NONE,
            right: NONE,
            key: 0,
            key_frame: 0,
            gen: node.gen.wrapping_add(1),
            leaf_slot: NONE,
            diamond_slot: NONE,
            overlaps: grid.overlaps_grid(&tri),
            leaf_pair: false,
        };
    }

    fn alloc_pair(&mut self) -> u32 {
        if let Some(k) = self.free.pop() {
            return k;
        }
        let k = self.nodes.len() as u32;
        assert!(k < NONE - 2, "ROAM pool: 2^32 nodes");
        let blank = Node {
            tri: BinTri {
                apex: [0, 0],
                left: [0, 0],
                right: [0, 0],
                id: 0,
            },
            parent: NONE,
            children: NONE,
            base: NONE,
            left: NONE,
            right: NONE,
            key: 0,
            key_frame: 0,
            gen: 0,
            leaf_slot: NONE,
            diamond_slot: NONE,
            overlaps: false,
            leaf_pair: false,
        };
        self.nodes.push(blank.clone());
        self.nodes.push(blank);
        k
    }

    fn free_pair(&mut self, k: u32) {
        for n in [k, k + 1] {
            let node = &mut self.nodes[n as usize];
            node.gen = node.gen.wrapping_add(1);
            node.parent = NONE;
        }
        self.free.push(k);
    }
}
