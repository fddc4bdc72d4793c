#version 450
// Surfaces emit and reflect from their front only: a back face shows black.
// A textured one shows radiance + reflected x texture(uv): the texture
// sampled as `scene::Texture::sample` does (sRGB texels decoded to linear,
// bilinear between texel centres, repeated or clamped, v = 0 at the
// bottom row).

layout(location = 0) in vec3 in_radiance;
layout(location = 1) in vec3 in_reflected;
layout(location = 2) in vec2 in_uv;
layout(location = 3) flat in uint in_texture;
layout(location = 0) out vec4 out_color;

struct TextureInfo {
    uint first;   // index of its top-left texel in `texels`
    uint width;
    uint height;
    uint clamped; // 1: -clamp on
    vec2 scale;   // uv * scale + shift
    vec2 shift;
};

layout(std430, set = 0, binding = 0) readonly buffer Infos {
    TextureInfo infos[];
};
// RGBA8 sRGB, red in the low byte, top row first.
layout(std430, set = 0, binding = 1) readonly buffer Texels {
    uint texels[];
};

const uint NO_TEXTURE = 0xffffffffu;

vec3 decode(uint c) {
    vec3 s = vec3(c & 255u, (c >> 8) & 255u, (c >> 16) & 255u) / 255.0;
    vec3 low = s / 12.92;
    vec3 high = pow((s + 0.055) / 1.055, vec3(2.4));
    return mix(low, high, greaterThan(s, vec3(0.04045)));
}

// Texel column or row `i` (a whole number, as a float) of `n`.
uint wrap(float i, uint n, bool clamped) {
    float m = float(n);
    float w = clamped ? clamp(i, 0.0, m - 1.0) : i - m * floor(i / m);
    return min(uint(w), n - 1u);
}

vec3 sample_texture(TextureInfo t, vec2 uv) {
    uv = uv * t.scale + t.shift;
    vec2 p = vec2(uv.x * float(t.width), (1.0 - uv.y) * float(t.height)) - 0.5;
    vec2 f = floor(p);
    vec2 w = p - f;
    bool c = t.clamped != 0u;
    uint x0 = wrap(f.x, t.width, c);
    uint x1 = wrap(f.x + 1.0, t.width, c);
    uint y0 = wrap(f.y, t.height, c);
    uint y1 = wrap(f.y + 1.0, t.height, c);
    vec3 a = decode(texels[t.first + y0 * t.width + x0]);
    vec3 b = decode(texels[t.first + y0 * t.width + x1]);
    vec3 d = decode(texels[t.first + y1 * t.width + x0]);
    vec3 e = decode(texels[t.first + y1 * t.width + x1]);
    return mix(mix(a, b, w.x), mix(d, e, w.x), w.y);
}

void main() {
    if (!gl_FrontFacing) {
        out_color = vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    vec3 radiance = in_radiance;
    if (in_texture != NO_TEXTURE) {
        radiance += in_reflected * sample_texture(infos[in_texture], in_uv);
    }
    out_color = vec4(radiance, 1.0);
}
