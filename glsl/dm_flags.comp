#version 450
// Marks, per tile of the visibility atlas, every polygon id that shows in
// it: one bit per (tile, polygon) in `flags`.

layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 0, r32ui) uniform readonly uimage2D item_buffer;
layout(set = 0, binding = 1, std430) buffer Flags { uint flags[]; };

layout(push_constant) uniform Layout {
    uint tile_res;
    uint tiles_x;
    uint tile_count;
    uint words_per_tile;
} atlas;

const uint NO_POLYGON = 0xFFFFFFFFu;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(item_buffer);
    if (p.x >= size.x || p.y >= size.y) {
        return;
    }
    uint tile = uint(p.y) / atlas.tile_res * atlas.tiles_x + uint(p.x) / atlas.tile_res;
    if (tile >= atlas.tile_count) {
        return;
    }
    uint polygon = imageLoad(item_buffer, p).r;
    if (polygon == NO_POLYGON || polygon / 32u >= atlas.words_per_tile) {
        return;
    }
    uint word = tile * atlas.words_per_tile + polygon / 32u;
    uint bit = 1u << (polygon % 32u);
    // Most pixels repeat a bit already set: read first, write rarely.
    if ((flags[word] & bit) == 0u) {
        atomicOr(flags[word], bit);
    }
}
