#version 450
#extension GL_GOOGLE_include_directive : require
// Faces are one-sided for reception but block light from both sides: a back
// face still wins the depth test, it just receives nothing.

#include "shot_params.glsl"

layout(location = 0) flat in uint in_element;
layout(location = 0) out uint out_item;

void main() {
    out_item = gl_FrontFacing ? in_element : NO_ELEMENT;
}
