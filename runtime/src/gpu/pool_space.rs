//! Making contiguous room in the page pool (`stream_pool.rs`) for a unit that fits the pool's
//! free bytes but no single free range: the cheapest run of adjacent free ranges and placed
//! units, in one page, that spans the unit and whose units may all be evicted
//! (`Residency::may_evict_for`; why this is needed and why it ends: `stream/residency/space.rs`).

use super::stream_pool::{Placement, PoolAllocator};

/// One stretch of a page: free, or a placed unit.
#[derive(Clone, Copy, Debug)]
struct Stretch {
    start: u64,
    len: u64,
    /// The unit placed there (`None`: free), with its non-empty patches.
    unit: Option<(u32, u32)>,
}

/// The units to evict so that a unit of `bytes` bytes and `patches` non-empty patches can be
/// placed: the fewest bytes evicted over every page, among runs of adjacent stretches (free
/// ranges and the units of `placed`) that span `bytes` with only units `allowed` accepts and
/// leave the page's patch count within its capacity. Ranges neither free nor in `placed`
/// (the roots, retired placements) end a run. `Some(vec![])` when a free range already spans
/// it (the placement failed for another reason: record slots); `None` when no run can.
pub fn units_to_evict(
    pool: &PoolAllocator,
    placed: &[(u32, Placement)],
    bytes: u64,
    patches: u32,
    allowed: &dyn Fn(u32) -> bool,
) -> Option<Vec<u32>> {
    let bytes = bytes.next_multiple_of(8).max(8);
    let mut best: Option<(u64, Vec<u32>)> = None;
    for page in 0..pool.page_count() {
        let mut stretches: Vec<Stretch> = pool
            .free_ranges(page)
            .iter()
            .map(|&(start, len)| Stretch {
                start,
                len,
                unit: None,
            })
            .chain(
                placed
                    .iter()
                    .filter(|(_, p)| p.page as usize == page)
                    .map(|&(u, p)| Stretch {
                        start: p.offset,
                        len: p.bytes,
                        unit: Some((u, p.patches)),
                    }),
            )
            .collect();
        stretches.sort_by_key(|s| s.start);
        let page_patches = pool.page_patches(page);
        for first in 0..stretches.len() {
            let (mut span, mut evicted, mut freed_patches) = (0u64, 0u64, 0u32);
            let mut units = Vec::new();
            for (k, s) in stretches[first..].iter().enumerate() {
                let adjacent = k == 0 || {
                    let previous = &stretches[first + k - 1];
                    previous.start + previous.len == s.start
                };
                if !adjacent {
                    break;
                }
                if let Some((u, p)) = s.unit {
                    if !allowed(u) {
                        break;
                    }
                    units.push(u);
                    evicted += s.len;
                    freed_patches += p;
                }
                span += s.len;
                if span >= bytes {
                    let fits = page_patches - freed_patches + patches <= pool.patch_capacity();
                    if fits && best.as_ref().is_none_or(|(cost, _)| evicted < *cost) {
                        best = Some((evicted, units.clone()));
                    }
                    break;
                }
            }
        }
    }
    best.map(|(_, units)| units)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool_with(placements: &[(u64, u64)]) -> (PoolAllocator, Vec<(u32, Placement)>) {
        let mut pool = PoolAllocator::new(1, 100 * 8, 1000);
        let mut placed = Vec::new();
        // Fill the page, then free what is not listed.
        let mut all = Vec::new();
        for k in 0..100 {
            all.push(pool.allocate(8, 1).unwrap());
            assert_eq!(all[k].offset, 8 * k as u64);
        }
        for (k, p) in all.into_iter().enumerate() {
            let at = 8 * k as u64;
            match placements
                .iter()
                .position(|&(start, len)| start <= at && at < start + len)
            {
                Some(_) => placed.push((k as u32, p)),
                None => pool.free(p),
            }
        }
        (pool, placed)
    }

    #[test]
    fn the_cheapest_window_of_evictable_units_is_chosen() {
        // Units (8 bytes each) at 0..80 and 160..800; free 80..160: 80 bytes free in one run.
        let (pool, placed) = pool_with(&[(0, 80), (160, 640)]);
        // 80 bytes fit as they are: nothing to evict.
        assert_eq!(
            units_to_evict(&pool, &placed, 80, 1, &|_| true),
            Some(vec![])
        );
        // 96 bytes: the free run plus two units at one of its ends.
        let v = units_to_evict(&pool, &placed, 96, 1, &|_| true).unwrap();
        assert_eq!(v.len(), 2, "{v:?}");
        // Only units 20.. may go: the window grows to the right of the free run.
        let v = units_to_evict(&pool, &placed, 96, 1, &|u| u >= 20).unwrap();
        assert_eq!(v, vec![20, 21]);
        // Nothing may go: no room.
        assert_eq!(units_to_evict(&pool, &placed, 96, 1, &|_| false), None);
    }

    #[test]
    fn unlisted_ranges_end_a_window() {
        // Units 0..10 placed but not listed (the roots, say): they block.
        let (pool, mut placed) = pool_with(&[(0, 800)]);
        placed.retain(|(u, _)| *u >= 10);
        let v = units_to_evict(&pool, &placed, 800, 1, &|_| true);
        assert_eq!(v, None);
        let v = units_to_evict(&pool, &placed, 720, 1, &|_| true).unwrap();
        assert_eq!(v.len(), 90);
    }
}
