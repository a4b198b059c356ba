// The expansion pass, after the compaction, one indirect dispatch per page (zero workgroups
// when the page's slots exceed its index region): one thread per selected strip slot writes
// the slot's triangle as three page-relative position slots into the page's index region,
// (s[k], s[k+1], s[k+2]) shifted by the patch's base vertex, the first two swapped when k is
// odd (every segment starts at an even position: patch.rs); a slot that touches a restart
// marker or repeats an index writes one index three times (a zero-area triangle). The indexed
// draw then shades each vertex about once (draw.wgsl, vs_indexed).
// Prepended by records.wgsl.

@group(0) @binding(0) var<storage, read> tets: array<TetRecord>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;                 // one per page
@group(0) @binding(2) var<storage, read> selected: array<Selected>;
@group(0) @binding(3) var<storage, read> locations: array<PatchLocation>;
@group(0) @binding(4) var<storage, read> args: array<u32>;                   // 16 words a page

struct PageDraw {
    page: u32,
    first_entry: u32,
    patch_count: u32,
    attributes: u32,
}

@group(1) @binding(0) var<storage, read> page: array<u32>;                   // one resident page
@group(1) @binding(1) var<uniform> page_draw: PageDraw;
@group(1) @binding(2) var<storage, read_write> indices: array<u32>;          // its index region

const WORKGROUP: u32 = 64u;

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

@compute @workgroup_size(64)
fn expand(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let total = args[PAGE_ARGS_WORDS * page_draw.page + SELECTED_SLOTS];
    let count = counts[page_draw.page];
    let first = page_draw.first_entry;
    for (var t = id.x; t < total; t += groups.x * WORKGROUP) {
        // The last entry of the list whose first slot is <= t.
        var low = 0u;
        var high = count;
        while high - low > 1u {
            let middle = (low + high) / 2u;
            if selected[first + middle].first_slot <= t {
                low = middle;
            } else {
                high = middle;
            }
        }
        let entry = selected[first + low];
        let k = t - entry.first_slot;
        let location = locations[entry.simplex];
        let wide = tets[entry.simplex].vertex_count > 65535u;
        var a = strip_index(location.first_index, k, wide);
        var b = strip_index(location.first_index, k + 1u, wide);
        let c = strip_index(location.first_index, k + 2u, wide);
        if (k & 1u) == 1u {
            let swap = a;
            a = b;
            b = swap;
        }
        let base = location.base_vertex;
        if a == NO_INDEX || b == NO_INDEX || c == NO_INDEX || a == b || b == c || a == c {
            indices[3u * t] = base;
            indices[3u * t + 1u] = base;
            indices[3u * t + 2u] = base;
        } else {
            indices[3u * t] = base + a;
            indices[3u * t + 1u] = base + b;
            indices[3u * t + 2u] = base + c;
        }
    }
}
