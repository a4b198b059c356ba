// Drawing the selected patches: triangle strips with primitive restart, vertices pulled from the
// resident page (packed 63-bit positions on the global grid, then the optional attributes),
// the simplex index arriving as the instance index (the traversal's first_instance).
// Prepended by records.wgsl.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> tets: array<TetRecord>;             // one per simplex
@group(0) @binding(2) var<storage, read> locations: array<PatchLocation>;    // one per simplex
@group(1) @binding(0) var<storage, read> page: array<u32>;                   // one resident page

const MODE_LIT: u32 = 0u;
const MODE_PATCHES: u32 = 1u;
const MODE_LEVELS: u32 = 2u;

// The pixel crack check counts exactly this colour: back faces, seen only through a crack.
const FLAG_COLOUR: vec4<f32> = vec4<f32>(1.0, 0.0, 1.0, 1.0);

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) eye_relative: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec3<f32>,
    @location(3) @interpolate(flat) simplex: u32,
}

// tessera_core::repository::format::unpack_position.
fn unpack_position(w0: u32, w1: u32) -> vec3<u32> {
    return vec3<u32>(w0 & 0x1fffffu, (w0 >> 21u) | ((w1 & 0x3ffu) << 11u), (w1 >> 10u) & 0x1fffffu);
}

// tessera_core::repository::format::oct_decode_normal.
fn oct_decode(word: u32) -> vec3<f32> {
    let e = max(unpack2x16snorm(word), vec2<f32>(-1.0));
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    if n.z < 0.0 {
        let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), n.xy >= vec2<f32>(0.0));
        n = vec3<f32>((1.0 - abs(n.yx)) * s, n.z);
    }
    return normalize(n);
}

@vertex
fn vs_main(@builtin(vertex_index) slot: u32, @builtin(instance_index) simplex: u32) -> VertexOut {
    // slot = base_vertex + local index: the vertex's 8-byte position slot in the page.
    let q = unpack_position(page[2u * slot], page[2u * slot + 1u]);
    let local_position = frame.base.xyz + vec3<f32>(q) * frame.step.xyz;
    let eye_relative = local_position - frame.eye_tau.xyz;
    var out: VertexOut;
    out.clip = frame.view_proj * vec4<f32>(eye_relative, 1.0);
    out.eye_relative = eye_relative;
    out.simplex = simplex;
    out.normal = vec3<f32>(0.0);
    out.colour = vec3<f32>(0.82, 0.80, 0.76);
    // The attribute arrays follow the positions, one u32 per vertex each (patch.rs).
    let first = u32(locations[simplex].base_vertex);
    let n = tets[simplex].vertex_count;
    let local_index = slot - first;
    var word = 2u * (first + n) + local_index;
    let attributes = frame.counts.w;
    if (attributes & ATTR_NORMALS) != 0u {
        out.normal = oct_decode(page[word]);
        word += n;
    }
    if (attributes & ATTR_COLORS) != 0u {
        out.colour = unpack4x8unorm(page[word]).rgb;
    }
    return out;
}

// A stable colour per integer.
fn palette(k: u32) -> vec3<f32> {
    var h = k * 0x9e3779b9u;
    h ^= h >> 15u;
    h *= 0x85ebca6bu;
    h ^= h >> 13u;
    return vec3<f32>(f32(h & 0xffu), f32((h >> 8u) & 0xffu), f32((h >> 16u) & 0xffu)) / 255.0 * 0.7 + 0.3;
}

// Diffuse shading factor: stored normals if the model has them, else the face normal from
// screen derivatives (`face` = cross(dpdx, dpdy), taken in uniform control flow by the caller).
fn shade(in: VertexOut, face: vec3<f32>) -> f32 {
    var n = face;
    if (frame.counts.w & ATTR_NORMALS) != 0u && dot(in.normal, in.normal) > 0.0 {
        n = in.normal;
    }
    n = normalize(n);
    if dot(n, -in.eye_relative) < 0.0 {
        n = -n;
    }
    return 0.25 + 0.75 * max(dot(n, frame.light.xyz), 0.0);
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let face = cross(dpdx(in.eye_relative), dpdy(in.eye_relative));
    let mode = frame.counts.z;
    var base = in.colour;
    if mode == MODE_PATCHES {
        base = palette(in.simplex);
    } else if mode == MODE_LEVELS {
        base = palette(tets[in.simplex].level * 7919u + 1u);
    }
    return vec4<f32>(base * shade(in, face), 1.0);
}

// The pixel crack check draws twice. First the front faces alone (back faces culled), grey,
// writing depth. Then the back faces alone (front faces culled) in FLAG_COLOUR at depth 0 with
// the depth test "equal": they land only on pixels no front face covers. On a closed surface
// seen from outside, every ray that meets the surface meets a front face, so a flag pixel is a
// hole in the front layer: a crack. A back face poking through a front face (a
// self-intersection of a coarse patch, an error within tau) covers a front pixel and is not
// counted.
@fragment
fn fs_check_front(in: VertexOut) -> @location(0) vec4<f32> {
    let face = cross(dpdx(in.eye_relative), dpdy(in.eye_relative));
    return vec4<f32>(vec3<f32>(0.75) * shade(in, face), 1.0);
}

// Below this |cos| between a face and the view ray a face is edge-on (about 1.7 degrees): its
// screen winding can flip under f32 projection and sub-pixel snapping, so showing its back is
// not evidence of a crack. Such pixels get GRAZING_COLOUR: covered, neither grey nor flagged
// (the terrain check counts background pixels as holes, so they must not stay background).
const GRAZING_COS: f32 = 0.03;
const GRAZING_COLOUR: vec4<f32> = vec4<f32>(0.0, 0.0, 0.5, 1.0);

struct CheckOut {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_check_back(in: VertexOut) -> CheckOut {
    let face = cross(dpdx(in.eye_relative), dpdy(in.eye_relative));
    if abs(dot(normalize(face), normalize(in.eye_relative))) < GRAZING_COS {
        return CheckOut(GRAZING_COLOUR, 0.0);
    }
    return CheckOut(FLAG_COLOUR, 0.0);
}

// The terrain check's skirts: walls from the input's border edges (its outline and the borders
// of its nodata holes) down below the terrain (views from above) or up above it (from below),
// drawn in both check passes with fixed positions relative to the repository origin. Their
// side facing the hole is front: a ray through a hole meets a grey wall or passes beyond the
// terrain, as it does for the input, instead of seeing the far side of the surface.
@vertex
fn vs_skirt(@location(0) local_position: vec3<f32>) -> VertexOut {
    let eye_relative = local_position - frame.eye_tau.xyz;
    var out: VertexOut;
    out.clip = frame.view_proj * vec4<f32>(eye_relative, 1.0);
    out.eye_relative = eye_relative;
    out.normal = vec3<f32>(0.0);
    out.colour = vec3<f32>(0.82, 0.80, 0.76);
    out.simplex = 0u;
    return out;
}

// The wireframe overlay (line polygon mode, where the adapter has it).
@fragment
fn fs_wire(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(0.05, 0.05, 0.08, 1.0);
}
