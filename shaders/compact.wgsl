// The compaction pass, after the traversal: one workgroup per resident page turns the page's
// selection list into one non-indexed indirect draw. It writes each selected patch's first
// strip slot (the exclusive prefix sum of strip_slots over the list, in list order) and the
// page's DrawIndirect with 3 vertices per slot; the vertex shader (draw.wgsl) finds a vertex's
// patch by binary search over those prefix sums. Work: the list's length, in chunks of 256.
// Prepended by records.wgsl.

@group(0) @binding(0) var<storage, read> tets: array<TetRecord>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;                 // one per page
@group(0) @binding(2) var<storage, read> list_starts: array<u32>;            // one per page
@group(0) @binding(3) var<storage, read_write> selected: array<Selected>;
@group(0) @binding(4) var<storage, read_write> draws: array<DrawIndirect>;   // one per page

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
    let first = list_starts[page];
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
        draws[page] = DrawIndirect(3u * min(carry, MAX_SLOTS), 1u, 0u, 0u);
    }
}
