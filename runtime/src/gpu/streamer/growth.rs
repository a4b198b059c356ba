//! Growing the pools: the streamer starts with one page and a few record slots
//! (`GpuStreamer::new`) and allocates more only when a landing unit finds no room, up to the
//! layout the budget allows (`stream_budget::fixed_bytes`). So what the GPU holds follows what
//! the views have needed, not the budget: the roots of a 100 M-triangle model take the same
//! bytes as those of a small one, whatever `--gpu-budget` says. Pages are added one at a time
//! (`stream_pool::GROWTH_PAGE_BYTES` at most), record slots double; neither ever shrinks (the
//! residency evicts within what is allocated once the layout is reached).

use super::super::device::GpuContext;
use super::super::renderer::Renderer;
use super::super::resident::ResidentModel;
use super::super::stream_pool::grow_model;
use super::GpuStreamer;

impl GpuStreamer {
    /// Grows the pools so that a unit of `pairs` slot pairs and `bytes` bytes holding
    /// `patches` non-empty patches can be placed: more record slots when too few pairs are
    /// free, one more page when no page has room; `false` when neither could grow (the
    /// layout is reached: the caller waits for or makes room as before).
    pub(super) fn grow_for(
        &mut self,
        ctx: &GpuContext,
        renderer: &mut Renderer,
        pairs: usize,
        bytes: u64,
        patches: u32,
    ) -> bool {
        let model = renderer.model();
        let (mut pages, mut slots) = (model.pages.len(), model.slot_count);
        if self.slots.free_pairs() < pairs && slots < self.sizes.slots {
            let needed = slots as u64 + 2 * (pairs - self.slots.free_pairs()) as u64;
            slots = (2 * slots as u64).max(needed).min(self.sizes.slots as u64) as u32;
        }
        if !self.pool.has_room(bytes, patches) && pages < self.sizes.layout.pages {
            pages += 1;
        }
        if (pages, slots) == (model.pages.len(), model.slot_count) {
            return false;
        }
        let layout = self.sizes.layout;
        grow_model(ctx, renderer.model_mut(), &layout, pages, slots);
        renderer.rebind_model(ctx);
        while self.pool.page_count() < pages {
            self.pool.add_page();
            self.first_entries
                .push(renderer.model().lists[self.first_entries.len()].first_entry);
        }
        self.slots.grow(slots);
        self.count_allocations(renderer.model());
        self.stats.pool_growths += 1;
        true
    }

    /// Sets the statistics' allocation figures from what `model` holds now.
    pub(super) fn count_allocations(&mut self, model: &ResidentModel) {
        let (pages, slots) = (model.pages.len(), model.slot_count);
        let (fixed, total) = self.sizes.allocated(pages, slots);
        self.stats.gpu_bytes = total;
        self.stats.fixed_bytes = fixed;
        self.stats.record_slots = slots;
        self.stats.record_bytes = slots as u64 * super::super::stream_budget::SLOT_BYTES;
        self.stats.pool_bytes = pages as u64 * self.sizes.layout.page_bytes;
        self.stats.pool_pages = pages as u32;
    }
}
