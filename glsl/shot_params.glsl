// Per-shot parameters, written by the CPU before each submission, one
// slot per shooter of a batch (a dynamic uniform buffer offset picks it)
// (std140; mirrors `ShotParams` in src/gpu/shooting/params.rs; the layout,
// binding and constants are checked by src/gpu/contracts).
layout(set = 0, binding = 0, std140) uniform ShotParams {
    // World -> clip for the five hemicube faces: top, then the four sides.
    mat4 face_view_proj[5];
    // The area of the shooter's elements.
    float shooter_area;
    // The shooter's place in its batch: where shot_light.comp leaves its
    // unshot light for shoot.comp.
    uint slot;
    // This shot's hemicube: top-face resolution (the item buffer uses the
    // atlas's top-left res x 3 res pixels) and the first of its per-pixel
    // weights in the weight table (one table per resolution).
    uint hemicube_res;
    uint weight_offset;
    uint element_count;
    // Form factors: 0 = the hemicube's own (element shots), 1 = exact x
    // visibility from a region's outline (glsl/ff_node.comp).
    uint mode;
    // Item-buffer pixels of this shot's hemicube (for ff_node).
    uint hemicube_pixels;
    uint _pad0;
    // The shooter's elements: ranks [x, y) (the shooting hierarchy's order).
    uvec4 shooter_ranks;
    // The shooting region (mode 1): outline corners (xyz), counter-clockwise
    // seen from the front; how many in outline_count.
    vec4 outline[8];
    // xyz: the hemicube's position (the elements' centroid); w: the
    // outline's radius around it.
    vec4 centre_radius;
    // xyz: the region's unit normal; w: the outline's area.
    vec4 normal_area;
    uint outline_count;
    // How many children describe the region's unshot light (0: take it as
    // even); their corner counts; their outlines, 4 corners each; and each
    // one's mean unshot radiosity over the region's.
    uint child_count;
    uvec4 child_corners;
    vec4 child_outline[16];
    vec4 child_weight;
} shot;

// Item-buffer value of pixels that show no receiver (background or a back face).
const uint NO_ELEMENT = 0xFFFFFFFFu;

// Form factors are accumulated as fixed point: F = ff / 2^31.
const float FF_SCALE = 1.0 / 2147483648.0;
