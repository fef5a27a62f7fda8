/* A hit's position, normals and base colour (before textures) from its
 * triangle, barycentrics and material, in plain C that nvcc compiles too
 * (RTK_HD): scene.c's rtk_surface_at and device programs
 * (plugins/integrators/device_programs.h) share it, so both see the same
 * surface. */
#ifndef RTK_KERNEL_SURFACE_GEOM_H
#define RTK_KERNEL_SURFACE_GEOM_H

#include <rtk/math.h>

#include <math.h>

/* Point (u, v) of triangle (a, b, c), hit along dir: p; the geometric
 * normal ng turned towards the ray (front 1 when it already faced it);
 * the shading normal ns, interpolated from the corners' normals (9
 * floats, NULL for none) and turned to ng's side, else ng where they
 * are missing or degenerate. */
RTK_HD static inline void rtk_surface_geometry(rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, const float *normals, float u,
                                               float v, rtk_vec3 dir, rtk_vec3 *p, rtk_vec3 *ng, rtk_vec3 *ns,
                                               int *front)
{
    float w = 1.0f - u - v;
    *p = rtk_vec3_make(w * a.x + u * b.x + v * c.x, w * a.y + u * b.y + v * c.y, w * a.z + u * b.z + v * c.z);
    rtk_vec3 n = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a)));
    *front = rtk_vec3_dot(n, dir) < 0.0f;
    if (!*front)
        n = rtk_vec3_neg(n);
    *ng = n;
    *ns = n;
    if (!normals)
        return;
    const float *k = normals;
    rtk_vec3 s = rtk_vec3_normalize(rtk_vec3_make(w * k[0] + u * k[3] + v * k[6], w * k[1] + u * k[4] + v * k[7],
                                                  w * k[2] + u * k[5] + v * k[8]));
    if (rtk_vec3_dot(s, s) > 0.0f && isfinite(s.x) && isfinite(s.y) && isfinite(s.z))
        *ns = rtk_vec3_dot(s, n) < 0.0f ? rtk_vec3_neg(s) : s;
}

/* The RGBA vertex colour at (u, v) of a triangle's 12 corner values. */
RTK_HD static inline void rtk_corner_colors(const float *c, float u, float v, float rgba[4])
{
    float w = 1.0f - u - v;
    for (int k = 0; k < 4; k++)
        rgba[k] = w * c[k] + u * c[4 + k] + v * c[8 + k];
}

/* A hit's base colour before textures: its material's factor (base) times
 * the vertex colour's RGB at (u, v) when the triangle has colours (12
 * floats, NULL for none). */
RTK_HD static inline rtk_rgb rtk_surface_base_color(rtk_rgb base, const float *colors, float u, float v)
{
    if (!colors)
        return base;
    float vc[4];
    rtk_corner_colors(colors, u, v, vc);
    return rtk_rgb_mul(base, rtk_rgb_make(vc[0], vc[1], vc[2]));
}

#endif
