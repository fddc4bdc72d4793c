#version 450
// Polygons block light from both sides: no gl_FrontFacing test here.

layout(location = 0) flat in uint in_polygon;
layout(location = 0) out uint out_item;

void main() {
    out_item = in_polygon;
}
