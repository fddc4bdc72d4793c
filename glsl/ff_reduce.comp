#version 450
#extension GL_GOOGLE_include_directive : require
// Sums delta form factors per element: each item-buffer pixel adds its
// precomputed fixed-point weight (the table of this shot's resolution) to
// the element it shows. Integer atomics
// make the sum exact and independent of execution order.
//
// Neighbouring pixels mostly show the same element, so each invocation walks
// a run of RUN pixels along a row and issues one atomic per change of
// element instead of one per pixel (contention on a single address is what
// makes per-pixel atomics slow).

#include "shot_params.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D item_buffer;
layout(set = 0, binding = 2, std430) readonly buffer Weights { uint weight[]; };
layout(set = 0, binding = 3, std430) buffer FormFactors { uint ff[]; };

const int RUN = 16;

void flush(uint element, uint sum) {
    if (element != NO_ELEMENT && element < shot.element_count && sum != 0u) {
        atomicAdd(ff[element], sum);
    }
}

void main() {
    // This shot's hemicube fills the atlas's top-left res x 3 res pixels.
    int res = int(shot.hemicube_res);
    ivec2 size = ivec2(res, 3 * res);
    int runs_per_row = (size.x + RUN - 1) / RUN;
    int run = int(gl_GlobalInvocationID.x);
    int y = run / runs_per_row;
    if (y >= size.y) {
        return;
    }
    int x0 = (run % runs_per_row) * RUN;
    int x1 = min(x0 + RUN, size.x);
    uint current = NO_ELEMENT;
    uint sum = 0u;
    for (int x = x0; x < x1; ++x) {
        uint element = imageLoad(item_buffer, ivec2(x, y)).r;
        if (element != current) {
            flush(current, sum);
            current = element;
            sum = 0u;
        }
        sum += weight[shot.weight_offset + uint(y * size.x + x)];
    }
    flush(current, sum);
}
