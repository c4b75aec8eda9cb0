// plane_segment.wgsl: where an epipolar plane through the eye cuts a triangle, shared by Voxelize
// (every item's segment, voxelize.wgsl) and Cull (the segments that bound a block of a large
// triangle's planes, cull.wgsl `hidden_blocks`).
//
// Watertight: a crossing on an edge is computed from the edge's two vertices in a canonical order,
// so the two triangles that share the edge get the same point bit for bit; a vertex on the plane is
// taken as it is.

fn vertex_less(a: vec3f, b: vec3f) -> bool {
    if (a.x != b.x) { return a.x < b.x; }
    if (a.y != b.y) { return a.y < b.y; }
    return a.z < b.z;
}

// Where edge (a, b) crosses the plane (signed distances da, db of opposite signs), computed from
// the vertices in a canonical order: both triangles sharing the edge get the same bits.
// (One division on the ordered pair rather than one per order.)
fn edge_point(a: vec3f, da: f32, b: vec3f, db: f32) -> vec3f {
    let swap = vertex_less(b, a);
    let s = select(a, b, swap);
    let t = select(b, a, swap);
    let ds = select(da, db, swap);
    let dt = select(db, da, swap);
    return s + (t - s) * (ds / (ds - dt));
}

// A triangle's vertices, relative to the eye.
struct Tri {
    p0: vec3f,
    p1: vec3f,
    p2: vec3f,
}

struct Segment {
    p: vec3f,
    q: vec3f,
    ok: bool,
}

// The segment where the plane with normal n through the eye cuts the triangle (vertices relative
// to the eye): empty when it misses, a point when it touches a vertex, nothing for a triangle lying
// in the plane (seen edge-on from every light ray in it; its neighbours' edges carry the surface).
// The points on the plane are taken in a fixed order (the vertices on it, then the crossings of
// edges 01, 12, 20); the first and the last are the ends. Written without a private array: on
// llvmpipe an index that differs between the lanes of a SIMD group is a gather through memory, and
// with one here (pts[count]) the pass took three times as long on the classroom.
fn plane_segment(t: Tri, n: vec3f) -> Segment {
    let d0 = dot(n, t.p0);
    let d1 = dot(n, t.p1);
    let d2 = dot(n, t.p2);
    var a = vec3f(0.0);
    var b = vec3f(0.0);
    var count = 0u;
    if (d0 == 0.0) { a = t.p0; b = t.p0; count = 1u; }
    if (d1 == 0.0) { if (count == 0u) { a = t.p1; } b = t.p1; count++; }
    if (d2 == 0.0) { if (count == 0u) { a = t.p2; } b = t.p2; count++; }
    if (crosses(d0, d1)) { let e = edge_point(t.p0, d0, t.p1, d1); if (count == 0u) { a = e; } b = e; count++; }
    if (crosses(d1, d2)) { let e = edge_point(t.p1, d1, t.p2, d2); if (count == 0u) { a = e; } b = e; count++; }
    if (crosses(d2, d0)) { let e = edge_point(t.p2, d2, t.p0, d0); if (count == 0u) { a = e; } b = e; count++; }
    return Segment(a, b, count != 0u && count != 3u);
}

// Strictly opposite signs (not a product, which underflows to 0 for tiny distances).
fn crosses(da: f32, db: f32) -> bool {
    return (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0);
}

