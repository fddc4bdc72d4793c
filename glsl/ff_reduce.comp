#version 450
#extension GL_GOOGLE_include_directive : require
// Sums delta form factors per element: each item-buffer pixel adds its
// precomputed fixed-point weight to the element it shows. Integer atomics
// make the sum exact and independent of execution order.

#include "shot_params.glsl"

layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D item_buffer;
layout(set = 0, binding = 2, std430) readonly buffer Weights { uint weight[]; };
layout(set = 0, binding = 3, std430) buffer FormFactors { uint ff[]; };

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(item_buffer);
    if (p.x >= size.x || p.y >= size.y) {
        return;
    }
    uint element = imageLoad(item_buffer, p).r;
    if (element == NO_ELEMENT || element >= shot.element_count) {
        return;
    }
    atomicAdd(ff[element], weight[p.y * size.x + p.x]);
}
