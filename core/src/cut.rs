//! The cut: which simplices' patches are drawn for an eye and a pixel tolerance τ.
//!
//! Stateless rule (seed 001, Algorithm 7 made per-simplex): simplex t of diamond D, whose
//! parent simplex belongs to diamond P, is drawn iff ρ(D) ≤ τ < ρ(P), with ρ = 0 for leaves
//! (no split diamond) and ρ(P) = ∞ for roots. Saturation makes ρ monotone along the DAG, so
//! the drawn set is a conforming cut, and each simplex decides alone — the GPU runs the same
//! rule, one invocation per simplex. `select_top_down` reaches the same set by descending from
//! the roots and visiting only what the cut needs.
//!
//! `may_refine` flags (one bit per diamond, all set by default) let streaming keep a diamond
//! whose children's patches are not resident from refining: the rule then uses
//! ρ'(D) = may_refine(D) ? ρ(D) : 0 (`restrict_rhos`), unchanged otherwise. With flags closed
//! downwards (`close_may_refine`: a diamond may refine only if every parent may) ρ' stays
//! monotone, so every cut is still conforming, only coarser where refining is not allowed.

use crate::cull::CullTests;
use crate::metric::{center_minus_eye, ScreenSpaceMetric};
use crate::repository::format::{DiamondRecord, TetRecord, NO_INDEX};

/// ρ of every diamond for an eye given in the repository frame (see `metric::eye_local`).
pub fn diamond_rhos(
    diamonds: &[DiamondRecord],
    eye_local: [f32; 3],
    metric: &ScreenSpaceMetric,
) -> Vec<f32> {
    diamonds
        .iter()
        .map(|d| metric.rho(d.error, center_minus_eye(d.center, eye_local), d.radius))
        .collect()
}

/// Flag words letting every one of `diamond_count` diamonds refine (at least one word, so the
/// GPU binding is never empty): bit d % 32 of word d / 32 is diamond d's flag.
pub fn may_refine_all(diamond_count: usize) -> Vec<u32> {
    vec![u32::MAX; diamond_count.div_ceil(32).max(1)]
}

/// Diamond `d`'s flag (false beyond the words).
pub fn may_refine(words: &[u32], d: u32) -> bool {
    words
        .get(d as usize / 32)
        .is_some_and(|w| (w >> (d % 32)) & 1 == 1)
}

/// Clears diamond `d`'s flag (nothing beyond the words).
pub fn forbid_refine(words: &mut [u32], d: u32) {
    if let Some(w) = words.get_mut(d as usize / 32) {
        *w &= !(1 << (d % 32));
    }
}

/// Closes the flags downwards: clears the flag of every diamond with a parent whose flag is
/// clear, parents first (a parent's LEB level is one less than its child's).
pub fn close_may_refine(diamonds: &[DiamondRecord], words: &mut [u32]) {
    let mut order: Vec<u32> = (0..diamonds.len() as u32).collect();
    order.sort_by_key(|&d| diamonds[d as usize].level);
    for d in order {
        let parents = diamonds[d as usize].parents();
        if parents.iter().any(|&p| !may_refine(words, p)) {
            forbid_refine(words, d);
        }
    }
}

/// ρ'(D) = may_refine(D) ? ρ(D) : 0, in place.
pub fn restrict_rhos(rhos: &mut [f32], words: &[u32]) {
    for (d, rho) in rhos.iter_mut().enumerate() {
        if !may_refine(words, d as u32) {
            *rho = 0.0;
        }
    }
}

/// ρ of a simplex's own diamond: 0 for a leaf.
#[inline]
pub fn own_rho(tet: &TetRecord, rhos: &[f32]) -> f32 {
    if tet.diamond == NO_INDEX {
        0.0
    } else {
        rhos[tet.diamond as usize]
    }
}

/// ρ of the diamond whose split created the simplex: ∞ for a root.
#[inline]
pub fn parent_rho(tet: &TetRecord, rhos: &[f32]) -> f32 {
    if tet.parent_diamond == NO_INDEX {
        f32::INFINITY
    } else {
        rhos[tet.parent_diamond as usize]
    }
}

/// The stateless rule: drawn iff ρ(own) ≤ τ < ρ(parent).
#[inline]
pub fn is_drawn(tet: &TetRecord, rhos: &[f32], tau: f32) -> bool {
    own_rho(tet, rhos) <= tau && tau < parent_rho(tet, rhos)
}

/// Every simplex index the rule selects, by a flat scan (what the GPU does).
pub fn select_stateless(tets: &[TetRecord], rhos: &[f32], tau: f32) -> Vec<u32> {
    (0..tets.len() as u32)
        .filter(|&i| is_drawn(&tets[i as usize], rhos, tau))
        .collect()
}

/// What the GPU traversal draws: the rule's selection, minus the simplices `tests` cull for an
/// eye at `eye_local` (the same f32 operations as `shaders/traverse.wgsl`).
pub fn select_visible(
    tets: &[TetRecord],
    rhos: &[f32],
    tau: f32,
    eye_local: [f32; 3],
    tests: &CullTests,
) -> Vec<u32> {
    (0..tets.len() as u32)
        .filter(|&i| {
            let t = &tets[i as usize];
            is_drawn(t, rhos, tau) && tests.keeps(t, eye_local)
        })
        .collect()
}

/// The same set by descent from the roots (simplices `0..root_count`), in O(cut) time.
pub fn select_top_down(tets: &[TetRecord], root_count: usize, rhos: &[f32], tau: f32) -> Vec<u32> {
    let mut selected = Vec::new();
    let mut stack: Vec<u32> = (0..root_count as u32).rev().collect();
    while let Some(i) = stack.pop() {
        let t = &tets[i as usize];
        if own_rho(t, rhos) <= tau || t.first_child == NO_INDEX {
            selected.push(i);
        } else {
            stack.push(t.first_child + 1);
            stack.push(t.first_child);
        }
    }
    selected.sort_unstable();
    selected
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diamond(level: u32, parents: &[u32]) -> DiamondRecord {
        let mut d: DiamondRecord = bytemuck::Zeroable::zeroed();
        d.level = level;
        d.parent_count = parents.len() as u8;
        d.parents = [NO_INDEX; 4];
        d.parents[..parents.len()].copy_from_slice(parents);
        d
    }

    #[test]
    fn flags_close_downwards_and_zero_rho() {
        // 0 → {1, 2}, {1, 2} → 3, 2 → 4; listed out of level order.
        let diamonds = [
            diamond(2, &[1, 2]),
            diamond(0, &[]),
            diamond(1, &[1]),
            diamond(1, &[1]),
            diamond(2, &[3]),
        ];
        // Renumbered: index 0 is level 2 with parents 1 and 2; the root is 1.
        let mut words = may_refine_all(diamonds.len());
        assert_eq!(words, [u32::MAX]);
        forbid_refine(&mut words, 2);
        close_may_refine(&diamonds, &mut words);
        let allowed: Vec<bool> = (0..5).map(|d| may_refine(&words, d)).collect();
        // 0 has the forbidden parent 2; 4's parent 3 may still refine.
        assert_eq!(allowed, [false, true, false, true, true]);
        let mut rhos = [5.0, 9.0, 6.0, 6.0, 4.0];
        restrict_rhos(&mut rhos, &words);
        assert_eq!(rhos, [0.0, 9.0, 0.0, 6.0, 4.0]);
        assert_eq!(may_refine_all(33).len(), 2);
        assert!(!may_refine(&words, 64), "beyond the words");
    }
}
