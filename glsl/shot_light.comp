#version 450
#extension GL_GOOGLE_include_directive : require
// The unshot radiosity a shooter carries, read on the GPU at the moment it
// shoots: the mean over its elements (ranks shooter_ranks.x .. y) of their
// unshot radiosity, area-weighted, into shot_light[slot] for shoot.comp.
//
// The CPU picks shooters from unshot radiosity it read back a batch or two
// earlier (it prepares the next batch while the GPU runs this one); since
// then earlier shots may have sent a shooter more light. Reading the light
// here, right before the shot, makes every shot carry all of it and the
// shooting pass zero it: energy is conserved however stale the pick.
//
// One workgroup: a shooter has at most a few thousand elements.

#include "shot_params.glsl"

layout(local_size_x = 64) in;

// rgb: reflectance; w: area.
layout(set = 0, binding = 4, std430) readonly buffer Elements { vec4 reflectance_area[]; };
layout(set = 0, binding = 6, std430) readonly buffer Unshot { vec4 unshot[]; };
// Per shooter of the batch: rgb its mean unshot radiosity.
layout(set = 0, binding = 9, std430) writeonly buffer ShotLight { vec4 shot_light[]; };
// The element of every rank (the inverse of Ranks).
layout(set = 0, binding = 10, std430) readonly buffer Order { uint element_of_rank[]; };

shared vec3 partial[64];

void main() {
    uint lane = gl_LocalInvocationID.x;
    vec3 sum = vec3(0.0);
    for (uint r = shot.shooter_ranks.x + lane; r < shot.shooter_ranks.y; r += 64u) {
        uint e = element_of_rank[r];
        sum += unshot[e].rgb * reflectance_area[e].w;
    }
    partial[lane] = sum;
    barrier();
    for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lane < stride) {
            partial[lane] += partial[lane + stride];
        }
        barrier();
    }
    if (lane == 0u) {
        shot_light[shot.slot] = vec4(partial[0] / max(shot.shooter_area, 1e-30), 0.0);
    }
}
