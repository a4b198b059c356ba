//! Prints, per dimension, level and interior/boundary, the histogram of (simplices, parents,
//! children) over every diamond down to a level — a quick look at seed 001's table 1.
use std::collections::{BTreeMap, BTreeSet};
use tessera_core::leb::{Diamond, Simplex};

fn main() {
    let bits = 4;
    for dim in [2u8, 3] {
        let mut seen = BTreeSet::new();
        let mut hist: BTreeMap<(u16, bool, usize, usize, usize), usize> = BTreeMap::new();
        let mut stack = Simplex::roots(dim, bits);
        while let Some(s) = stack.pop() {
            if !s.can_split() || s.level() > 9 {
                continue;
            }
            if seen.insert(s.split_point()) {
                let d = Diamond::find(dim, bits, s.split_point()).unwrap();
                *hist
                    .entry((
                        d.level,
                        d.is_interior(bits),
                        d.simplices.len(),
                        d.parents.len(),
                        d.children.len(),
                    ))
                    .or_default() += 1;
            }
            stack.extend(s.children());
        }
        println!("dim {dim}: (level, interior, simplices, parents, children) -> count");
        for (k, v) in hist {
            println!("  {k:?} -> {v}");
        }
    }
}
