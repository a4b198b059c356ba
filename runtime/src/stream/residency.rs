//! Which units are resident, which diamonds may refine, what to load next and what to evict.
//!
//! The rule that keeps every frame's cut valid (shared/DESIGN.md, "Residency without losing
//! the stateless rule"): `may_refine(D)` ⇔ R(D) is resident ∧ every parent of D may refine.
//! The traversal uses ρ'(D) = may_refine(D) ? ρ(D) : 0 in the unchanged rule, so the refined
//! set {ρ' > τ} is closed upwards (ρ(P) ≥ ρ(D) for every parent P) and every drawn simplex was
//! created by a diamond that may refine, i.e. is resident: each frame draws a conforming cut,
//! crack-free at every moment of streaming, only coarser where data is missing.
//!
//! Each frame the traversal reports the diamonds it refined (used, with their ρ/τ) and the
//! ones it wanted to refine but could not (requests, with their ρ/τ), both from visible
//! simplices only. A request for D asks for R(A) of every ancestor A of D that is not
//! resident, with the request's priority; `plan` issues loads by priority (coarsest first on
//! ties) within a per-frame byte budget, and makes room by evicting units that
//! - have no resident (or loading) child unit, so no refined descendant loses its parent —
//!   counting children evicted for the same load first: a chain of units goes leaf first,
//!   so a load larger than every childless unit still finds its room — and
//! - were not used in the latest frame, least recently used first, or were used with a lower
//!   priority than the request: a unit is never evicted for a request of lower or equal
//!   priority, so a paused camera settles and stops loading (no thrash).
//!
//! A unit that fails to load (a damaged patch) is broken for good: it never becomes resident,
//! so the diamond whose split creates the damaged patch never refines. A unit too large for
//! the GPU to hold (`refuse`) is treated the same way without being read.
//!
//! Two budgets: bytes (the units' patches) and records (one per simplex of a unit: the GPU's
//! record slots, `gpu::records`); a load must fit both, and eviction makes room in both. The
//! CPU streamer leaves records unlimited.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::units::UnitTable;

mod invariants;

/// Where a unit is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnitState {
    /// Not in memory.
    Absent,
    /// Issued to the loader; its bytes count against the budget.
    Loading,
    /// In memory: its diamond may refine once its parents may.
    Resident,
    /// Failed to load (a damaged patch): never loaded again.
    Broken,
    /// Larger than the GPU can hold as one unit (a page of the pool, `refuse`): never loaded;
    /// its diamond never refines, so the cut stays coarser there.
    TooLarge,
}

/// Totals since the residency was made.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResidencyStats {
    /// Bytes of resident and loading units plus the pinned roots.
    pub resident_bytes: u64,
    /// Records (simplices) of resident and loading units plus the pinned roots.
    pub resident_records: u64,
    /// The most `resident_bytes` ever reached.
    pub peak_resident_bytes: u64,
    /// Units resident now.
    pub resident_units: usize,
    /// Units issued to the loader and not yet completed.
    pub loading_units: usize,
    /// Bytes of every load issued.
    pub loaded_bytes: u64,
    /// Loads issued.
    pub loads: u64,
    /// Units evicted.
    pub evictions: u64,
    /// Units broken by a failed load.
    pub broken_units: usize,
    /// Units refused as larger than the GPU can hold (`refuse`).
    pub too_large_units: usize,
    /// Units wanted in the latest frame but neither resident nor loading.
    pub pending_units: usize,
    /// Units evicted because the GPU pool had the bytes but not in one range
    /// (`evict_for_space`), and loads given back because no such eviction could help
    /// (`withdraw`).
    pub space_evictions: u64,
    pub withdrawn_loads: u64,
}

/// What `plan` decided: load these units (in this order), after evicting those.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// Units evicted now: their diamonds may no longer refine from the next frame's flags on;
    /// their memory may be reused once no frame in flight can draw them.
    pub evict: Vec<u32>,
    /// Units to read, highest priority first; their bytes are reserved.
    pub load: Vec<u32>,
}

/// The residency of one repository's units under a byte budget.
#[derive(Clone, Debug)]
pub struct Residency {
    units: UnitTable,
    state: Vec<UnitState>,
    may_refine: Vec<bool>,
    /// Per unit: child units that are resident or loading (a unit with any is not evictable).
    live_children: Vec<u32>,
    /// Per unit: live children taken as victims by the choice in progress (0 outside
    /// `choose_victims`).
    taken_children: Vec<u32>,
    /// Per unit: the frame it was last used (itself or a descendant refined or wanted by a
    /// visible simplex), 0 = never.
    last_used: Vec<u64>,
    /// Per unit: the frame `feedback` last reached it, and the priority then (ρ/τ of the
    /// highest-priority diamond at or below it).
    touched: Vec<u64>,
    priority: Vec<f32>,
    /// Units wanted in the latest frame (deduplicated), not resident nor loading.
    candidates: Vec<u32>,
    /// The resident units, in no order, and each one's position there.
    resident: Vec<u32>,
    resident_at: Vec<u32>,
    budget_bytes: u64,
    budget_records: u64,
    frame: u64,
    flags_changed: bool,
    /// Diamonds whose flag changed since `take_changed_flags` (duplicates allowed), when
    /// `track_changes`.
    changed: Vec<u32>,
    track_changes: bool,
    /// Per unit: a load given back for want of contiguous pool space (`withdraw`), not issued
    /// again until an eviction frees some; and the units so marked.
    deferred: Vec<bool>,
    deferred_units: Vec<u32>,
    stats: ResidencyStats,
}

impl Residency {
    /// Every unit absent; the roots' patches pinned. Fails when the roots alone exceed the
    /// budget (the message gives both sizes). Records unlimited.
    pub fn new(units: UnitTable, budget_bytes: u64) -> Result<Residency, String> {
        Residency::with_records(units, budget_bytes, u64::MAX)
    }

    /// As `new`, with at most `budget_records` records (simplices) resident or loading, the
    /// roots' included.
    pub fn with_records(
        units: UnitTable,
        budget_bytes: u64,
        budget_records: u64,
    ) -> Result<Residency, String> {
        let root_records = units.roots().len() as u64;
        if root_records > budget_records {
            return Err(format!(
                "the roots take {root_records} records, more than the budget of \
                 {budget_records} records"
            ));
        }
        if units.root_bytes() > budget_bytes {
            return Err(format!(
                "the roots' patches take {} bytes, more than the budget of {budget_bytes} bytes",
                units.root_bytes()
            ));
        }
        let n = units.len();
        let stats = ResidencyStats {
            resident_bytes: units.root_bytes(),
            resident_records: root_records,
            peak_resident_bytes: units.root_bytes(),
            ..Default::default()
        };
        Ok(Residency {
            units,
            state: vec![UnitState::Absent; n],
            may_refine: vec![false; n],
            live_children: vec![0; n],
            taken_children: vec![0; n],
            last_used: vec![0; n],
            touched: vec![0; n],
            priority: vec![0.0; n],
            candidates: Vec::new(),
            resident: Vec::new(),
            resident_at: vec![0; n],
            budget_bytes,
            budget_records,
            frame: 0,
            flags_changed: true,
            changed: Vec::new(),
            track_changes: false,
            deferred: vec![false; n],
            deferred_units: Vec::new(),
            stats,
        })
    }

    /// The unit table.
    pub fn units(&self) -> &UnitTable {
        &self.units
    }

    /// Per diamond: may it refine in the next frame.
    pub fn may_refine(&self) -> &[bool] {
        &self.may_refine
    }

    /// The flags as bit words (bit d % 32 of word d / 32), as the GPU reads them.
    pub fn may_refine_words(&self) -> Vec<u32> {
        let mut words = vec![0u32; self.may_refine.len().div_ceil(32).max(1)];
        for (d, _) in self.may_refine.iter().enumerate().filter(|(_, &m)| m) {
            words[d / 32] |= 1 << (d % 32);
        }
        words
    }

    /// True once since the flags last changed (the caller uploads them then).
    pub fn take_flags_changed(&mut self) -> bool {
        std::mem::take(&mut self.flags_changed)
    }

    /// From now on, record which diamonds' flags change (`take_changed_flags`).
    pub fn track_changed_flags(&mut self) {
        self.track_changes = true;
    }

    /// The diamonds whose flag changed since the last call (with `track_changed_flags`), each
    /// once, ascending (the caller writes their current flags).
    pub fn take_changed_flags(&mut self) -> Vec<u32> {
        let mut changed = std::mem::take(&mut self.changed);
        changed.sort_unstable();
        changed.dedup();
        changed
    }

    /// The record budget.
    pub fn budget_records(&self) -> u64 {
        self.budget_records
    }

    /// Where unit `d` is.
    pub fn state(&self, d: u32) -> UnitState {
        self.state[d as usize]
    }

    /// The byte budget.
    pub fn budget_bytes(&self) -> u64 {
        self.budget_bytes
    }

    /// Totals so far.
    pub fn stats(&self) -> ResidencyStats {
        self.stats
    }

    /// Takes one frame's feedback: the diamonds the traversal refined and those it wanted to
    /// refine but could not, each with its ρ/τ (duplicates allowed). Every ancestor of either
    /// counts as used in this frame with the highest priority among the diamonds below it
    /// (ρ only grows upwards, so that is a lower bound of its own); every absent one becomes
    /// a candidate load with that priority. Cost: the distinct ancestors reached, about the
    /// refined set.
    pub fn feedback(&mut self, refined: &[(u32, f32)], wanted: &[(u32, f32)]) {
        self.frame += 1;
        let frame = self.frame;
        let mut seeds: Vec<(u32, f32)> = refined.iter().chain(wanted).copied().collect();
        // Highest priority first: the first visit of a unit carries its highest priority.
        seeds.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        self.candidates.clear();
        let mut stack: Vec<u32> = Vec::new();
        for (d, priority) in seeds {
            stack.push(d);
            while let Some(a) = stack.pop() {
                let ai = a as usize;
                if self.touched[ai] == frame {
                    continue;
                }
                self.touched[ai] = frame;
                self.priority[ai] = priority;
                match self.state[ai] {
                    UnitState::Resident | UnitState::Loading => self.last_used[ai] = frame,
                    UnitState::Absent => self.candidates.push(a),
                    UnitState::Broken | UnitState::TooLarge => {}
                }
                stack.extend_from_slice(self.units.parents(a));
            }
        }
        self.stats.pending_units = self.candidates.len();
    }

    /// The eviction key of resident unit `d` this frame: used units keep their priority,
    /// unused ones rank below every request (`-1`), least recently used first.
    fn eviction_key(&self, d: u32) -> (f32, u64) {
        let d = d as usize;
        let priority = if self.last_used[d] == self.frame {
            self.priority[d]
        } else {
            -1.0
        };
        (priority, self.last_used[d])
    }

    /// Decides this frame's loads (at most `upload_bytes` of them, but always at least one
    /// candidate that fits, so a unit larger than the per-frame allowance still loads) and the
    /// evictions that make room for them. Issued loads are `Loading` until `complete`.
    pub fn plan(&mut self, upload_bytes: u64) -> Plan {
        let mut plan = Plan::default();
        if self.candidates.is_empty() {
            return plan;
        }
        let frame = self.frame;
        let mut order = std::mem::take(&mut self.candidates);
        order.sort_by(|&a, &b| {
            let (pa, pb) = (self.priority[a as usize], self.priority[b as usize]);
            pb.total_cmp(&pa)
                .then(self.units.level(a).cmp(&self.units.level(b)))
                .then(a.cmp(&b))
        });
        // Eviction candidates, best victim last (`choose_victims` adds the parents a load's
        // victims leave without live children).
        // Only resident units can be victims: scan those (bounded by the budget), not the
        // model's every unit, on the render thread's per-frame path.
        let mut victims: Vec<u32> = self
            .resident
            .iter()
            .copied()
            .filter(|&d| self.evictable(d))
            .collect();
        victims.sort_by_key(|&d| Reverse(self.victim_order(d)));
        let mut issued_bytes = 0u64;
        for &u in &order {
            if self.state[u as usize] != UnitState::Absent
                || self.touched[u as usize] != frame
                || self.deferred[u as usize]
            {
                continue;
            }
            let bytes = self.units.bytes(u);
            let records = self.units.simplices(u).len() as u64;
            if !plan.load.is_empty() && issued_bytes + bytes > upload_bytes {
                break;
            }
            let priority = self.priority[u as usize];
            // Make room, never for a request that does not outrank the victim, and only when
            // the room can be made: evicting without loading would only start a cycle.
            let over = (self.stats.resident_bytes + bytes).saturating_sub(self.budget_bytes);
            let over_records =
                (self.stats.resident_records + records).saturating_sub(self.budget_records);
            if over > 0 || over_records > 0 {
                let Some((chosen, freed_parents)) =
                    self.choose_victims(&victims, priority, over, over_records)
                else {
                    continue; // does not fit: a smaller candidate may
                };
                // Children before parents: the listed victims were evictable already, each
                // freed parent follows the children that freed it (choice order).
                let listed: Vec<u32> = chosen.iter().map(|&k| victims[k]).collect();
                // `chosen` holds descending positions: removing them in order keeps the rest.
                for &k in &chosen {
                    victims.remove(k);
                }
                let first = plan.evict.len();
                for v in listed.into_iter().chain(freed_parents) {
                    self.evict(v);
                    plan.evict.push(v);
                }
                // The parents these evictions left without live children are victims for the
                // next candidates (`evictable` is rechecked: one may become a parent of a
                // load).
                let mut childless: Vec<u32> = plan.evict[first..]
                    .iter()
                    .flat_map(|&v| self.units.parents(v).iter().copied())
                    .filter(|&p| self.evictable(p))
                    .collect();
                childless.sort_unstable();
                childless.dedup();
                for p in childless {
                    let key = self.victim_order(p);
                    let at = victims.partition_point(|&x| self.victim_order(x) > key);
                    victims.insert(at, p);
                }
            }
            self.issue(u, bytes);
            plan.load.push(u);
            issued_bytes += bytes;
            // A parent of a loading unit is no longer evictable: `evictable` is rechecked.
        }
        self.stats.pending_units = order
            .iter()
            .filter(|&&u| self.state[u as usize] == UnitState::Absent)
            .count();
        self.candidates = order;
        plan
    }

    /// `eviction_key(d)` as one totally ordered value, `d` last on ties: the smallest is the
    /// best victim.
    fn victim_order(&self, d: u32) -> (i32, u64, u32) {
        let (priority, last_used) = self.eviction_key(d);
        // `f32::total_cmp`'s order as an integer.
        let bits = priority.to_bits() as i32;
        (bits ^ ((((bits >> 31) as u32) >> 1) as i32), last_used, d)
    }

    /// The victims that make room for a load of priority `priority` that is `over` bytes and
    /// `over_records` records over the budget, or `None` when no choice can (then nothing may
    /// be evicted). Victims are units whose eviction key is below `priority`, taken best
    /// first: the evictable units of `victims` (best last), and each resident unit once
    /// every one of its live children is taken (children first, so no refined descendant
    /// loses its parent; a unit with a loading child is never taken). Without the second
    /// kind, a load larger than every childless unit of lower priority would wait for good
    /// whenever evicting those and the parents they leave childless makes its room. Returns
    /// positions in `victims` (descending) and the parents taken, in the order taken.
    fn choose_victims(
        &mut self,
        victims: &[u32],
        priority: f32,
        over: u64,
        over_records: u64,
    ) -> Option<(Vec<usize>, Vec<u32>)> {
        let (mut freed, mut freed_records) = (0u64, 0u64);
        let mut chosen = Vec::new();
        let mut parents = Vec::new();
        // Parents whose live children are all taken, best first.
        let mut ready: BinaryHeap<Reverse<(i32, u64, u32)>> = BinaryHeap::new();
        // Units whose `taken_children` count was raised (reset before returning).
        let mut counted: Vec<u32> = Vec::new();
        let mut next = victims.len();
        while freed < over || freed_records < over_records {
            while next > 0 && !self.evictable(victims[next - 1]) {
                next -= 1; // became a parent of something issued this frame
            }
            let listed = (next > 0).then(|| self.victim_order(victims[next - 1]));
            let parent = ready.peek().map(|r| r.0);
            let (v, from_list) = match (listed, parent) {
                (Some(l), Some(p)) if p < l => (p.2, false),
                (Some(l), _) => (l.2, true),
                (None, Some(p)) => (p.2, false),
                (None, None) => break,
            };
            if self.eviction_key(v).0 >= priority {
                break;
            }
            freed += self.units.bytes(v);
            freed_records += self.units.simplices(v).len() as u64;
            if from_list {
                next -= 1;
                chosen.push(next);
            } else {
                ready.pop();
                parents.push(v);
            }
            for i in 0..self.units.parents(v).len() {
                let p = self.units.parents(v)[i] as usize;
                if self.taken_children[p] == 0 {
                    counted.push(p as u32);
                }
                self.taken_children[p] += 1;
                if self.taken_children[p] == self.live_children[p]
                    && self.state[p] == UnitState::Resident
                {
                    ready.push(Reverse(self.victim_order(p as u32)));
                }
            }
        }
        for p in counted {
            self.taken_children[p as usize] = 0;
        }
        (freed >= over && freed_records >= over_records).then_some((chosen, parents))
    }

    fn evictable(&self, d: u32) -> bool {
        self.state[d as usize] == UnitState::Resident && self.live_children[d as usize] == 0
    }

    fn issue(&mut self, u: u32, bytes: u64) {
        self.state[u as usize] = UnitState::Loading;
        for &p in self.units.parents(u) {
            self.live_children[p as usize] += 1;
        }
        self.stats.resident_bytes += bytes;
        self.stats.resident_records += self.units.simplices(u).len() as u64;
        self.stats.peak_resident_bytes = self
            .stats
            .peak_resident_bytes
            .max(self.stats.resident_bytes);
        self.stats.loaded_bytes += bytes;
        self.stats.loads += 1;
        self.stats.loading_units += 1;
    }

    fn evict(&mut self, v: u32) {
        debug_assert!(self.evictable(v));
        self.state[v as usize] = UnitState::Absent;
        let at = self.resident_at[v as usize] as usize;
        self.resident.swap_remove(at);
        if let Some(&moved) = self.resident.get(at) {
            self.resident_at[moved as usize] = at as u32;
        }
        self.set_may_refine(v, false);
        for &p in self.units.parents(v) {
            self.live_children[p as usize] -= 1;
        }
        self.stats.resident_bytes -= self.units.bytes(v);
        self.stats.resident_records -= self.units.simplices(v).len() as u64;
        self.stats.resident_units -= 1;
        self.stats.evictions += 1;
        // Room was made: the loads given back for want of it may be issued again.
        for u in self.deferred_units.drain(..) {
            self.deferred[u as usize] = false;
        }
    }

    fn set_may_refine(&mut self, d: u32, value: bool) {
        if self.may_refine[d as usize] != value {
            self.may_refine[d as usize] = value;
            self.flags_changed = true;
            if self.track_changes {
                self.changed.push(d);
            }
        }
    }

    /// Marks absent unit `u` as one that can never be held (larger than any page of the GPU's
    /// pool: pages are at most one storage binding, and a unit lands whole in one page). It
    /// is never requested or loaded, its diamond never refines: the cut stays coarser there
    /// and the stream still settles (a unit issued but never placed would keep it loading
    /// for good).
    pub fn refuse(&mut self, u: u32) {
        if self.state[u as usize] == UnitState::Absent {
            self.state[u as usize] = UnitState::TooLarge;
            self.stats.too_large_units += 1;
        }
    }

    /// Ends a load: `ok` makes the unit resident (and lets it and every resident descendant
    /// whose parents now all may refine refine); a failure marks it broken and frees its
    /// bytes.
    pub fn complete(&mut self, u: u32, ok: bool) {
        let ui = u as usize;
        assert_eq!(
            self.state[ui],
            UnitState::Loading,
            "unit {u} completed without being issued"
        );
        self.stats.loading_units -= 1;
        if !ok {
            self.state[ui] = UnitState::Broken;
            for &p in self.units.parents(u) {
                self.live_children[p as usize] -= 1;
            }
            self.stats.resident_bytes -= self.units.bytes(u);
            self.stats.resident_records -= self.units.simplices(u).len() as u64;
            self.stats.broken_units += 1;
            return;
        }
        self.state[ui] = UnitState::Resident;
        self.resident_at[ui] = self.resident.len() as u32;
        self.resident.push(u);
        self.stats.resident_units += 1;
        let mut stack = vec![u];
        while let Some(d) = stack.pop() {
            let ready = self.state[d as usize] == UnitState::Resident
                && !self.may_refine[d as usize]
                && self
                    .units
                    .parents(d)
                    .iter()
                    .all(|&p| self.may_refine[p as usize]);
            if ready {
                self.set_may_refine(d, true);
                stack.extend_from_slice(self.units.children(d));
            }
        }
    }
}

mod space;
