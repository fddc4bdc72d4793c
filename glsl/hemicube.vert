#version 450
#extension GL_GOOGLE_include_directive : require
// Item buffer for one hemicube face: every element's triangles, carrying
// the element id to the fragment stage.

#include "shot_params.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in uint in_element;

layout(push_constant) uniform Face {
    uint face;
} pc;

layout(location = 0) flat out uint out_element;

void main() {
    gl_Position = shot.face_view_proj[pc.face] * vec4(in_position, 1.0);
    out_element = in_element;
}
