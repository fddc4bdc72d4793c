// Per-shot parameters, written by the CPU before each submission
// (std140; mirrors `ShotParams` in src/gpu/hemicube.rs).
layout(set = 0, binding = 0, std140) uniform ShotParams {
    // World -> clip for the five hemicube faces: top, then the four sides.
    mat4 face_view_proj[5];
    // rgb: the shooter's unshot radiosity; w: the shooter's area.
    vec4 shooter_unshot;
    uint shooter;
    uint element_count;
} shot;

// Item-buffer value of pixels that show no receiver (background or a back face).
const uint NO_ELEMENT = 0xFFFFFFFFu;

// Form factors are accumulated as fixed point: F = ff / 2^31.
const float FF_SCALE = 1.0 / 2147483648.0;
