// cull.wgsl: the triangles that can shadow a visible point, and their rectangles (DESIGN 6).
//
// One thread per triangle: its epipolar bounding rectangles (triangle_bounds.wgsl) and its z range.
// A triangle is dropped when it lies outside the visible wedge of planes, past the last visible
// ray, or outside the bins' z range (beyond the farthest visible depth the Ranges pass found).
// Kept triangles are appended to a list the Voxelize pass draws with an indirect draw
// (12 vertices each); the Scan's indirect dispatch is empty when nothing was kept.

#import common
#import triangle_bounds

@group(0) @binding(0) var<uniform> f: Frame;
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> kept: array<u32>;
@group(0) @binding(3) var<storage, read_write> kept_rects: array<vec4f>;
// [0] kept, [1] culled by z (beyond the farthest visible depth or outside the casters' range),
// [2] culled by rays or planes (outside the visible wedge or past the last visible ray).
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>, 4>;
// DrawIndirect arguments: vertex_count, instance_count, first_vertex, first_instance.
@group(0) @binding(5) var<storage, read_write> draw_args: array<atomic<u32>, 4>;
// Scan's DispatchIndirect arguments: no workgroups at all when no triangle was kept.
@group(0) @binding(6) var<storage, read_write> scan_args: array<u32, 3>;

@compute @workgroup_size(64)
fn cull(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = arrayLength(&tris) / 3u;
    let tri = id.x + id.y * groups.x * 64u;
    if (tri >= count) { return; }
    let rects = triangle_rects(tri);
    if (rects.a.x >= rects.a.z) {
        atomicAdd(&counters[2], 1u);
        return;
    }
    let z = triangle_z_range(tri);
    let bins = f32(f.grid.z);
    if (bin_coord(f, z.y) < 0.0 || bin_coord(f, z.x) >= bins || z.x > z.y) {
        atomicAdd(&counters[1], 1u);
        return;
    }
    let i = atomicAdd(&counters[0], 1u);
    kept[i] = tri;
    kept_rects[2u * i] = rects.a;
    kept_rects[2u * i + 1u] = rects.b;
    atomicAdd(&draw_args[0], 12u);
}

@compute @workgroup_size(1)
fn cull_finish() {
    atomicStore(&draw_args[1], 1u);
    let columns = f.grid.x * f.grid.w;
    scan_args[0] = select(0u, (columns + 63u) / 64u, atomicLoad(&counters[0]) > 0u);
    scan_args[1] = 1u;
    scan_args[2] = 1u;
}

