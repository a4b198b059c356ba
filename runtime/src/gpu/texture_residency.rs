//! Which texture pages are in the pool's layers: the CPU side of the texture cache, no GPU.
//!
//! Each read-back of the fragment shader's request bits (`texture_cache.rs`) is one `plan`:
//! requested pages already resident are stamped with the read-back's number; the missing ones
//! are loaded into free layers, else into the layer least recently requested, never a pinned
//! one (each texture's last level, its one-page fallback) nor one requested by this read-back.
//! When the requests exceed the layers, coarser pages go first: a coarse page serves every
//! pixel of its area as a fallback, a fine one only its own.

use std::collections::HashMap;

/// What one plan changes: pages to load and the layer each goes to, pages evicted.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PagePlan {
    pub loads: Vec<(u32, u32)>,
    pub evicted: Vec<u32>,
    /// Requested pages that found no layer (every layer pinned or requested now).
    pub refused: u32,
}

/// The pages in the layers and when each was last requested.
#[derive(Clone, Debug)]
pub struct PageResidency {
    /// Per layer: its page (`None`: free), its last request's stamp, pinned.
    layers: Vec<Layer>,
    /// Global page → layer.
    resident: HashMap<u32, u32>,
    free: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct Layer {
    page: Option<u32>,
    stamp: u64,
    pinned: bool,
}

impl PageResidency {
    /// `capacity` layers, the first `pinned.len()` holding the pinned pages (loaded by the
    /// caller). Panics if the pinned pages do not fit.
    pub fn new(capacity: u32, pinned: &[u32]) -> PageResidency {
        assert!(pinned.len() as u32 <= capacity, "pinned pages fit the pool");
        let layers = (0..capacity)
            .map(|l| Layer {
                page: pinned.get(l as usize).copied(),
                stamp: 0,
                pinned: (l as usize) < pinned.len(),
            })
            .collect();
        PageResidency {
            layers,
            resident: pinned
                .iter()
                .enumerate()
                .map(|(l, &p)| (p, l as u32))
                .collect(),
            free: (pinned.len() as u32..capacity).rev().collect(),
        }
    }

    /// Layers in the pool.
    pub fn capacity(&self) -> u32 {
        self.layers.len() as u32
    }

    /// Pages resident (pinned included): never more than `capacity`.
    pub fn resident_count(&self) -> usize {
        self.resident.len()
    }

    /// The layer holding `page`.
    pub fn layer_of(&self, page: u32) -> Option<u32> {
        self.resident.get(&page).copied()
    }

    /// One read-back's requests (global pages, any order, no duplicates) numbered `stamp`
    /// (increasing): what to load where and what leaves. `level_of` gives a page's level.
    pub fn plan(
        &mut self,
        requested: &[u32],
        stamp: u64,
        level_of: impl Fn(u32) -> u32,
    ) -> PagePlan {
        let mut missing = Vec::new();
        for &page in requested {
            match self.resident.get(&page) {
                Some(&layer) => self.layers[layer as usize].stamp = stamp,
                None => missing.push(page),
            }
        }
        // Coarser first, then by page: deterministic.
        missing.sort_unstable_by_key(|&p| (std::cmp::Reverse(level_of(p)), p));
        let mut plan = PagePlan::default();
        // Eviction candidates, least recently requested first (stamps below this one's).
        let mut victims: Vec<u32> = (0..self.capacity())
            .filter(|&l| {
                let layer = &self.layers[l as usize];
                layer.page.is_some() && !layer.pinned && layer.stamp < stamp
            })
            .collect();
        victims.sort_unstable_by_key(|&l| (std::cmp::Reverse(self.layers[l as usize].stamp), l));
        for page in missing {
            let layer = match self.free.pop() {
                Some(layer) => layer,
                None => match victims.pop() {
                    Some(layer) => {
                        let old = self.layers[layer as usize]
                            .page
                            .take()
                            .expect("a victim holds a page");
                        self.resident.remove(&old);
                        plan.evicted.push(old);
                        layer
                    }
                    None => {
                        plan.refused += 1;
                        continue;
                    }
                },
            };
            self.layers[layer as usize] = Layer {
                page: Some(page),
                stamp,
                pinned: false,
            };
            self.resident.insert(page, layer);
            plan.loads.push((page, layer));
        }
        plan
    }

    /// Forgets a load that failed (its layer becomes free again).
    pub fn unload(&mut self, page: u32) {
        if let Some(layer) = self.resident.remove(&page) {
            self.layers[layer as usize].page = None;
            self.free.push(layer);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pages 100.. are level 1 (coarser), the rest level 0.
    fn level(p: u32) -> u32 {
        u32::from(p >= 100)
    }

    #[test]
    fn loads_fill_free_layers_then_evict_the_least_recently_requested() {
        let mut r = PageResidency::new(4, &[999]);
        let plan = r.plan(&[1, 2, 3], 1, level);
        assert_eq!(plan.loads.len(), 3);
        assert!(plan.evicted.is_empty());
        assert_eq!(r.resident_count(), 4);
        // 2 is requested again at 2; at 3, page 4 evicts 1 (stamp 1), never 2 or 3 which are
        // requested now, never the pinned page.
        assert!(r.plan(&[2], 2, level).loads.is_empty());
        let plan = r.plan(&[4, 3], 3, level);
        assert_eq!(plan.evicted, vec![1]);
        assert_eq!(plan.loads, vec![(4, r.layer_of(4).unwrap())]);
        assert!(r.layer_of(999).is_some());
        assert_eq!(r.resident_count(), 4);
    }

    #[test]
    fn requests_over_capacity_keep_the_coarser_pages_and_never_overflow() {
        let mut r = PageResidency::new(3, &[999]);
        let plan = r.plan(&[1, 2, 100, 101], 1, level);
        let loaded: Vec<u32> = plan.loads.iter().map(|&(p, _)| p).collect();
        assert_eq!(loaded, vec![100, 101]);
        assert_eq!(plan.refused, 2);
        assert_eq!(r.resident_count(), 3);
        // Layers distinct, within capacity.
        let mut layers: Vec<u32> = [100, 101, 999]
            .iter()
            .map(|&p| r.layer_of(p).unwrap())
            .collect();
        layers.sort_unstable();
        layers.dedup();
        assert_eq!(layers.len(), 3);
        assert!(layers.iter().all(|&l| l < 3));
        r.unload(100);
        assert_eq!(r.plan(&[1], 2, level).loads.len(), 1);
    }
}
