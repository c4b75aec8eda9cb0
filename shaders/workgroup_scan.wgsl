// workgroup_scan.wgsl: an inclusive prefix sum over a workgroup's threads, for the passes that
// place items in blocks (cull.wgsl's work list, surface_cull.wgsl's draw list). Hillis-Steele, in
// log2(width) steps:
//
//   partial[i] <- partial[0] + ... + partial[i]   for every i < width
//
// Each of the first `width` threads writes its own `partial[lid]` first, then every thread of the
// workgroup calls scan_partial with the same `width` (the loop holds barriers). On a CPU adapter
// every barrier switches between all of a workgroup's invocations: keep workgroups that scan small.

var<workgroup> partial: array<u32, 256>;

fn scan_partial(lid: u32, width: u32) {
    for (var step = 1u; step < width; step <<= 1u) {
        workgroupBarrier();
        var add = 0u;
        if (lid >= step) { add = partial[lid - step]; }
        workgroupBarrier();
        partial[lid] += add;
    }
    workgroupBarrier();
}

// One chunk of 256 values of an exclusive prefix sum longer than a workgroup: thread lid brings
// value v and gets (the chunk's values before its own, the chunk's total). Every thread of a
// workgroup of 256 calls it, the same number of times (it holds barriers); the caller carries the
// totals from one chunk to the next.
fn scan_chunk(lid: u32, v: u32) -> vec2u {
    partial[lid] = v;
    scan_partial(lid, 256u);
    let out = vec2u(partial[lid] - v, partial[255]);
    // The next chunk overwrites `partial`.
    workgroupBarrier();
    return out;
}
