#version 450
#extension GL_GOOGLE_include_directive : require
// Progressive refinement shot (thesis fig. 8, lines 8-12), one invocation per
// receiver j: dB_j = rho_j * F_ij * A_i / A_j * dB_i, added to the receiver's
// radiosity and unshot radiosity. The shooter's unshot radiosity is zeroed
// (every element of a shooting region: ranks shooter_ranks.x .. y), or in a
// batch reduced by what it shoots.

#include "shot_params.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 3, std430) readonly buffer FormFactors { uint ff[]; };
// rgb: reflectance rho; w: area.
layout(set = 0, binding = 4, std430) readonly buffer Elements { vec4 reflectance_area[]; };
layout(set = 0, binding = 5, std430) buffer Radiosity { vec4 radiosity[]; };
layout(set = 0, binding = 6, std430) buffer Unshot { vec4 unshot[]; };
// Position of every element in the shooting hierarchy's order.
layout(set = 0, binding = 8, std430) readonly buffer Ranks { uint rank[]; };
// Unshot radiosity when the batch was picked (subtract_snapshot only).
layout(set = 0, binding = 9, std430) readonly buffer Snapshot { vec4 snapshot[]; };

void main() {
    uint j = gl_GlobalInvocationID.x;
    if (j >= shot.element_count) {
        return;
    }
    uint r = rank[j];
    if (r >= shot.shooter_ranks.x && r < shot.shooter_ranks.y) {
        // Alone in its submission, a shooter gives away all its unshot
        // radiosity. One of a batch gives away what it held when the batch
        // was picked (the snapshot), which is what its shot carries, and
        // keeps what earlier shooters of the batch sent it since: the
        // batch's shooters are disjoint, so each element loses its snapshot
        // at most once and never goes below zero.
        unshot[j] = shot.subtract_snapshot != 0u ? unshot[j] - snapshot[j] : vec4(0.0);
        return;
    }
    uint fixed_ff = ff[j];
    if (fixed_ff == 0u) {
        return;
    }
    float form_factor = float(fixed_ff) * FF_SCALE;
    if (shot.mode == 1u) {
        // A region shot: scale the corrected row to the hemicube's sum
        // (ff_node.comp), so that it conserves energy.
        uint hemicube_sum = ff[shot.element_count];
        uint corrected_sum = ff[shot.element_count + 1u];
        form_factor *= corrected_sum > 0u ? float(hemicube_sum) / float(corrected_sum) : 0.0;
    }
    vec4 ra = reflectance_area[j];
    vec3 delta = ra.rgb * shot.shooter_unshot.rgb * (form_factor * shot.shooter_unshot.w / ra.w);
    radiosity[j].rgb += delta;
    unshot[j].rgb += delta;
}
