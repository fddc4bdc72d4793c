#version 450
// Final image: the lit mesh with per-vertex radiance (Gouraud). On a
// textured surface `in_reflected` is the part of the radiance the texture
// multiplies (Kd x irradiance / pi over the texture's mean), at `in_uv`.

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_radiance;
layout(location = 2) in vec3 in_reflected;
layout(location = 3) in vec2 in_uv;
layout(location = 4) in uint in_texture;

layout(push_constant) uniform Camera {
    mat4 view_proj;
} camera;

layout(location = 0) out vec3 out_radiance;
layout(location = 1) out vec3 out_reflected;
layout(location = 2) out vec2 out_uv;
layout(location = 3) flat out uint out_texture;

void main() {
    gl_Position = camera.view_proj * vec4(in_position, 1.0);
    out_radiance = in_radiance;
    out_reflected = in_reflected;
    out_uv = in_uv;
    out_texture = in_texture;
}
