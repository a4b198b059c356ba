//! One frame of the streaming traversal on the CPU: the reference the GPU traversal is
//! compared with under partial residency, and the driver of `bench stream`'s CPU mode and the
//! streaming tests.
//!
//! Top-down from the roots, each reached simplex t of diamond D decides alone with
//! ρ'(D) = may_refine(D) ? ρ(D) : 0. A simplex whose sphere is outside the view volume is
//! dropped with its whole subtree: a simplex's sphere contains every patch below it (the
//! build nests them), so nothing there is visible. Otherwise a leaf, or ρ'(D) ≤ τ, is drawn
//! (if it survives `CullTests::keeps`); else its children are queued. Being reached means the
//! parent refined, so the selection is exactly `select_visible` over the ρ' array. Feedback
//! comes from simplices inside the view volume: D refined (used), or D wanted — ρ(D) > τ but
//! D may not refine yet.

use tessera_core::cull::CullTests;
use tessera_core::metric::center_minus_eye;
use tessera_core::repository::format::{TetRecord, NO_INDEX};

/// What one frame selected and reported.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StreamFrame {
    /// The drawn simplices (visible ones only when culling is on), ascending.
    pub selection: Vec<u32>,
    /// Diamonds refined by a visible simplex, with ρ/τ, deduplicated.
    pub refined: Vec<(u32, f32)>,
    /// Diamonds a visible simplex wanted to refine but could not, with ρ/τ, deduplicated.
    pub wanted: Vec<(u32, f32)>,
    /// The largest ρ(D)/τ over the drawn simplices (0 for leaves): ≤ 1 when the cut is what
    /// the tolerance asks for, above 1 where missing data keeps it coarser.
    pub max_error_over_tau: f32,
}

/// ρ' of every diamond: ρ where the diamond may refine, else 0.
pub fn gated_rhos(rhos: &[f32], may_refine: &[bool]) -> Vec<f32> {
    rhos.iter()
        .zip(may_refine)
        .map(|(&r, &m)| if m { r } else { 0.0 })
        .collect()
}

/// Runs the traversal for one eye (`eye_local`, the repository frame) at tolerance `tau`.
pub fn stream_frame(
    tets: &[TetRecord],
    root_count: usize,
    rhos: &[f32],
    may_refine: &[bool],
    tau: f32,
    eye_local: [f32; 3],
    cull: &CullTests,
) -> StreamFrame {
    let mut frame = StreamFrame::default();
    let mut stack: Vec<u32> = (0..root_count as u32).rev().collect();
    while let Some(i) = stack.pop() {
        let t = &tets[i as usize];
        if let Some(volume) = &cull.frustum {
            if !volume.sphere_visible(center_minus_eye(t.center, eye_local), t.radius) {
                continue;
            }
        }
        if t.diamond == NO_INDEX || rhos[t.diamond as usize] <= tau {
            if cull.keeps(t, eye_local) {
                frame.selection.push(i);
                if t.diamond != NO_INDEX {
                    let e = rhos[t.diamond as usize] / tau;
                    frame.max_error_over_tau = frame.max_error_over_tau.max(e);
                }
            }
            continue;
        }
        let (d, priority) = (t.diamond, rhos[t.diamond as usize] / tau);
        if may_refine[d as usize] {
            frame.refined.push((d, priority));
            stack.push(t.first_child + 1);
            stack.push(t.first_child);
        } else {
            if cull.keeps(t, eye_local) {
                frame.selection.push(i);
                frame.max_error_over_tau = frame.max_error_over_tau.max(priority);
            }
            frame.wanted.push((d, priority));
        }
    }
    frame.selection.sort_unstable();
    for list in [&mut frame.refined, &mut frame.wanted] {
        list.sort_unstable_by_key(|&(d, _)| d);
        list.dedup_by_key(|&mut (d, _)| d);
    }
    frame
}
