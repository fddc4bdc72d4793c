// Any-hit segment and first-hit ray queries (one traversal, bvh_trace) against a binary BVH in
// storage buffers
// (mirrors src/geom/bvh_layout.rs::{BvhNode, BvhTriangle}, built by
// src/formfactor/raytrace/flat_bvh.rs; checked by src/gpu/contracts).
// The rules are those of Occluders::visible: every triangle blocks from
// both sides, Moller-Trumbore with inclusive edges, t strictly inside
// (tmin, 1 - tmin) with tmin = eps / length, triangles of the two skipped
// patches ignored.
// The includer declares nothing at bindings 0 and 1.

struct BvhNode {
    // count == 0: interior, left child = this + 1, right child = index;
    // count > 0: leaf holding triangles index .. index + count.
    vec3 lo;
    uint index;
    vec3 hi;
    uint count;
};

struct BvhTriangle {
    vec3 v0;
    uint patch_id;
    vec3 e1;
    uint pad0;
    vec3 e2;
    uint pad1;
};

layout(set = 0, binding = 0, std430) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(set = 0, binding = 1, std430) readonly buffer BvhTriangles { BvhTriangle bvh_tris[]; };

// The shader's traversal stack; flat_bvh.rs keeps the depth under it.
#define BVH_STACK 64

// Entry distance of a + t d (inv = 1 / d) into the box over [tmin, tmax],
// or -1 when it misses.
float bvh_slab(uint node, vec3 a, vec3 inv, float tmin, float tmax) {
    vec3 t0 = (bvh_nodes[node].lo - a) * inv;
    vec3 t1 = (bvh_nodes[node].hi - a) * inv;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    float near = max(max(lo.x, lo.y), max(lo.z, tmin));
    float far = min(min(hi.x, hi.y), min(hi.z, tmax));
    return near <= far ? near : -1.0;
}

// `precise`: no fused multiply-adds, so that the test rounds as the CPU's
// (occluders.rs::hit_distance) does and grazing hits fall the same way.
// The t where a + t d meets triangle k, when strictly inside (tmin, tmax);
// -1 otherwise.
float bvh_hit_t(uint k, vec3 a, vec3 d, float tmin, float tmax) {
    vec3 e1 = bvh_tris[k].e1;
    vec3 e2 = bvh_tris[k].e2;
    precise vec3 p = cross(d, e2);
    precise float det = dot(e1, p);
    if (det == 0.0 || isinf(det) || isnan(det)) {
        return -1.0;
    }
    precise float inv = 1.0 / det;
    precise vec3 s = a - bvh_tris[k].v0;
    precise float u = dot(s, p) * inv;
    if (!(u >= 0.0 && u <= 1.0)) {
        return -1.0;
    }
    precise vec3 q = cross(s, e1);
    precise float v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) {
        return -1.0;
    }
    precise float t = dot(e2, q) * inv;
    return t > tmin && t < tmax ? t : -1.0;
}

float bvh_safe(float x) {
    return abs(x) < 1e-30 ? (x < 0.0 ? -1e-30 : 1e-30) : x;
}

// The nearest triangle that a + t d meets with t strictly inside
// (tmin, tmax), triangles of the patches in `skip` ignored: its t, and its
// patch in `patch_id`; -1 when it meets none. `any`: the first one found,
// not the nearest (a visibility query stops there).
float bvh_trace(vec3 a, vec3 d, float tmin, float tmax, uvec2 skip, bool any, out uint patch_id) {
    patch_id = 0xffffffffu;
    float best = tmax;
    vec3 inv = 1.0 / vec3(bvh_safe(d.x), bvh_safe(d.y), bvh_safe(d.z));
    if (bvh_slab(0u, a, inv, tmin, best) < 0.0) {
        return -1.0;
    }
    uint stack[BVH_STACK];
    int sp = 0;
    uint node = 0u;
    while (true) {
        uint count = bvh_nodes[node].count;
        uint index = bvh_nodes[node].index;
        if (count > 0u) {
            for (uint k = index; k < index + count; k++) {
                uint id = bvh_tris[k].patch_id;
                if (id == skip.x || id == skip.y) {
                    continue;
                }
                float t = bvh_hit_t(k, a, d, tmin, best);
                if (t >= 0.0) {
                    patch_id = id;
                    if (any) {
                        return t;
                    }
                    best = t;
                }
            }
        } else {
            uint l = node + 1u;
            uint r = index;
            float tl = bvh_slab(l, a, inv, tmin, best);
            float tr = bvh_slab(r, a, inv, tmin, best);
            if (tl >= 0.0 && tr >= 0.0) {
                // Nearer first; the other waits on the stack.
                bool left_first = tl <= tr;
                stack[sp++] = left_first ? r : l;
                node = left_first ? l : r;
                continue;
            }
            if (tl >= 0.0) {
                node = l;
                continue;
            }
            if (tr >= 0.0) {
                node = r;
                continue;
            }
        }
        // The next box on the stack that the nearest hit so far leaves
        // open (any box pushed is, until a hit shortens the ray).
        bool found = false;
        while (sp > 0) {
            node = stack[--sp];
            if (any || bvh_slab(node, a, inv, tmin, best) >= 0.0) {
                found = true;
                break;
            }
        }
        if (!found) {
            break;
        }
    }
    return patch_id == 0xffffffffu ? -1.0 : best;
}

// Whether the segment from a to b is unblocked (node_count 0: no scene).
bool bvh_visible(vec3 a, vec3 b, uvec2 skip, float eps, uint node_count) {
    vec3 d = b - a;
    float len = length(d);
    if (node_count == 0u || isnan(len) || len <= 2.0 * eps) {
        return true;
    }
    float tmin = eps / len;
    uint patch_id;
    return bvh_trace(a, d, tmin, 1.0 - tmin, skip, true, patch_id) < 0.0;
}

// The nearest triangle the ray a + t d (t > tmin) meets, patch `skip`
// ignored (Occluders::first_hit_beyond): its t, and its patch in
// `patch_id`; -1 when it meets none.
float bvh_first_hit(vec3 a, vec3 d, float tmin, uint skip, uint node_count, out uint patch_id) {
    patch_id = 0xffffffffu;
    if (node_count == 0u) {
        return -1.0;
    }
    return bvh_trace(a, d, tmin, 1.0 / 0.0, uvec2(skip, skip), false, patch_id);
}
