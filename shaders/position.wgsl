// Positions on the global lattice and the eye-relative position every vertex stage projects.
// A stored position is q, 21-bit integers per axis (tessera_core::repository::format:
// position = bbox_min + q × step). The CPU splits the eye's lattice coordinate
// (eye − bbox_min) / step into an integer cell and a fraction (frame.eye_cell,
// frame.eye_fraction); here q − eye_cell is formed in exact i32 arithmetic, converted to f32
// (exact: |q − eye_cell| < 2^24), the fraction subtracted, and the step applied. Near the eye
// both terms are small, so precision there does not depend on the model's extent; and the
// result depends on q and the frame alone, so a vertex shared by two patches lands on the
// same bits in both. CPU mirror: tessera_core::eye_relative::EyeLattice.
// Prepended, after records.wgsl, to draw.wgsl and position_probe.wgsl; each declares `frame`.

// tessera_core::repository::format::unpack_position.
fn unpack_position(w0: u32, w1: u32) -> vec3<u32> {
    return vec3<u32>(w0 & 0x1fffffu, (w0 >> 21u) | ((w1 & 0x3ffu) << 11u), (w1 >> 10u) & 0x1fffffu);
}

// Lattice point q (stored positions lie in [0, 2^21); the terrain check's skirts a little
// beyond) minus the eye, in model units.
fn eye_relative_position(q: vec3<i32>) -> vec3<f32> {
    return (vec3<f32>(q - frame.eye_cell.xyz) - frame.eye_fraction.xyz) * frame.step.xyz;
}

// Eye-relative position -> clip space.
fn clip_position(eye_relative: vec3<f32>) -> vec4<f32> {
    return frame.view_proj * vec4<f32>(eye_relative, 1.0);
}
