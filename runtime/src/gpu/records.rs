//! The traversal's records on the GPU: one 88-byte `SlotRecord` per *record slot*, and the
//! slot allocator of the streaming renderer.
//!
//! The traversal, the compaction, the expansion and the draw address simplices by slot: a
//! selection-list entry holds a slot, and `locations` is indexed by slot. A slot record is
//! self-contained — the simplex's sphere and cone, its diamond's index (feedback, flag words)
//! and saturated sphere and error (ρ, duplicated into each of the diamond's simplices), and the
//! slot of its first child (children in two adjacent slots) — so the traversal never reads a
//! table indexed by simplex or by diamond.
//!
//! - Fully resident (`ResidentModel::upload`): slot = simplex id, one record per simplex, the
//!   children's slot is `first_child`; the `may_refine` words gate refinement.
//! - Streaming (`stream_pool.rs`, `streamer.rs`): a fixed number of slots sized from the budget.
//!   The roots are pinned in slots `0..root_count`. A unit R(D) (the simplices D's split
//!   creates, in child pairs) is given one *pair* of adjacent slots per child pair when it
//!   lands (`PairSlots`: fixed-size blocks, so no fragmentation), and its records are written
//!   there with no child link. The link *is* the flag: when `may_refine(D)` turns on, the
//!   slot of each of D's simplices gets the slot of its children's pair in R(D); when it turns
//!   off, `NO_INDEX`. A diamond may refine only when R(D) and its parents' units are resident
//!   (so every simplex of D is in a slot), and the links are written after the records they
//!   point to, so a frame never follows a link to a slot that is not its target's.
//!
//! The fields the draw, compaction and expansion passes read (`level`, `vertex_count`,
//! `strip_index_count`) sit where `TetRecord` has them, so those shaders read slot records
//! through their `TetRecord` declaration unchanged.

use bytemuck::{Pod, Zeroable};
use tessera_core::repository::format::{DiamondRecord, TetRecord, NO_INDEX};

/// One record slot; mirrors `SlotRecord` in `shaders/records.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SlotRecord {
    /// The simplex's bounding sphere (its subtree's: nested) and normal cone, as in the file.
    pub center: [f32; 3],
    pub radius: f32,
    pub cone_axis: [f32; 3],
    pub cone_cos: f32,
    /// The simplex's diamond (global index), `NO_INDEX` for a leaf.
    pub diamond: u32,
    /// The simplex's id in the repository (the CPU's; the GPU does not read it).
    pub simplex: u32,
    /// Slot of the first child (the second is the next slot); `NO_INDEX`: may not refine.
    pub children: u32,
    /// LEB level (`TetRecord::level`'s place: the draw's level colouring reads it).
    pub level: u32,
    /// The diamond's saturated sphere centre x, y.
    pub diamond_cx: f32,
    pub diamond_cy: f32,
    /// As in `TetRecord` (same places: the draw and compaction read them).
    pub patch_bytes: u32,
    pub vertex_count: u32,
    pub strip_index_count: u32,
    pub triangle_count: u32,
    /// The diamond's saturated sphere centre z, radius and saturated error.
    pub diamond_cz: f32,
    pub diamond_radius: f32,
    pub diamond_error: f32,
    pub pad: u32,
}

const _: () = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<SlotRecord>() == size_of::<TetRecord>());
    assert!(offset_of!(SlotRecord, level) == offset_of!(TetRecord, level));
    assert!(offset_of!(SlotRecord, vertex_count) == offset_of!(TetRecord, vertex_count));
    assert!(offset_of!(SlotRecord, strip_index_count) == offset_of!(TetRecord, strip_index_count));
    assert!(offset_of!(SlotRecord, triangle_count) == offset_of!(TetRecord, triangle_count));
};

/// Bytes of one slot record.
pub const SLOT_RECORD_BYTES: u64 = std::mem::size_of::<SlotRecord>() as u64;
/// Byte offset of `children` in a slot record (the link writes touch only that word).
pub const CHILDREN_OFFSET: u64 = std::mem::offset_of!(SlotRecord, children) as u64;

impl SlotRecord {
    /// The record of simplex `simplex` (`t`), whose diamond is `diamond` (`None` for a leaf),
    /// with children at slot `children` (`NO_INDEX`: none, or not allowed to refine).
    pub fn new(
        simplex: u32,
        t: &TetRecord,
        diamond: Option<&DiamondRecord>,
        children: u32,
    ) -> SlotRecord {
        let (c, r, e) = diamond.map_or(([0.0; 3], 0.0, 0.0), |d| (d.center, d.radius, d.error));
        SlotRecord {
            center: t.center,
            radius: t.radius,
            cone_axis: t.cone_axis,
            cone_cos: t.cone_cos,
            diamond: t.diamond,
            simplex,
            children,
            level: t.level,
            diamond_cx: c[0],
            diamond_cy: c[1],
            patch_bytes: t.patch_bytes,
            vertex_count: t.vertex_count,
            strip_index_count: t.strip_index_count,
            triangle_count: t.triangle_count,
            diamond_cz: c[2],
            diamond_radius: r,
            diamond_error: e,
            pad: 0,
        }
    }

    /// The fully resident records: slot = simplex, children at `first_child`.
    pub fn all(tets: &[TetRecord], diamonds: &[DiamondRecord]) -> Vec<SlotRecord> {
        tets.iter()
            .enumerate()
            .map(|(i, t)| {
                let d = (t.diamond != NO_INDEX).then(|| &diamonds[t.diamond as usize]);
                SlotRecord::new(i as u32, t, d, t.first_child)
            })
            .collect()
    }
}

/// The streaming renderer's record slots: `pinned` slots for the roots, then pairs of adjacent
/// slots handed out one at a time from a free list (every unit is made of child pairs, so a
/// fixed block size leaves no fragmentation).
#[derive(Clone, Debug)]
pub struct PairSlots {
    free: Vec<u32>,
    pairs: u32,
    first_pair_slot: u32,
}

impl PairSlots {
    /// Pairs of `slots` slots of which the first `pinned` are the roots' (nothing allocated).
    pub fn pairs_within(slots: u32, pinned: u32) -> u32 {
        slots.saturating_sub(pinned.next_multiple_of(2)) / 2
    }

    /// `slots` slots of which the first `pinned` are the roots'.
    pub fn new(slots: u32, pinned: u32) -> PairSlots {
        let first_pair_slot = pinned.next_multiple_of(2);
        let pairs = Self::pairs_within(slots, pinned);
        PairSlots {
            // Popped from the end: low slots first.
            free: (0..pairs).rev().collect(),
            pairs,
            first_pair_slot,
        }
    }

    /// The first slot of a free pair, or `None` when none is left.
    pub fn allocate(&mut self) -> Option<u32> {
        self.free.pop().map(|p| self.first_pair_slot + 2 * p)
    }

    /// `n` pairs at once, or none (nothing taken) when fewer are free.
    pub fn allocate_pairs(&mut self, n: usize) -> Option<Vec<u32>> {
        if self.free.len() < n {
            return None;
        }
        Some((0..n).map(|_| self.allocate().unwrap()).collect())
    }

    /// Returns the pair starting at `slot`.
    pub fn free(&mut self, slot: u32) {
        debug_assert!(
            slot >= self.first_pair_slot && (slot - self.first_pair_slot).is_multiple_of(2)
        );
        self.free.push((slot - self.first_pair_slot) / 2);
    }

    /// Grows to `slots` slots (never shrinks): the new pairs are free, handed out after the
    /// lower ones still free.
    pub fn grow(&mut self, slots: u32) {
        let pairs = slots.saturating_sub(self.first_pair_slot) / 2;
        if pairs > self.pairs {
            self.free.splice(0..0, (self.pairs..pairs).rev());
            self.pairs = pairs;
        }
    }

    /// Pairs free now.
    pub fn free_pairs(&self) -> usize {
        self.free.len()
    }

    /// Pairs in all.
    pub fn pairs(&self) -> u32 {
        self.pairs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_follow_the_pinned_slots_and_come_back() {
        let mut slots = PairSlots::new(12, 5);
        assert_eq!(slots.pairs(), 3);
        assert_eq!(slots.allocate_pairs(2), Some(vec![6, 8]));
        assert_eq!(slots.allocate_pairs(2), None);
        assert_eq!(slots.free_pairs(), 1);
        slots.free(6);
        assert_eq!(slots.allocate_pairs(2), Some(vec![6, 10]));
        assert_eq!(slots.allocate(), None);
    }

    #[test]
    fn grown_pairs_come_after_the_lower_free_ones() {
        let mut slots = PairSlots::new(10, 5); // pairs at 6 and 8
        assert_eq!(slots.allocate(), Some(6));
        slots.grow(9); // not a whole pair more: nothing
        assert_eq!((slots.pairs(), slots.free_pairs()), (2, 1));
        slots.grow(14);
        assert_eq!((slots.pairs(), slots.free_pairs()), (4, 3));
        assert_eq!(slots.allocate_pairs(3), Some(vec![8, 10, 12]));
        slots.grow(12); // never shrinks
        assert_eq!(slots.pairs(), 4);
    }
}
