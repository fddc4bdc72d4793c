#version 450
#extension GL_GOOGLE_include_directive : require
// Progressive refinement shot (thesis fig. 8, lines 8-12), one invocation per
// receiver j: dB_j = rho_j * F_ij * A_i / A_j * dB_i, added to the receiver's
// radiosity and unshot radiosity. The shooter's unshot radiosity is zeroed.

#include "shot_params.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 3, std430) readonly buffer FormFactors { uint ff[]; };
// rgb: reflectance rho; w: area.
layout(set = 0, binding = 4, std430) readonly buffer Elements { vec4 reflectance_area[]; };
layout(set = 0, binding = 5, std430) buffer Radiosity { vec4 radiosity[]; };
layout(set = 0, binding = 6, std430) buffer Unshot { vec4 unshot[]; };

void main() {
    uint j = gl_GlobalInvocationID.x;
    if (j >= shot.element_count) {
        return;
    }
    if (j == shot.shooter) {
        unshot[j] = vec4(0.0);
        return;
    }
    uint fixed_ff = ff[j];
    if (fixed_ff == 0u) {
        return;
    }
    float form_factor = float(fixed_ff) * FF_SCALE;
    vec4 ra = reflectance_area[j];
    vec3 delta = ra.rgb * shot.shooter_unshot.rgb * (form_factor * shot.shooter_unshot.w / ra.w);
    radiosity[j].rgb += delta;
    unshot[j].rgb += delta;
}
