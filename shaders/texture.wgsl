// Textures streamed as pages (virtual texturing with GPU feedback): the textured fill's
// fragment entry points. Appended to draw.wgsl in a renderer given textures
// (tessera_runtime::gpu::texture_cache); the arithmetic is mirrored operation for operation by
// tessera_runtime::gpu::texture_pages (tested against tessera_core::texture).
//
// A wedge's v names its band (the one holding floor(v)); the band names a texture (or none:
// white) and the shift to subtract. The level wanted is floor(½ log2 ρ²), ρ the larger UV
// derivative in level-0 texels, clamped to the texture's levels; its page is REQUESTED (a bit
// a global page, read back by the CPU, which loads it), and the finest RESIDENT page at that
// level or coarser is sampled (each texture's last level, one page, is always resident), with
// explicit gradients in page coordinates so that the page's own two mips filter trilinearly.

@group(2) @binding(0) var pool: texture_2d_array<f32>;                // a page a layer, 3 mips
@group(2) @binding(1) var pool_sampler: sampler;                      // linear, clamped
// Header (band count, texture count, 2 pads), bands (start, span, shift, texture: 4 words a
// band), then RECORD_WORDS a texture (width, height, levels, wrap u | wrap v << 1, first
// global page, 3 pads, the start of each level among the texture's pages).
@group(2) @binding(2) var<storage, read> texture_info: array<u32>;
@group(2) @binding(3) var<storage, read> page_table: array<u32>;     // one per global page: layer + 1, 0 absent
@group(2) @binding(4) var<storage, read_write> page_requests: array<atomic<u32>>; // a bit a global page

// tessera_core::texture and texture_pages.rs.
const PAGE_PAYLOAD: u32 = 128u;
const PAGE_GUTTER: i32 = 4;
const PAGE_SIDE: f32 = 136.0;
const INFO_HEADER_WORDS: u32 = 4u;
const RECORD_WORDS: u32 = 24u;
const NO_TEXTURE: u32 = 0xffffffffu;

// Texels of level `level` of the texture whose record starts at word `record`.
fn level_size(record: u32, level: u32) -> vec2<u32> {
    let d = (1u << level) - 1u;
    let w = (texture_info[record] + d) >> level;
    let h = (texture_info[record + 1u] + d) >> level;
    return max(vec2<u32>(w, h), vec2<u32>(1u));
}

// Texel index i of a level n texels long, wrapped (repeat) or clamped into [0, n). No `%` of
// a negative operand: naga writes it into GLSL as it is, where it is undefined (llvmpipe GL
// computed it as unsigned, right only for power-of-two sides); `/` truncates everywhere.
fn wrap_texel(i: i32, n: i32, repeat: bool) -> i32 {
    if repeat {
        let r = i - n * (i / n);
        return select(r, r + n, r < 0);
    }
    return clamp(i, 0, n - 1);
}

// texture_pages.rs `desired_level`.
fn desired_level(record: u32, ddx: vec2<f32>, ddy: vec2<f32>) -> u32 {
    let size = vec2<f32>(f32(texture_info[record]), f32(texture_info[record + 1u]));
    let a = ddx * size;
    let b = ddy * size;
    let rho2 = max(a.x * a.x + a.y * a.y, b.x * b.x + b.y * b.y);
    let lod = 0.5 * log2(rho2);
    if !(lod >= 1.0) {
        return 0u;
    }
    return min(u32(floor(lod)), texture_info[record + 2u] - 1u);
}

struct PagePoint {
    global: u32,          // the global page
    texel: vec2<f32>,     // where in its image, page texels (gutter included)
}

// texture_pages.rs `page_point`: the page of `level` serving texture coordinate `st`.
fn page_point(record: u32, level: u32, st: vec2<f32>) -> PagePoint {
    let n = level_size(record, level);
    let wrap = texture_info[record + 3u];
    let p = st * vec2<f32>(n);
    let i = floor(p);
    let index = vec2<i32>(i);
    let wrapped = vec2<i32>(
        wrap_texel(index.x, i32(n.x), (wrap & 1u) == 0u),
        wrap_texel(index.y, i32(n.y), (wrap & 2u) == 0u),
    );
    let page = vec2<u32>(wrapped) / PAGE_PAYLOAD;
    let texel = (p - i) + vec2<f32>(wrapped - vec2<i32>(page * PAGE_PAYLOAD) + vec2<i32>(PAGE_GUTTER));
    let pages_x = (n.x + PAGE_PAYLOAD - 1u) / PAGE_PAYLOAD;
    let global = texture_info[record + 4u] + texture_info[record + 8u + level] + page.y * pages_x + page.x;
    return PagePoint(global, texel);
}

fn request_page(global: u32) {
    let word = global / 32u;
    let bit = 1u << (global % 32u);
    if (atomicLoad(&page_requests[word]) & bit) == 0u {
        atomicOr(&page_requests[word], bit);
    }
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let high = 1.055 * pow(max(c, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, c * 12.92, c <= vec3<f32>(0.0031308));
}

// The texel at shifted coordinate `uv` as stored (sRGB-encoded, as the wedge colours are
// drawn), `ddx` and `ddy` its screen derivatives; x < 0 where its band has no texture.
fn band_texel(uv: vec2<f32>, ddx: vec2<f32>, ddy: vec2<f32>) -> vec4<f32> {
    let bands = texture_info[0];
    let f = floor(uv.y);
    var texture = NO_TEXTURE;
    var shift = 0.0;
    for (var b = 0u; b < bands; b++) {
        let at = INFO_HEADER_WORDS + 4u * b;
        let start = f32(bitcast<i32>(texture_info[at]));
        if f >= start && f < start + f32(texture_info[at + 1u]) {
            texture = texture_info[at + 3u];
            shift = f32(bitcast<i32>(texture_info[at + 2u]));
            break;
        }
    }
    if texture == NO_TEXTURE {
        return vec4<f32>(-1.0);
    }
    let record = INFO_HEADER_WORDS + 4u * bands + RECORD_WORDS * texture;
    let st = vec2<f32>(uv.x, uv.y - shift);
    let levels = texture_info[record + 2u];
    let wanted = desired_level(record, ddx, ddy);
    request_page(page_point(record, wanted, st).global);
    // The finest resident level from the wanted one; the last is pinned.
    var level = wanted;
    loop {
        let point = page_point(record, level, st);
        let entry = page_table[point.global];
        if entry != 0u || level + 1u >= levels {
            let scale = vec2<f32>(level_size(record, level)) / PAGE_SIDE;
            let layer = max(entry, 1u) - 1u;
            let c = textureSampleGrad(pool, pool_sampler, point.texel / PAGE_SIDE, layer, ddx * scale, ddy * scale);
            return vec4<f32>(srgb_encode(c.rgb), c.a);
        }
        level += 1u;
    }
    return vec4<f32>(-1.0);
}

// The albedo: the texel × the wedge colour (white where the model has no colours); where
// the band has no texture, the wedge colour (`plain` where the model has none).
fn albedo(uv: vec2<f32>, colour: vec3<f32>, plain: vec3<f32>) -> vec3<f32> {
    let ddx = dpdx(uv);
    let ddy = dpdy(uv);
    let has_colours = (frame.counts.w & ATTR_COLORS) != 0u;
    let texel = band_texel(uv, ddx, ddy);
    if texel.x < 0.0 {
        return select(plain, colour, has_colours);
    }
    return texel.rgb * select(vec3<f32>(1.0), colour, has_colours);
}

// The textured fill's inputs, each entry reading only what it uses (see draw.wgsl).
struct UvIn {
    @location(0) eye_relative: vec3<f32>,
    @location(4) uv: vec2<f32>,
}

struct UvNormalIn {
    @location(0) eye_relative: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(4) uv: vec2<f32>,
}

struct UvColourIn {
    @location(0) eye_relative: vec3<f32>,
    @location(2) colour: vec3<f32>,
    @location(4) uv: vec2<f32>,
}

struct UvNormalColourIn {
    @location(0) eye_relative: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec3<f32>,
    @location(4) uv: vec2<f32>,
}

struct UvOnlyIn {
    @location(4) uv: vec2<f32>,
}

struct UvColourOnlyIn {
    @location(2) colour: vec3<f32>,
    @location(4) uv: vec2<f32>,
}

// The lit mode, textured (derivatives first: uniform control flow).
@fragment
fn fs_lit_textured(in: UvIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    let base = albedo(in.uv, PLAIN_COLOUR, PLAIN_COLOUR);
    return vec4<f32>(base * shade(in.eye_relative, vec3<f32>(0.0), face), 1.0);
}

@fragment
fn fs_lit_normals_textured(in: UvNormalIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    let base = albedo(in.uv, PLAIN_COLOUR, PLAIN_COLOUR);
    return vec4<f32>(base * shade(in.eye_relative, in.normal, face), 1.0);
}

@fragment
fn fs_lit_colours_textured(in: UvColourIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    let base = albedo(in.uv, in.colour, PLAIN_COLOUR);
    return vec4<f32>(base * shade(in.eye_relative, vec3<f32>(0.0), face), 1.0);
}

@fragment
fn fs_lit_normals_colours_textured(in: UvNormalColourIn) -> @location(0) vec4<f32> {
    let face = face_of(in.eye_relative);
    let base = albedo(in.uv, in.colour, PLAIN_COLOUR);
    return vec4<f32>(base * shade(in.eye_relative, in.normal, face), 1.0);
}

// The color mode, textured: unlit albedo.
@fragment
fn fs_colour_textured(in: UvOnlyIn) -> @location(0) vec4<f32> {
    return vec4<f32>(albedo(in.uv, ALBEDO_GREY, ALBEDO_GREY), 1.0);
}

@fragment
fn fs_colour_colours_textured(in: UvColourOnlyIn) -> @location(0) vec4<f32> {
    return vec4<f32>(albedo(in.uv, in.colour, ALBEDO_GREY), 1.0);
}
