#version 450
#extension GL_GOOGLE_include_directive : require
// One segment per invocation: whether it is unblocked, one bit per segment
// (bit i % 32 of word i / 32). Mirrors src/gpu/rays/occlusion.rs.

#include "bvh.glsl"

layout(local_size_x = 64) in;

struct Segment {
    vec3 a;
    uint skip0;
    vec3 b;
    uint skip1;
};

layout(set = 0, binding = 2, std430) readonly buffer Segments { Segment segments[]; };
layout(set = 0, binding = 3, std430) writeonly buffer Visible { uint visible_bits[]; };

layout(push_constant) uniform Push {
    uint segment_count;
    uint node_count;
    float eps;
} pc;

// This workgroup's 64 bits, gathered before one write per word.
shared uint words[2];

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint local = gl_LocalInvocationID.x;
    if (local < 2u) {
        words[local] = 0u;
    }
    barrier();
    if (i < pc.segment_count) {
        Segment s = segments[i];
        if (bvh_visible(s.a, s.b, uvec2(s.skip0, s.skip1), pc.eps, pc.node_count)) {
            atomicOr(words[local / 32u], 1u << (local % 32u));
        }
    }
    barrier();
    uint word = gl_WorkGroupID.x * 2u + local;
    if (local < 2u && word * 32u < pc.segment_count) {
        visible_bits[word] = words[local];
    }
}
