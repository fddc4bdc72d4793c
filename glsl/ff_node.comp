#version 450
#extension GL_GOOGLE_include_directive : require
// Form factors from a shooting region (a node of the shooting hierarchy,
// src/solve/hierarchy.rs) to every receiver element: "exact x visibility".
//
// The hemicube at the region's centroid c has left F_hc(j) in ff[j]: the
// form factor from the point c to element j, with occlusion. Near the
// region (closer than NEAR_RADII of its radius) that point value is wrong
// for the region as a whole, by tens of percent for a wall meeting a
// shooting floor. There the form factor is rebuilt from two exact
// unoccluded point-to-polygon values (the closed form of
// formfactor::analytic::point_to_polygon):
//
//   F(region -> j) = (A_j / A_outline) * mean_q F(q -> outline) * V_j,
//   V_j = F_hc(j) / F(c -> j)   (the fraction of j that c sees, in [0, 1])
//
// q runs over the centres of j's sub-cells (halfway from j's centre to each
// corner), or is j's centre alone where j is small beside its distance to
// the region. A region's unshot light is not quite even: where the CPU gives
// its children's outlines and mean unshot radiosity (relative to the
// region's), F(q -> outline) becomes sum_k w_k F(q -> child k), so a
// receiver next to the dim end of a region gets less than one next to its
// bright end. Where the hemicube cannot resolve j (fewer than MIN_PIXELS of
// its pixels expected) V_j = 1: such a receiver (edge-on to c, or facing
// away from c but not from all of the region) is taken as unoccluded.
// Farther away the hemicube's own value stands (error O((r/d)^2)).
//
// The corrected row is then scaled (in shoot.comp) to the hemicube's row
// sum: the hemicube's total is right (every pixel counts once), only its
// spread over near receivers is not, so the shot conserves energy as an
// element shot does.

#include "shot_params.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 3, std430) buffer FormFactors { uint ff[]; };
// rgb: reflectance; w: area.
layout(set = 0, binding = 4, std430) readonly buffer Elements { vec4 reflectance_area[]; };
// Corners (xyz; unused ones repeat the last) and (unit normal, corner count).
struct Geometry {
    vec4 corner[4];
    vec4 normal_count;
};
layout(set = 0, binding = 7, std430) readonly buffer ElementGeometry { Geometry geometry[]; };
layout(set = 0, binding = 8, std430) readonly buffer Ranks { uint rank[]; };

const float PI = 3.14159265358979;
const float NEAR_RADII = 8.0;
const float MIN_PIXELS = 2.0;
// Receivers whose radius is under this share of their gap to the region
// integrate it at their centre alone.
const float SINGLE_POINT_GAP = 0.25;
// An outline of 8 corners clipped by one plane has at most 9.
const int MAX_CORNERS = 9;

// The unoccluded form factor from a differential area at p (unit normal n)
// to a convex polygon (counter-clockwise seen from its front; normal pn,
// centroid pc). 0 when p is not in front of it; the part behind p's
// tangent plane is clipped off.
float point_to_polygon(vec3 p, vec3 n, vec3 poly[MAX_CORNERS], int count, vec3 pn, vec3 pc) {
    if (dot(p - pc, pn) <= 0.0) {
        return 0.0;
    }
    vec3 clipped[MAX_CORNERS + 1];
    int m = 0;
    for (int i = 0; i < count; ++i) {
        vec3 a = poly[i];
        vec3 b = poly[(i + 1) % count];
        float da = dot(a - p, n);
        float db = dot(b - p, n);
        if (da >= 0.0) {
            clipped[m++] = a;
        }
        if ((da >= 0.0) != (db >= 0.0)) {
            vec3 x = a + (b - a) * (da / (da - db));
            clipped[m++] = x - n * dot(x - p, n);
        }
    }
    if (m < 3) {
        return 0.0;
    }
    float sum = 0.0;
    for (int i = 0; i < m; ++i) {
        vec3 gi = clipped[i] - p;
        vec3 gj = clipped[(i + 1) % m] - p;
        vec3 c = cross(gi, gj);
        float cl = length(c);
        if (cl > 0.0) {
            sum += atan(cl, dot(gi, gj)) * dot(n, c) / cl;
        }
    }
    return max(-sum / (2.0 * PI), 0.0);
}

// Row sums for energy conservation, in units of 2^-27 (ff >> 4, rounded):
// ff[element_count] the hemicube's, ff[element_count + 1] the corrected.
// Each workgroup adds its own total once.
shared uint group_hemicube[64];
shared uint group_corrected[64];

uint sum_unit(uint fixed_ff) {
    return (fixed_ff >> 4) + ((fixed_ff >> 3) & 1u);
}

// The corrected form factor of receiver j (fixed point), given the
// hemicube's.
uint corrected(uint j, uint hemicube_ff) {
    uint r = rank[j];
    if (r >= shot.shooter_ranks.x && r < shot.shooter_ranks.y) {
        return 0u;
    }
    Geometry g = geometry[j];
    int count = int(g.normal_count.w);
    vec3 nj = g.normal_count.xyz;
    vec3 element[MAX_CORNERS];
    vec3 cj = vec3(0.0);
    for (int k = 0; k < count; ++k) {
        element[k] = g.corner[k].xyz;
        cj += element[k];
    }
    cj /= float(count);
    vec3 c = shot.centre_radius.xyz;
    if (distance(cj, c) > NEAR_RADII * shot.centre_radius.w) {
        return hemicube_ff;
    }
    vec3 n = shot.normal_area.xyz;
    float f_centre = point_to_polygon(c, n, element, count, nj, cj);
    float visible = 1.0;
    if (f_centre * float(shot.hemicube_pixels) >= MIN_PIXELS) {
        visible = clamp(float(hemicube_ff) * FF_SCALE / f_centre, 0.0, 1.0);
    }
    if (visible <= 0.0) {
        return 0u;
    }
    // A receiver small beside its gap to the region takes the factor at
    // its centre (midpoint rule, error O((r_j / gap)^2)); only those close
    // to the region for their size average four sub-cells.
    float rj = 0.0;
    for (int k = 0; k < count; ++k) {
        rj = max(rj, distance(element[k], cj));
    }
    float gap = distance(cj, c) - shot.centre_radius.w;
    int points = rj < SINGLE_POINT_GAP * gap ? 1 : count;
    float exact = 0.0;
    int children = int(shot.child_count);
    for (int part = 0; part < max(children, 1); ++part) {
        int oc;
        float weight;
        vec3 outline[MAX_CORNERS];
        vec3 middle = vec3(0.0);
        if (children == 0) {
            oc = int(shot.outline_count);
            weight = 1.0;
            for (int k = 0; k < oc; ++k) {
                outline[k] = shot.outline[k].xyz;
            }
        } else {
            oc = int(shot.child_corners[part]);
            weight = shot.child_weight[part];
            for (int k = 0; k < oc; ++k) {
                outline[k] = shot.child_outline[4 * part + k].xyz;
            }
        }
        if (weight <= 0.0 || oc < 3) {
            continue;
        }
        for (int k = 0; k < oc; ++k) {
            middle += outline[k];
        }
        middle /= float(oc);
        if (points == 1) {
            exact += weight * point_to_polygon(cj, nj, outline, oc, n, middle);
            continue;
        }
        float sum = 0.0;
        for (int k = 0; k < count; ++k) {
            vec3 q = cj + 0.5 * (element[k] - cj);
            sum += point_to_polygon(q, nj, outline, oc, n, middle);
        }
        exact += weight * sum / float(count);
    }
    float f = reflectance_area[j].w / shot.normal_area.w * exact * visible;
    return uint(clamp(round(f / FF_SCALE), 0.0, 4294967040.0));
}

void main() {
    if (shot.mode != 1u) {
        return;
    }
    uint j = gl_GlobalInvocationID.x;
    uint lane = gl_LocalInvocationID.x;
    uint before = 0u;
    uint after = 0u;
    if (j < shot.element_count) {
        before = ff[j];
        after = corrected(j, before);
        ff[j] = after;
    }
    group_hemicube[lane] = sum_unit(before);
    group_corrected[lane] = sum_unit(after);
    barrier();
    for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lane < stride) {
            group_hemicube[lane] += group_hemicube[lane + stride];
            group_corrected[lane] += group_corrected[lane + stride];
        }
        barrier();
    }
    if (lane == 0u) {
        atomicAdd(ff[shot.element_count], group_hemicube[0]);
        atomicAdd(ff[shot.element_count + 1u], group_corrected[0]);
    }
}
