// The traversal: stateless and top-down (seed 001). Dispatch k visits the simplices of depth k
// that the descent reaches, by record slot (runtime/src/gpu/records.rs: a slot record holds
// what the simplex needs, its diamond's sphere and error included, and its children's slot);
// each decides alone with the rule rho(own diamond) <= tau (a leaf
// always stops) and either selects its patch — after the frustum and normal-cone tests,
// appending it to its page's selection list — or queues its two children for dispatch k + 1. Reaching a simplex means its parent refined,
// i.e. tau < rho(parent diamond): the same rule as the flat CPU reference
// tessera_core::cut::select_visible, with the same f32 operations in the same order, and work
// proportional to the cut rather than to the model.
// Prepended by records.wgsl.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> records: array<SlotRecord>;        // one per slot
@group(0) @binding(2) var<storage, read> locations: array<PatchLocation>;    // one per slot
@group(0) @binding(3) var<storage, read_write> selected: array<Selected>;    // the pages' lists
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;   // one per page
@group(0) @binding(5) var<storage, read_write> queued: array<atomic<u32>>;   // one per depth
// Fully resident (step.gate_words = 1): bit d % 32 of word d / 32: diamond d may refine
// (tessera_core::cut::may_refine; all set unless a caller forbids some, closed downwards).
// Streaming (gate_words = 0) binds one unused word: a slot's child link is its flag.
@group(0) @binding(6) var<storage, read> may_refine: array<u32>;
// Streaming feedback (runtime/src/gpu/feedback.rs): [0] refined count, [1] wanted count,
// [2] capacity of each list; refined entries (diamond, bits of rho/tau) from word 4, wanted
// ones from word 4 + 2 * capacity. Appends past the capacity are counted, not written.
@group(0) @binding(7) var<storage, read_write> feedback: array<atomic<u32>>;

struct Step {
    depth: u32,
    root_count: u32,
    gate_words: u32,    // 1: may_refine words gate refinement too (fully resident)
    pad: u32,
}

@group(1) @binding(0) var<uniform> step: Step;                                // one per depth
@group(1) @binding(1) var<storage, read> queue_in: array<u32>;               // this depth's simplices
@group(1) @binding(2) var<storage, read_write> queue_out: array<u32>;        // the next depth's
// The next depth's indirect dispatch arguments: (x, y, z) per depth of the other parity, x
// growing as children are queued. (A dispatch cannot write the buffer it is dispatched from:
// even depths are dispatched from one buffer, odd depths from the other.)
@group(1) @binding(3) var<storage, read_write> next_dispatches: array<atomic<u32>>;

const WORKGROUP: u32 = 64u;
const MAX_WORKGROUPS: u32 = 65535u;

// Screen-space error of a slot's diamond: error * K / max(|centre - eye| - radius, near).
fn rho(t: SlotRecord) -> f32 {
    let x = t.dcx - frame.eye_tau.x;
    let y = t.dcy - frame.eye_tau.y;
    let z = t.dcz - frame.eye_tau.z;
    let distance = sqrt(x * x + y * y + z * z);
    return t.derror * frame.metric.x / max(distance - t.dradius, frame.metric.y);
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// may_refine(t.diamond): its children are in slots (a link) and, fully resident, its flag
// bit is set.
fn allowed(t: SlotRecord) -> bool {
    if t.children == NO_INDEX {
        return false;
    }
    let d = t.diamond;
    return step.gate_words == 0u || ((may_refine[d / 32u] >> (d % 32u)) & 1u) != 0u;
}

// rho'(d) = may_refine(d) ? rho(d) : 0 (tessera_core::cut::restrict_rhos).
fn restricted_rho(t: SlotRecord) -> f32 {
    if !allowed(t) {
        return 0.0;
    }
    return rho(t);
}

// Streaming feedback: appends (d, rho/tau) to list 0 (refined) or 1 (wanted), from simplices
// inside the view volume only (stream::stream_frame's rule).
fn report(list: u32, d: u32, priority: f32) {
    let capacity = atomicLoad(&feedback[2]);
    let k = atomicAdd(&feedback[list], 1u);
    if k < capacity {
        let at = 4u + 2u * (list * capacity + k);
        atomicStore(&feedback[at], d);
        atomicStore(&feedback[at + 1u], bitcast<u32>(priority));
    }
}

// Streaming feedback from simplex t of diamond d (not a leaf) at tolerance tau.
fn feed_back(t: SlotRecord, d: u32, tau: f32) {
    let flags = frame.counts.y;
    let c = vec3<f32>(t.cx - frame.eye_tau.x, t.cy - frame.eye_tau.y, t.cz - frame.eye_tau.z);
    if (flags & CULL_FRUSTUM) != 0u && !sphere_visible(c, t.radius) {
        return;
    }
    let r = rho(t);
    if r <= tau {
        return;
    }
    report(select(1u, 0u, allowed(t)), d, r / tau);
}

// tessera_core::cull::ViewVolume::sphere_visible.
fn sphere_visible(c: vec3<f32>, radius: f32) -> bool {
    for (var k = 0u; k < 4u; k++) {
        if dot3(frame.planes[k].xyz, c) < -radius {
            return false;
        }
    }
    let depth = dot3(frame.forward_near.xyz, c);
    return depth + radius >= frame.forward_near.w && depth - radius <= frame.metric.z;
}

// tessera_core::cull::cone_backfacing.
fn cone_backfacing(axis: vec3<f32>, cone_cos: f32, c: vec3<f32>, radius: f32) -> bool {
    if cone_cos <= 0.1 {
        return false;
    }
    let distance = sqrt(dot3(c, c));
    if distance <= radius {
        return false;
    }
    let sin_a = sqrt(max(1.0 - cone_cos * cone_cos, 0.0));
    let sin_g = radius / distance;
    let cos_g = sqrt(max(1.0 - sin_g * sin_g, 0.0));
    if cone_cos * cos_g - sin_a * sin_g <= 0.0 {
        return false;
    }
    let sin_sum = sin_a * cos_g + cone_cos * sin_g;
    return dot3(axis, c) > (sin_sum + 1e-4) * distance;
}

// Selects slot i's patch if it survives the culling tests: appends it to its page's list.
fn draw(i: u32, t: SlotRecord) {
    let location = locations[i];
    if location.page == NO_INDEX {
        return; // an empty patch: selected, nothing to draw
    }
    let c = vec3<f32>(t.cx - frame.eye_tau.x, t.cy - frame.eye_tau.y, t.cz - frame.eye_tau.z);
    let flags = frame.counts.y;
    if (flags & CULL_FRUSTUM) != 0u && !sphere_visible(c, t.radius) {
        return;
    }
    if (flags & CULL_CONES) != 0u && cone_backfacing(vec3<f32>(t.ax, t.ay, t.az), t.cone_cos, c, t.radius) {
        return;
    }
    let k = atomicAdd(&counts[location.page], 1u);
    selected[location.first_entry + k].simplex = i;
}

@compute @workgroup_size(64) // one simplex per thread (threads stride over big depths)
fn traverse(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let depth = step.depth;
    var count = step.root_count;
    if depth > 0u {
        count = atomicLoad(&queued[depth]);
    }
    let tau = frame.eye_tau.w;
    for (var k = id.x; k < count; k += groups.x * WORKGROUP) {
        var i = k; // depth 0: the roots are slots 0..root_count
        if depth > 0u {
            i = queue_in[k];
        }
        let t = records[i];
        if t.diamond != NO_INDEX {
            feed_back(t, t.diamond, tau); // streaming (feedback.rs)
        }
        if t.diamond == NO_INDEX || restricted_rho(t) <= tau {
            draw(i, t);
        } else {
            // Refine: the children (slots children, children + 1) are visited at depth + 1.
            let slot = atomicAdd(&queued[depth + 1u], 2u);
            queue_out[slot] = t.children;
            queue_out[slot + 1u] = t.children + 1u;
            let needed = min((slot + 2u + WORKGROUP - 1u) / WORKGROUP, MAX_WORKGROUPS);
            atomicMax(&next_dispatches[3u * ((depth + 1u) / 2u)], needed);
        }
    }
}
