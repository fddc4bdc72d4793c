#version 450
#extension GL_GOOGLE_include_directive : require
// The final gather's direct part, one invocation per gather point (p, n,
// patch): for every source, B_s F(p -> s) V(p, s), summed (not multiplied
// by the point's reflectance). F is the exact point-to-polygon form factor
// (Lambert's edge sum after clipping the source to p's front half-space,
// as formfactor/analytic.rs::point_to_polygon), V the visible share of it
// from `rays` stratified samples uniform in the clipped source's area,
// weighted by the point kernel (solve/vertex_gather/receiver.rs). A source
// with early_out set, over 32 rays, is taken as wholly seen or hidden when
// 16 first rays and its corners all agree. Mirrors
// src/gpu/rays/{mod.rs, gather.rs}.

#include "bvh.glsl"

layout(local_size_x = 64) in;

#define MAX_CORNERS 8
// A convex polygon clipped by one plane gains at most one corner.
#define MAX_CLIPPED 9
#define PI 3.14159265358979
#define FIRST_RAYS 16u
#define CORNER_INSET 1e-3

struct GatherPoint {
    vec3 p;
    uint patch_id;
    vec3 n;
    // The point's random stream (with the push constant's seed).
    uint stream;
};

struct GatherSource {
    vec4 corners[MAX_CORNERS];
    vec3 normal;
    uint patch_id;
    vec3 radiosity;
    uint rays;
    uint corner_count;
    uint early_out;
    uint pad0;
    uint pad1;
};

layout(set = 0, binding = 2, std430) readonly buffer Points { GatherPoint points[]; };
layout(set = 0, binding = 3, std430) readonly buffer Sources { GatherSource sources[]; };
layout(set = 0, binding = 4, std430) writeonly buffer Gathered { vec4 gathered[]; };

layout(push_constant) uniform Push {
    uint point_count;
    uint source_count;
    uint node_count;
    float eps;
    uint seed;
} pc;

uint rng_state;

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1) (PCG-RXS-M-XS 32).
float next_float() {
    rng_state = rng_state * 747796405u + 2891336453u;
    uint s = rng_state;
    uint word = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    word = (word >> 22u) ^ word;
    return float(word >> 8u) * (1.0 / 16777216.0);
}

vec3 poly[MAX_CLIPPED];
uint poly_len;

// poly = the source's corners clipped to (x - p) . n >= 0 (Sutherland-Hodgman).
void clip_source(uint s, vec3 p, vec3 n) {
    uint k = min(sources[s].corner_count, uint(MAX_CORNERS));
    poly_len = 0u;
    for (uint i = 0u; i < k; i++) {
        vec3 a = sources[s].corners[i].xyz;
        vec3 b = sources[s].corners[(i + 1u) % k].xyz;
        float da = dot(a - p, n);
        float db = dot(b - p, n);
        if (da >= 0.0) {
            poly[poly_len++] = a;
        }
        if ((da >= 0.0) != (db >= 0.0)) {
            vec3 x = a + (b - a) * (da / (da - db));
            poly[poly_len++] = x - n * dot(x - p, n);
        }
    }
}

// The exact unoccluded form factor from (p, n) to source s; leaves the
// clipped polygon in poly.
float point_to_polygon(uint s, vec3 p, vec3 n) {
    uint k = min(sources[s].corner_count, uint(MAX_CORNERS));
    poly_len = 0u;
    if (k < 3u) {
        return 0.0;
    }
    vec3 pn = vec3(0.0);
    vec3 mid = vec3(0.0);
    for (uint i = 0u; i < k; i++) {
        vec3 a = sources[s].corners[i].xyz;
        pn += cross(a, sources[s].corners[(i + 1u) % k].xyz);
        mid += a;
    }
    mid /= float(k);
    float twice_area = length(pn);
    if (!(twice_area > 0.0) || isinf(twice_area) || dot(p - mid, pn) <= 0.0) {
        return 0.0;
    }
    clip_source(s, p, n);
    if (poly_len < 3u) {
        return 0.0;
    }
    float sum = 0.0;
    for (uint i = 0u; i < poly_len; i++) {
        vec3 gi = poly[i] - p;
        vec3 gj = poly[(i + 1u) % poly_len] - p;
        vec3 c = cross(gi, gj);
        float cl = length(c);
        if (cl <= 0.0) {
            continue;
        }
        sum += atan(cl, dot(gi, gj)) * dot(n, c) / cl;
    }
    return max(-sum / (2.0 * PI), 0.0);
}

// The fan of poly from its corner 0: cumulative area shares.
float cdf[MAX_CLIPPED - 2];

void fan_of_poly() {
    float total = 0.0;
    for (uint k = 1u; k + 1u < poly_len; k++) {
        total += length(cross(poly[k] - poly[0], poly[k + 1u] - poly[0]));
        cdf[k - 1u] = total;
    }
    for (uint k = 1u; k + 1u < poly_len; k++) {
        cdf[k - 1u] /= max(total, 1.17549435e-38);
    }
}

// The fan's point for (u, w) in the unit square, uniform in area.
vec3 fan_point(float u, float w) {
    uint tris = poly_len - 2u;
    uint k = 0u;
    while (k < tris && cdf[k] < u) {
        k++;
    }
    k = min(k, tris - 1u);
    float lo = k == 0u ? 0.0 : cdf[k - 1u];
    float uu = clamp((u - lo) / max(cdf[k] - lo, 1.17549435e-38), 0.0, 1.0);
    vec3 a = poly[0];
    vec3 b = poly[k + 1u];
    vec3 e = poly[k + 2u];
    float sq = sqrt(uu);
    return a + sq * ((b - a) + w * (e - b));
}

// (visible, total) kernel weight of `rays` stratified rays to the fan.
vec2 visible_weight(uint rays, uint s, GatherPoint g) {
    if (poly_len < 3u) {
        return vec2(0.0);
    }
    uint rows = uint(sqrt(float(rays)));
    while (rows > 1u && rays % rows != 0u) {
        rows--;
    }
    rows = max(rows, 1u);
    uint cols = rays / rows;
    vec3 ns = sources[s].normal;
    uvec2 skip = uvec2(g.patch_id, sources[s].patch_id);
    vec2 acc = vec2(0.0);
    for (uint r = 0u; r < rows; r++) {
        for (uint c = 0u; c < cols; c++) {
            float u = (float(r) + next_float()) / float(rows);
            float w = (float(c) + next_float()) / float(cols);
            vec3 x = fan_point(u, w);
            vec3 d = x - g.p;
            float r2 = dot(d, d);
            float cos_v = dot(g.n, d);
            float cos_s = -dot(ns, d);
            if (isnan(r2) || r2 <= 0.0 || cos_v <= 0.0 || cos_s <= 0.0) {
                continue;
            }
            float term = cos_v * cos_s / (r2 * r2);
            acc.y += term;
            if (bvh_visible(g.p, x, skip, pc.eps, pc.node_count)) {
                acc.x += term;
            }
        }
    }
    return acc;
}

// (seen, in front) of the source's corners, each a hair inside it.
uvec2 corners_visible(uint s, GatherPoint g) {
    uint k = min(sources[s].corner_count, uint(MAX_CORNERS));
    vec3 centre = vec3(0.0);
    for (uint i = 0u; i < k; i++) {
        centre += sources[s].corners[i].xyz;
    }
    centre /= float(max(k, 1u));
    uvec2 out_ = uvec2(0u);
    for (uint i = 0u; i < k; i++) {
        vec3 c = sources[s].corners[i].xyz;
        vec3 x = c + CORNER_INSET * (centre - c);
        vec3 d = x - g.p;
        if (dot(g.n, d) <= 0.0 || dot(sources[s].normal, d) >= 0.0) {
            continue;
        }
        out_.y++;
        if (bvh_visible(g.p, x, uvec2(g.patch_id, sources[s].patch_id), pc.eps, pc.node_count)) {
            out_.x++;
        }
    }
    return out_;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.point_count) {
        return;
    }
    GatherPoint g = points[i];
    rng_state = pcg_hash(pc.seed ^ pcg_hash(g.stream));
    vec3 sum = vec3(0.0);
    for (uint s = 0u; s < pc.source_count; s++) {
        float exact = point_to_polygon(s, g.p, g.n);
        if (isnan(exact) || exact <= 0.0) {
            continue;
        }
        fan_of_poly();
        uint rays = max(sources[s].rays, 1u);
        if (sources[s].early_out != 0u && rays > 2u * FIRST_RAYS) {
            vec2 first = visible_weight(FIRST_RAYS, s, g);
            if (first.y <= 0.0) {
                continue;
            }
            uvec2 corners = corners_visible(s, g);
            if ((first.x <= 0.0 && corners.x == 0u) || (first.x >= first.y && corners.x == corners.y)) {
                sum += sources[s].radiosity * (exact * (first.x / first.y));
                continue;
            }
        }
        vec2 all = visible_weight(rays, s, g);
        if (all.y > 0.0) {
            sum += sources[s].radiosity * (exact * (all.x / all.y));
        }
    }
    gathered[i] = vec4(sum, 0.0);
}
