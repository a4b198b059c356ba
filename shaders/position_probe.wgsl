// The position probe (tessera_runtime::gpu::position_probe): for each packed position, the clip
// position the draw pass's vertex stages compute (draw.wgsl's pull_vertex: unpack_position,
// eye_relative_position, clip_position of position.wgsl), written out for tests to compare
// with an f64 projection. Prepended by records.wgsl and position.wgsl.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> packed: array<u32>;             // 2 words a position
@group(0) @binding(2) var<storage, read_write> clip: array<vec4<f32>>;   // one per position

@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&clip) {
        return;
    }
    let q = unpack_position(packed[2u * i], packed[2u * i + 1u]);
    clip[i] = clip_position(eye_relative_position(vec3<i32>(q)));
}
