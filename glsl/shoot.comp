#version 450
#extension GL_GOOGLE_include_directive : require
// Progressive refinement shot (thesis fig. 8, lines 8-12), one invocation per
// receiver j: dB_j = rho_j * F_ij * A_i / A_j * dB_i, added to the receiver's
// radiosity and unshot radiosity. dB_i is the shooter's unshot radiosity as
// shot_light.comp read it just before (its mean over the shooter's
// elements); every element of the shooter (ranks shooter_ranks.x .. y) is
// zeroed, so the power shot is exactly the power removed.

#include "shot_params.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 3, std430) readonly buffer FormFactors { uint ff[]; };
// rgb: reflectance rho; w: area.
layout(set = 0, binding = 4, std430) readonly buffer Elements { vec4 reflectance_area[]; };
layout(set = 0, binding = 5, std430) buffer Radiosity { vec4 radiosity[]; };
layout(set = 0, binding = 6, std430) buffer Unshot { vec4 unshot[]; };
// Position of every element in the shooting hierarchy's order.
layout(set = 0, binding = 8, std430) readonly buffer Ranks { uint rank[]; };
// Per shooter of the batch: its mean unshot radiosity (shot_light.comp).
layout(set = 0, binding = 9, std430) readonly buffer ShotLight { vec4 shot_light[]; };

void main() {
    uint j = gl_GlobalInvocationID.x;
    if (j >= shot.element_count) {
        return;
    }
    uint r = rank[j];
    if (r >= shot.shooter_ranks.x && r < shot.shooter_ranks.y) {
        unshot[j] = vec4(0.0);
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
    vec3 light = shot_light[shot.slot].rgb;
    vec3 delta = ra.rgb * light * (form_factor * shot.shooter_area / ra.w);
    radiosity[j].rgb += delta;
    unshot[j].rgb += delta;
}
