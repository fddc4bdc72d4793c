#version 450
// The final image of a scene without textures: radiance per vertex only
// (render.frag's texture inputs cost llvmpipe 0.7 s on the Cornell box).
// Surfaces emit and reflect from their front only: a back face shows black.

layout(location = 0) in vec3 in_radiance;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = gl_FrontFacing ? vec4(in_radiance, 1.0) : vec4(0.0, 0.0, 0.0, 1.0);
}
