// The compaction pass, after the traversal: one workgroup per resident page turns the page's
// selection list into draw arguments. It writes each selected patch's first strip slot (the
// exclusive prefix sum of strip_slots over the list, in list order), then the page's
// arguments: when the slots fit the page's index region, the expansion's dispatch (expand.wgsl
// writes 3 indices per slot) and an indexed draw of them; else a non-indexed draw of 3
// vertices per slot whose vertex shader finds its slot by binary search (draw.wgsl, vs_main).
// Work: the list's length, in chunks of 256.
// Prepended by records.wgsl.

@group(0) @binding(0) var<storage, read> tets: array<TetRecord>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;                 // one per page
@group(0) @binding(2) var<storage, read> pages: array<PageInfo>;
@group(0) @binding(3) var<storage, read_write> selected: array<Selected>;
@group(0) @binding(4) var<storage, read_write> args: array<u32>;             // 16 words a page

const CHUNK: u32 = 256u;
// 3 × this fits in u32.
const MAX_SLOTS: u32 = 0x55555555u;

var<workgroup> scan: array<u32, CHUNK>;
var<workgroup> list_length: u32;

@compute @workgroup_size(256)
fn compact(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let page = group.x;
    if lane == 0u {
        list_length = counts[page];
    }
    let count = workgroupUniformLoad(&list_length);
    let first = pages[page].first_entry;
    var carry = 0u;
    for (var chunk = 0u; chunk < count; chunk += CHUNK) {
        let k = chunk + lane;
        var own = 0u;
        if k < count {
            own = strip_slots(tets[selected[first + k].simplex].strip_index_count);
        }
        // Inclusive scan of the chunk (Hillis-Steele).
        scan[lane] = own;
        for (var step = 1u; step < CHUNK; step *= 2u) {
            workgroupBarrier();
            var add = 0u;
            if lane >= step {
                add = scan[lane - step];
            }
            workgroupBarrier();
            scan[lane] += add;
        }
        workgroupBarrier();
        if k < count {
            selected[first + k].first_slot = carry + scan[lane] - own;
        }
        carry += scan[CHUNK - 1u];
        workgroupBarrier();
    }
    if lane == 0u {
        let total = min(carry, MAX_SLOTS);
        let info = pages[page];
        let indexed = total <= info.index_capacity;
        let at = PAGE_ARGS_WORDS * page;
        args[at + PULL_DRAW] = select(3u * total, 0u, indexed);
        args[at + PULL_DRAW + 1u] = 1u;
        args[at + PULL_DRAW + 2u] = 0u;
        args[at + PULL_DRAW + 3u] = 0u;
        args[at + INDEXED_DRAW] = select(0u, 3u * total, indexed);
        args[at + INDEXED_DRAW + 1u] = 1u;
        args[at + INDEXED_DRAW + 2u] = info.first_index;
        args[at + INDEXED_DRAW + 3u] = 0u;
        args[at + INDEXED_DRAW + 4u] = 0u;
        args[at + EXPAND_DISPATCH] = select(0u, min((total + 63u) / 64u, 65535u), indexed);
        args[at + EXPAND_DISPATCH + 1u] = 1u;
        args[at + EXPAND_DISPATCH + 2u] = 1u;
        args[at + SELECTED_SLOTS] = total;
    }
}
