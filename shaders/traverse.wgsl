// The stateless traversal: one invocation per simplex decides alone whether its patch is drawn
// (seed 001, the per-simplex rule; CPU reference: tessera_core::cut::select_visible with the
// same f32 operations in the same order) and appends an indexed indirect draw for it.
// Prepended by records.wgsl.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> diamonds: array<DiamondRecord>;     // one per diamond
@group(0) @binding(2) var<storage, read> tets: array<TetRecord>;             // one per simplex
@group(0) @binding(3) var<storage, read> locations: array<PatchLocation>;    // one per simplex
@group(0) @binding(4) var<storage, read_write> draws: array<DrawIndexedIndirect>;
@group(0) @binding(5) var<storage, read_write> counts: array<atomic<u32>>;   // one per draw list

// Screen-space error of a diamond: error * K / max(|centre - eye| - radius, near).
fn rho(d: DiamondRecord) -> f32 {
    let x = d.cx - frame.eye_tau.x;
    let y = d.cy - frame.eye_tau.y;
    let z = d.cz - frame.eye_tau.z;
    let distance = sqrt(x * x + y * y + z * z);
    return d.error * frame.metric.x / max(distance - d.radius, frame.metric.y);
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
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

@compute @workgroup_size(64) // one simplex per thread
fn traverse(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * frame.dispatch.x;
    if i >= frame.counts.x {
        return;
    }
    let t = tets[i];
    let tau = frame.eye_tau.w;
    // The rule: rho(own diamond) <= tau < rho(parent diamond).
    if t.diamond != NO_INDEX && !(rho(diamonds[t.diamond]) <= tau) {
        return;
    }
    if t.parent_diamond != NO_INDEX && !(tau < rho(diamonds[t.parent_diamond])) {
        return;
    }
    let location = locations[i];
    if location.list == NO_INDEX {
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
    let slot = atomicAdd(&counts[location.list], 1u);
    draws[location.first_slot + slot] = DrawIndexedIndirect(
        t.strip_index_count, 1u, location.first_index, location.base_vertex, i);
}
