#version 450
#extension GL_GOOGLE_include_directive : require
// One ray per invocation: the nearest patch it meets and at what t, patch
// `skip` ignored (Occluders::first_hit_beyond). Mirrors
// src/gpu/rays/first_hit.rs.

#include "bvh.glsl"

layout(local_size_x = 64) in;

struct Ray {
    vec3 a;
    uint skip;
    vec3 d;
    float tmin;
};

struct Hit {
    float t;
    uint patch_id;
};

layout(set = 0, binding = 2, std430) readonly buffer Rays { Ray rays[]; };
layout(set = 0, binding = 3, std430) writeonly buffer Hits { Hit hits[]; };

layout(push_constant) uniform Push {
    uint ray_count;
    uint node_count;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.ray_count) {
        return;
    }
    Ray r = rays[i];
    uint patch_id;
    float t = bvh_first_hit(r.a, r.d, r.tmin, r.skip, pc.node_count, patch_id);
    hits[i] = Hit(t, patch_id);
}
