//! The cut: which simplices' patches are drawn for an eye and a pixel tolerance τ.
//!
//! Stateless rule (seed 001, Algorithm 7 made per-simplex): simplex t of diamond D, whose
//! parent simplex belongs to diamond P, is drawn iff ρ(D) ≤ τ < ρ(P), with ρ = 0 for leaves
//! (no split diamond) and ρ(P) = ∞ for roots. Saturation makes ρ monotone along the DAG, so
//! the drawn set is a conforming cut, and each simplex decides alone — the GPU runs the same
//! rule, one invocation per simplex. `select_top_down` reaches the same set by descending from
//! the roots and visiting only what the cut needs.

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
