//! When the GPU pool has the bytes a loaded unit needs but not in one range (fragmentation),
//! the residency's byte budget says the unit fits while no page can take it: left alone it
//! would wait for good with the camera still, and the stream would never settle (seen in the
//! soak test under load: 116 KB free in ranges of at most 24 KB, a 29 KB unit waiting). The
//! streamer then either evicts units that free a range (`evict_for_space`: only units whose
//! eviction key is below the waiting unit's priority, with no live child) or gives the load
//! back (`withdraw`: absent again, and not issued again until an eviction frees room).
//!
//! Why this ends: a unit only ever evicts units of strictly lower priority for space, and a
//! withdrawn unit comes back only after an eviction; with the camera still, priorities are
//! fixed, so the chain of space evictions descends in priority and stops, and what is left
//! waiting is withdrawn: nothing stays loading, the stream settles (with the withdrawn units
//! absent, as under budget pressure).

use super::{Residency, UnitState};

impl Residency {
    /// Whether resident unit `v` may be evicted to make contiguous room for loading unit `u`:
    /// `v` has no live child and its eviction key is below `u`'s priority.
    pub fn may_evict_for(&self, v: u32, u: u32) -> bool {
        self.evictable(v) && self.eviction_key(v).0 < self.priority[u as usize]
    }

    /// Evicts resident unit `v` for contiguous room (`may_evict_for` must hold): as a planned
    /// eviction, its diamond may no longer refine and its memory is the caller's to retire.
    pub fn evict_for_space(&mut self, v: u32) {
        assert!(self.evictable(v), "unit {v} is not evictable");
        self.evict(v);
        self.stats.space_evictions += 1;
    }

    /// Gives back loading unit `u`, which no page can take and no eviction allowed for it
    /// would make room for: absent again, its bytes no longer counted, and not issued again
    /// until an eviction frees room.
    pub fn withdraw(&mut self, u: u32) {
        let ui = u as usize;
        assert_eq!(
            self.state[ui],
            UnitState::Loading,
            "unit {u} withdrawn without being issued"
        );
        self.state[ui] = UnitState::Absent;
        self.stats.loading_units -= 1;
        for &p in self.units.parents(u) {
            self.live_children[p as usize] -= 1;
        }
        self.stats.resident_bytes -= self.units.bytes(u);
        self.stats.resident_records -= self.units.simplices(u).len() as u64;
        if !self.deferred[ui] {
            self.deferred[ui] = true;
            self.deferred_units.push(u);
        }
        self.stats.withdrawn_loads += 1;
    }
}
