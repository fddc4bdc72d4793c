#version 450
// Final image: the lit mesh with per-vertex radiance (Gouraud).

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_radiance;

layout(push_constant) uniform Camera {
    mat4 view_proj;
} camera;

layout(location = 0) out vec3 out_radiance;

void main() {
    gl_Position = camera.view_proj * vec4(in_position, 1.0);
    out_radiance = in_radiance;
}
