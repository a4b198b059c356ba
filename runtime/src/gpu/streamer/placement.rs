//! Placing landed units in the page pool and record slots, and freeing them: `place_unit`
//! (step 2 of the streamer's module comment), `retire` (an evicted unit's space, freed once no
//! frame in flight draws it), `make_room` (a unit the pool has the bytes for but no range:
//! `stream/residency/space.rs`).

use tessera_core::repository::format::NO_INDEX;

use super::super::device::GpuContext;
use super::super::records::{SlotRecord, SLOT_RECORD_BYTES};
use super::super::renderer::Renderer;
use super::super::resident::{PatchLocation, PATCH_LOCATION_BYTES};
use super::super::stream_pool::{location_at, Placement};
use super::GpuStreamer;
use crate::stream::loader::UnitBytes;

impl GpuStreamer {
    /// Non-empty patches (selection-list entries) of a read unit.
    fn nonempty_patches(&self, bytes: &UnitBytes) -> u32 {
        let tets = self.repo.tets();
        bytes
            .patches
            .iter()
            .filter(|&&(t, _, _)| tets[t as usize].strip_index_count != 0)
            .count() as u32
    }

    /// Frees placed unit `u`'s pool range and slot pairs once no frame in flight draws it
    /// (the frame just submitted at the latest); nothing for a unit not placed.
    pub(super) fn retire(&mut self, u: u32) {
        if let Some(placed) = self.placed.remove(&u) {
            self.resident_patches -= self.residency.units().simplices(u).len();
            let pairs = self.pairs.remove(&u).unwrap_or_default();
            self.retired.push((self.submitted, placed, pairs));
        }
    }

    /// Places `bytes` in the pool and writes them, and each patch's slot record (no child
    /// link) and location into its slot (`slots[k]` for patch k); `None` when no page has room.
    pub(super) fn place(
        &mut self,
        ctx: &GpuContext,
        renderer: &mut Renderer,
        bytes: &UnitBytes,
        slots: &[u32],
    ) -> Option<Placement> {
        let tets = self.repo.tets();
        let diamonds = self.repo.diamonds();
        let nonempty = self.nonempty_patches(bytes);
        let placed = self.pool.allocate(bytes.bytes.len() as u64, nonempty)?;
        let model = renderer.model();
        let page = &model.pages[placed.page as usize].buffer;
        let mut data = bytes.bytes.clone();
        data.resize(data.len().next_multiple_of(4).max(4), 0);
        ctx.queue.write_buffer(page, placed.offset, &data);
        // Records and locations, one write per run of consecutive slots (a pair, or the
        // roots).
        let (mut records, mut locations) = (Vec::new(), Vec::new());
        let mut run_start = 0;
        for (k, &(t, at, _)) in bytes.patches.iter().enumerate() {
            let tet = &tets[t as usize];
            let diamond = (tet.diamond != NO_INDEX).then(|| &diamonds[tet.diamond as usize]);
            records.push(SlotRecord::new(t, tet, diamond, NO_INDEX));
            let mut location: PatchLocation =
                location_at(&self.repo, tet, placed.page, placed.offset + at as u64);
            if location.page == placed.page {
                location.first_entry = self.first_entries[placed.page as usize];
            }
            locations.push(location);
            let last = k + 1 == slots.len() || slots[k + 1] != slots[k] + 1;
            if last {
                let slot = slots[run_start] as u64;
                ctx.queue.write_buffer(
                    &model.records,
                    slot * SLOT_RECORD_BYTES,
                    bytemuck::cast_slice(&records),
                );
                ctx.queue.write_buffer(
                    &model.locations,
                    slot * PATCH_LOCATION_BYTES,
                    bytemuck::cast_slice(&locations),
                );
                records.clear();
                locations.clear();
                run_start = k + 1;
            }
        }
        for (&(t, _, _), &slot) in bytes.patches.iter().zip(slots) {
            renderer.set_slot_simplex(slot, t);
        }
        self.stats.uploaded_bytes += placed.bytes;
        self.resident_patches += bytes.patches.len();
        Some(placed)
    }

    /// Places unit `u`: a slot pair per child pair, then its bytes (`place`); `None` (nothing
    /// taken) when either pool has no room.
    pub(super) fn place_unit(
        &mut self,
        ctx: &GpuContext,
        renderer: &mut Renderer,
        u: u32,
        bytes: &UnitBytes,
    ) -> Option<Placement> {
        let n = bytes.patches.len();
        debug_assert!(
            n.is_multiple_of(2),
            "unit {u}: {n} simplices, not child pairs"
        );
        let (len, nonempty) = (bytes.bytes.len() as u64, self.nonempty_patches(bytes));
        if self.slots.free_pairs() < n / 2 || !self.pool.has_room(len, nonempty) {
            self.grow_for(ctx, renderer, n / 2, len, nonempty);
        }
        let pairs = self.slots.allocate_pairs(n / 2)?;
        let slots: Vec<u32> = (0..n).map(|k| pairs[k / 2] + (k % 2) as u32).collect();
        match self.place(ctx, renderer, bytes, &slots) {
            Some(placed) => {
                self.pairs.insert(u, pairs);
                Some(placed)
            }
            None => {
                for p in pairs {
                    self.slots.free(p);
                }
                None
            }
        }
    }

    /// Unit `u` (read as `bytes`) fits the budget but no page: evicts the units that free a
    /// range for it, when the residency allows them for `u`, and returns true (it waits for
    /// the room, retired once no frame in flight draws the victims); otherwise gives the
    /// load back (`Residency::withdraw`) and returns false.
    pub(super) fn make_room(&mut self, u: u32, bytes: &UnitBytes) -> bool {
        let patches = self.nonempty_patches(bytes);
        let placed: Vec<(u32, Placement)> = self.placed.iter().map(|(&v, &p)| (v, p)).collect();
        let residency = &self.residency;
        let victims = super::super::pool_space::units_to_evict(
            &self.pool,
            &placed,
            bytes.bytes.len() as u64,
            patches,
            &|v| residency.may_evict_for(v, u),
        );
        let victims = match victims {
            // The range exists: record slots ran out; any one allowed unit frees some.
            Some(v) if v.is_empty() => placed
                .iter()
                .map(|&(v, _)| v)
                .find(|&v| self.residency.may_evict_for(v, u))
                .into_iter()
                .collect(),
            Some(v) => v,
            None => Vec::new(),
        };
        if victims.is_empty() {
            self.residency.withdraw(u);
            return false;
        }
        for v in victims {
            self.residency.evict_for_space(v);
            self.retire(v);
        }
        true
    }
}
