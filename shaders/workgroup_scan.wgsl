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
