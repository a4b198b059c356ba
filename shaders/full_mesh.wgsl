// The full-resolution peer (tessera_runtime::gpu::full_mesh): the whole input mesh in one
// indexed draw — a triangle list of u32 indices over a plain vertex buffer of f32 positions
// relative to the repository origin — shaded exactly like the lit mode of draw.wgsl on a model
// without stored normals (face normal from screen derivatives, same light, same base colour).
// Prepended by records.wgsl; only the uniforms' view_proj, eye_tau.xyz and light are read.

@group(0) @binding(0) var<uniform> frame: Frame;

// draw.wgsl's base colour of a model without colours.
const FULL_MESH_COLOUR: vec3<f32> = vec3<f32>(0.82, 0.80, 0.76);

struct FullMeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) eye_relative: vec3<f32>,
}

@vertex
fn vs_full_mesh(@location(0) position: vec3<f32>) -> FullMeshOut { // one per input vertex
    let eye_relative = position - frame.eye_tau.xyz;
    var out: FullMeshOut;
    out.clip = frame.view_proj * vec4<f32>(eye_relative, 1.0);
    out.eye_relative = eye_relative;
    return out;
}

// draw.wgsl's `shade` with the face normal: turned towards the eye, diffuse plus ambient.
@fragment
fn fs_full_mesh(in: FullMeshOut) -> @location(0) vec4<f32> {
    var n = normalize(cross(dpdx(in.eye_relative), dpdy(in.eye_relative)));
    if dot(n, -in.eye_relative) < 0.0 {
        n = -n;
    }
    let light = 0.25 + 0.75 * max(dot(n, frame.light.xyz), 0.0);
    return vec4<f32>(FULL_MESH_COLOUR * light, 1.0);
}
