#version 450
// Discontinuity-meshing item buffer: every polygon seen from one emitter
// vertex through a frustum fitted to one target polygon.

layout(location = 0) in vec3 in_position;
layout(location = 1) in uint in_polygon;

layout(push_constant) uniform Tile {
    mat4 view_proj;
} tile;

layout(location = 0) flat out uint out_polygon;

void main() {
    gl_Position = tile.view_proj * vec4(in_position, 1.0);
    out_polygon = in_polygon;
}
