//! The residency's invariants, checked by tests and debug builds.

use super::{Residency, UnitState};

impl Residency {
    /// Checks the invariants (for tests and debug builds): `may_refine` is exactly "resident
    /// and every parent may refine", the live-children counts and the byte total match the
    /// states. Returns the first violation.
    pub fn check_invariants(&self) -> Result<(), String> {
        let mut bytes = self.units.root_bytes();
        let mut records = self.units.roots().len() as u64;
        let mut live = vec![0u32; self.state.len()];
        for d in 0..self.state.len() as u32 {
            let s = self.state[d as usize];
            if matches!(s, UnitState::Resident | UnitState::Loading) {
                bytes += self.units.bytes(d);
                records += self.units.simplices(d).len() as u64;
                for &p in self.units.parents(d) {
                    live[p as usize] += 1;
                }
            }
            let expected = s == UnitState::Resident
                && self
                    .units
                    .parents(d)
                    .iter()
                    .all(|&p| self.may_refine[p as usize]);
            if self.may_refine[d as usize] != expected {
                return Err(format!(
                    "diamond {d}: may_refine {} but state {s:?} and parents {:?}",
                    self.may_refine[d as usize],
                    self.units.parents(d)
                ));
            }
        }
        let resident = (0..self.state.len() as u32)
            .filter(|&d| self.state[d as usize] == UnitState::Resident)
            .count();
        if resident != self.resident.len()
            || self.resident.iter().enumerate().any(|(i, &d)| {
                self.state[d as usize] != UnitState::Resident
                    || self.resident_at[d as usize] != i as u32
            })
        {
            return Err("the resident list differs from the states".into());
        }
        if live != self.live_children {
            return Err("live-children counts differ from the states".into());
        }
        if bytes != self.stats.resident_bytes {
            return Err(format!(
                "resident bytes {} but the states add up to {bytes}",
                self.stats.resident_bytes
            ));
        }
        if records != self.stats.resident_records || records > self.budget_records {
            return Err(format!(
                "resident records {} (budget {}) but the states add up to {records}",
                self.stats.resident_records, self.budget_records
            ));
        }
        if bytes > self.budget_bytes {
            return Err(format!(
                "resident bytes {bytes} exceed the budget {}",
                self.budget_bytes
            ));
        }
        Ok(())
    }
}
