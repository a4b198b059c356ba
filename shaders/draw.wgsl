// Drawing the selected patches of one resident page. Usually one indexed draw of the indices
// expand.wgsl wrote (vs_indexed: the index is the vertex's position slot in the page, its patch
// found by binary search over the page's patches in base-vertex order). When a frame's slots
// exceed the page's index region, one non-indexed indirect draw instead (vs_main): 3
// vertices per strip slot of the page's selected patches (compact.wgsl). Vertex v belongs to
// slot t = v / 3; a binary search over the page's prefix sums finds the patch and its slot k,
// whose triangle is (s[k], s[k+1], s[k+2]) with the first two swapped when k is odd (every
// strip segment starts at an even position: patch.rs). A slot that touches a restart marker or
// repeats an index draws nothing (its three vertices at one point: zero area). Positions
// and attributes are pulled from the page (packed 63-bit positions on the global grid, then
// the optional attributes). No primitive restart, no multi-draw, no first_instance.
// Prepended by records.wgsl and position.wgsl (unpack_position, eye_relative_position).

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> tets: array<SlotRecord>;            // one per record slot
@group(0) @binding(2) var<storage, read> locations: array<PatchLocation>;    // one per simplex
@group(0) @binding(3) var<storage, read> selected: array<Selected>;          // the pages' lists
@group(0) @binding(4) var<storage, read> counts: array<u32>;                 // one per page
// Per page, at its first entry: its non-empty patches' simplices in base-vertex order.
@group(0) @binding(5) var<storage, read> page_simplices: array<u32>;

struct PageDraw {
    page: u32,
    first_entry: u32,   // the page's selection list (and page_simplices) start here
    patch_count: u32,   // non-empty patches of the page
    attributes: u32,    // the model's attribute flags (frame.counts.w)
}

@group(1) @binding(0) var<storage, read> page: array<u32>;                   // one resident page
// The vertex stage branches on no uniform-buffer value: lavapipe (Mesa 22.x) inlines the values
// a shader's branch and loop conditions read from uniform buffers into a newly compiled shader at
// every bind of its pipeline and keeps each one (the process grew by about 0.25 MB a frame).
// So the values the vertex stage branches on (the search bound, the attribute flags) are read
// from this storage binding; storage loads are not inlined.
@group(1) @binding(1) var<storage, read> page_draw: PageDraw;

// ShadingMode::code (frame.rs).
const MODE_LIT: u32 = 0u;
const MODE_PATCHES: u32 = 1u;
const MODE_LEVELS: u32 = 2u;
const MODE_COLOR: u32 = 4u;
const MODE_NORMALS: u32 = 5u;

// The pixel crack check counts exactly this colour: back faces, seen only through a crack.
const FLAG_COLOUR: vec4<f32> = vec4<f32>(1.0, 0.0, 1.0, 1.0);

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) eye_relative: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec3<f32>,
    @location(3) @interpolate(flat) simplex: u32,
    @location(4) uv: vec2<f32>,   // shifted texture coordinate (texture.wgsl); 0 without
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

// Strip index i of a patch whose strip starts at index `first` of the page; NO_INDEX for a
// restart marker.
fn strip_index(first: u32, i: u32, wide: bool) -> u32 {
    if wide {
        return page[first + i];
    }
    let at = first + i;
    let half = (page[at / 2u] >> (16u * (at % 2u))) & 0xffffu;
    return select(half, NO_INDEX, half == 0xffffu);
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> VertexOut {
    let t = vertex / 3u;
    let corner = vertex % 3u;
    // The last entry of the list whose first slot is ≤ t.
    let first = page_draw.first_entry;
    var low = 0u;
    var high = counts[page_draw.page]; // t < the list's slots, so entry `low` qualifies
    while high - low > 1u {
        let middle = (low + high) / 2u;
        if selected[first + middle].first_slot <= t {
            low = middle;
        } else {
            high = middle;
        }
    }
    let entry = selected[first + low];
    let simplex = entry.simplex;
    let k = t - entry.first_slot;
    let location = locations[simplex];
    let n = tets[simplex].vertex_count;
    let wide = n > 65535u;
    var a = strip_index(location.first_index, k, wide);
    var b = strip_index(location.first_index, k + 1u, wide);
    let c = strip_index(location.first_index, k + 2u, wide);
    if (k & 1u) == 1u {
        let swap = a;
        a = b;
        b = swap;
    }
    var out: VertexOut;
    out.simplex = simplex;
    out.normal = vec3<f32>(0.0);
    out.colour = PLAIN_COLOUR;
    out.uv = vec2<f32>(0.0);
    if a == NO_INDEX || b == NO_INDEX || c == NO_INDEX || a == b || b == c || a == c {
        // Nothing to draw: all three corners at one point, a zero-area triangle. The point is
        // inside the clip volume (on the far plane): a vertex outside it would send the whole
        // batch through the clipper on some drivers (lavapipe: 2× the frame time).
        out.clip = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        out.eye_relative = vec3<f32>(0.0);
        return out;
    }
    let local_index = select(select(c, b, corner == 1u), a, corner == 0u);
    pull_vertex(&out, location.base_vertex, n, local_index);
    return out;
}

// Vertex `local_index` of the patch of `n` vertices whose positions start at position slot
// `base_vertex` of the page: clip position, eye-relative position and attributes.
fn pull_vertex(out: ptr<function, VertexOut>, base_vertex: u32, n: u32, local_index: u32) {
    let slot = base_vertex + local_index; // the vertex's 8-byte position slot
    let q = unpack_position(page[2u * slot], page[2u * slot + 1u]);
    let eye_relative = eye_relative_position(vec3<i32>(q)); // position.wgsl
    (*out).clip = clip_position(eye_relative);
    (*out).eye_relative = eye_relative;
    (*out).normal = vec3<f32>(0.0);
    (*out).colour = PLAIN_COLOUR;
    (*out).uv = vec2<f32>(0.0);
    // The attribute arrays follow the positions, one u32 per vertex each (patch.rs).
    var word = 2u * (base_vertex + n) + local_index;
    let attributes = page_draw.attributes; // not frame.counts.w: see `page_draw`
    if (attributes & ATTR_NORMALS) != 0u {
        (*out).normal = oct_decode(page[word]);
        word += n;
    }
    if (attributes & ATTR_COLORS) != 0u {
        (*out).colour = unpack4x8unorm(page[word]).rgb;
        word += n;
    }
    if (attributes & ATTR_UVS) != 0u {
        // Two words a vertex: the array starts at word - local_index.
        let at = word + local_index;
        (*out).uv = vec2<f32>(bitcast<f32>(page[at]), bitcast<f32>(page[at + 1u]));
    }
}

// The indexed draw: `slot` is the vertex's 8-byte position slot in the page.
@vertex
fn vs_indexed(@builtin(vertex_index) slot: u32) -> VertexOut {
    // The page's last patch whose base vertex is <= slot.
    let first = page_draw.first_entry;
    var low = 0u;
    var high = page_draw.patch_count;
    while high - low > 1u {
        let middle = (low + high) / 2u;
        if locations[page_simplices[first + middle]].base_vertex <= slot {
            low = middle;
        } else {
            high = middle;
        }
    }
    let simplex = page_simplices[first + low];
    let location = locations[simplex];
    var out: VertexOut;
    out.simplex = simplex;
    pull_vertex(&out, location.base_vertex, tets[simplex].vertex_count, slot - location.base_vertex);
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

// What the fragment entry points read of `VertexOut`. Each reads only what it uses: every
// input a fragment stage reads is set up per triangle by the rasteriser, and a software one
// keeps that for every triangle of a binned scene (llvmpipe: 48 bytes an input and triangle,
// on the host), so the lit fill of a model without attributes reads the eye-relative position
// alone.
struct EyeIn {
    @location(0) eye_relative: vec3<f32>,
}

struct NormalIn {
    @location(0) eye_relative: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

struct ColourIn {
    @location(0) eye_relative: vec3<f32>,
    @location(2) colour: vec3<f32>,
}

struct NormalColourIn {
    @location(0) eye_relative: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec3<f32>,
}

// The fill's base colour where the model has no colours (as `VertexOut.colour` then is).
const PLAIN_COLOUR: vec3<f32> = vec3<f32>(0.82, 0.80, 0.76);

// The unit normal of a fragment: the stored normal (interpolated, renormalised) if the model
// has normals, this one is not zero and the frame does not ask for face normals
// (`SHADE_FACES`), else the face normal from screen derivatives (`face` = cross(dpdx, dpdy),
// taken in uniform control flow by the caller) turned towards the eye.
fn fragment_normal(eye_relative: vec3<f32>, normal: vec3<f32>, face: vec3<f32>) -> vec3<f32> {
    let stored = (frame.counts.w & ATTR_NORMALS) != 0u && (frame.counts.y & SHADE_FACES) == 0u;
    if stored && dot(normal, normal) > 0.0 {
        return normalize(normal);
    }
    let n = normalize(face);
    return select(n, -n, dot(n, -eye_relative) < 0.0);
}

// Diffuse shading factor with `fragment_normal`, turned towards the eye (a stored normal too:
// both sides of a face are lit alike).
fn shade(eye_relative: vec3<f32>, normal: vec3<f32>, face: vec3<f32>) -> f32 {
    var n = fragment_normal(eye_relative, normal, face);
    if dot(n, -eye_relative) < 0.0 {
        n = -n;
    }
    return 0.25 + 0.75 * max(dot(n, frame.light.xyz), 0.0);
}

fn face_of(eye_relative: vec3<f32>) -> vec3<f32> {
    return cross(dpdx(eye_relative), dpdy(eye_relative));
}

// What the color mode draws where the model has no colours (frame.rs: ALBEDO_GREY).
const ALBEDO_GREY: vec3<f32> = vec3<f32>(0.8);

// Every mode but the check (the patch and level colours read the simplex). The color and
// normals modes are unlit: the stored colour (else ALBEDO_GREY), and the normal n as
// n * 0.5 + 0.5 (model axes: x red, y green, z blue).
@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    let mode = frame.counts.z;
    if mode == MODE_COLOR {
        if (frame.counts.w & ATTR_COLORS) == 0u {
            return vec4<f32>(ALBEDO_GREY, 1.0);
        }
        return vec4<f32>(in.colour, 1.0);
    }
    if mode == MODE_NORMALS {
        return vec4<f32>(fragment_normal(in.eye_relative, in.normal, face) * 0.5 + 0.5, 1.0);
    }
    var base = in.colour;
    if mode == MODE_PATCHES {
        base = palette(tets[in.simplex].simplex); // the simplex's id: stable across reloads
    } else if mode == MODE_LEVELS {
        base = palette(tets[in.simplex].level * 7919u + 1u);
    }
    return vec4<f32>(base * shade(in.eye_relative, in.normal, face), 1.0);
}

// The lit mode, by the model's attributes: what `fs_main` draws in it.
@fragment
fn fs_lit(in: EyeIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    return vec4<f32>(PLAIN_COLOUR * shade(in.eye_relative, vec3<f32>(0.0), face), 1.0);
}

@fragment
fn fs_lit_normals(in: NormalIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    return vec4<f32>(PLAIN_COLOUR * shade(in.eye_relative, in.normal, face), 1.0);
}

@fragment
fn fs_lit_colours(in: ColourIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    return vec4<f32>(in.colour * shade(in.eye_relative, vec3<f32>(0.0), face), 1.0);
}

@fragment
fn fs_lit_normals_colours(in: NormalColourIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    return vec4<f32>(in.colour * shade(in.eye_relative, in.normal, face), 1.0);
}

// The pixel crack check draws twice. First the front faces alone (back faces culled), grey,
// writing depth. Then the back faces alone (front faces culled) in FLAG_COLOUR at depth 0 with
// the depth test "equal": they land only on pixels no front face covers. On a closed surface
// seen from outside, every ray that meets the surface meets a front face, so a flag pixel is a
// hole in the front layer: a crack. A back face poking through a front face (a
// self-intersection of a coarse patch, an error within tau) covers a front pixel and is not
// counted.
@fragment
fn fs_check_front(in: EyeIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    return vec4<f32>(vec3<f32>(0.75) * shade(in.eye_relative, vec3<f32>(0.0), face), 1.0);
}

@fragment
fn fs_check_front_normals(in: NormalIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    return vec4<f32>(vec3<f32>(0.75) * shade(in.eye_relative, in.normal, face), 1.0);
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
fn fs_check_back(in: EyeIn) -> CheckOut {
    let face = face_of(in.eye_relative);
    if abs(dot(normalize(face), normalize(in.eye_relative))) < GRAZING_COS {
        return CheckOut(GRAZING_COLOUR, 0.0);
    }
    return CheckOut(FLAG_COLOUR, 0.0);
}

// The terrain check's skirts: walls from the input's border edges (its outline and the borders
// of its nodata holes) down below the terrain (views from above) or up above it (from below),
// drawn in both check passes, their corners lattice points (the border vertices' own q, and
// heights below or above the terrain) placed like every vertex (position.wgsl). Their
// side facing the hole is front: a ray through a hole meets a grey wall or passes beyond the
// terrain, as it does for the input, instead of seeing the far side of the surface.
@vertex
fn vs_skirt(@location(0) q: vec3<i32>) -> VertexOut {
    let eye_relative = eye_relative_position(q);
    var out: VertexOut;
    out.clip = clip_position(eye_relative);
    out.eye_relative = eye_relative;
    out.normal = vec3<f32>(0.0);
    out.colour = PLAIN_COLOUR;
    out.simplex = 0u;
    out.uv = vec2<f32>(0.0);
    return out;
}

// The wireframe overlay (line polygon mode, where the adapter has it).
@fragment
fn fs_wire() -> @location(0) vec4<f32> {
    return vec4<f32>(0.05, 0.05, 0.08, 1.0);
}
