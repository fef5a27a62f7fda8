/* A hit's position, normals and base colour (before textures) from its
 * triangle, barycentrics and material, its texture coordinates, its
 * pixel's footprint in them and its normal bent by a normal map, in plain
 * C that nvcc compiles too (RTK_HD):
 * scene.c's rtk_surface_at, normalmap.c and device programs
 * (plugins/integrators/device_programs.h) share it, so all see the same
 * surface. */
#ifndef RTK_KERNEL_SURFACE_GEOM_H
#define RTK_KERNEL_SURFACE_GEOM_H

#include "texture.h"

#include <rtk/math.h>
#include <rtk/ray.h>

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

/* Texture coordinates at (u, v) of a triangle whose corners' (u, v) pairs
 * are t (6 floats), then through the 2x3 transform m when transformed
 * (KHR_texture_transform): rtk_tex_map_uv. */
RTK_HD static inline rtk_vec2 rtk_corner_uv(const float *t, int transformed, const float *m, float u, float v)
{
    float w = 1.0f - u - v;
    float tu = w * t[0] + u * t[2] + v * t[4], tv = w * t[1] + u * t[3] + v * t[5];
    rtk_vec2 r;
    r.x = transformed ? m[0] * tu + m[1] * tv + m[2] : tu;
    r.y = transformed ? m[3] * tu + m[4] * tv + m[5] : tv;
    return r;
}

RTK_HD static inline double rtk_dot3d(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Where the ray (o, d) meets the plane through p with normal n, minus p;
 * 0 when it runs parallel to the plane or the point is not finite. */
RTK_HD static inline int rtk_plane_offset(rtk_vec3 p, rtk_vec3 n, rtk_vec3 o, rtk_vec3 d, double out[3])
{
    const double pd[3] = {p.x, p.y, p.z}, nd[3] = {n.x, n.y, n.z}, od[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    const double den = rtk_dot3d(nd, dd);
    if (den == 0.0)
        return 0;
    const double po[3] = {pd[0] - od[0], pd[1] - od[1], pd[2] - od[2]};
    const double t = rtk_dot3d(nd, po) / den;
    for (int k = 0; k < 3; k++)
        out[k] = od[k] + t * dd[k] - pd[k];
    return isfinite(out[0]) && isfinite(out[1]) && isfinite(out[2]);
}

/* Change of the barycentrics of vertices 1 and 2 of triangle (a, b, c)
 * for a point moving by dp in its plane (least squares on the edges). */
RTK_HD static inline int rtk_bary_change(rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, const double dp[3], double db[2])
{
    const double e1[3] = {(double)b.x - a.x, (double)b.y - a.y, (double)b.z - a.z};
    const double e2[3] = {(double)c.x - a.x, (double)c.y - a.y, (double)c.z - a.z};
    const double g11 = rtk_dot3d(e1, e1), g12 = rtk_dot3d(e1, e2), g22 = rtk_dot3d(e2, e2);
    const double det = g11 * g22 - g12 * g12;
    if (!(det > 0.0))
        return 0;
    const double r1 = rtk_dot3d(e1, dp), r2 = rtk_dot3d(e2, dp);
    db[0] = (g22 * r1 - g12 * r2) / det;
    db[1] = (g11 * r2 - g12 * r1) / det;
    return isfinite(db[0]) && isfinite(db[1]);
}

/* The uv footprint (Igehy 1999) at p on triangle (a, b, c), normal n,
 * whose corners' (u, v) pairs are t (6 floats), for differentials d: the
 * differential rays meet the triangle's plane at p + dp/dx and p + dp/dy,
 * and those offsets in barycentrics give du/dx, dv/dx, du/dy, dv/dy. 0
 * when it cannot be measured. */
RTK_HD static inline int rtk_uv_footprint_at(const float *t, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, rtk_vec3 p,
                                             rtk_vec3 n, const rtk_ray_differential *d, rtk_uv_footprint *fp)
{
    double dpx[3], dpy[3], bx[2], by[2];
    if (!rtk_plane_offset(p, n, d->rx_org, d->rx_dir, dpx) || !rtk_plane_offset(p, n, d->ry_org, d->ry_dir, dpy) ||
        !rtk_bary_change(a, b, c, dpx, bx) || !rtk_bary_change(a, b, c, dpy, by))
        return 0;
    const double du1 = (double)t[2] - t[0], du2 = (double)t[4] - t[0];
    const double dv1 = (double)t[3] - t[1], dv2 = (double)t[5] - t[1];
    fp->dudx = (float)(bx[0] * du1 + bx[1] * du2);
    fp->dvdx = (float)(bx[0] * dv1 + bx[1] * dv2);
    fp->dudy = (float)(by[0] * du1 + by[1] * du2);
    fp->dvdy = (float)(by[0] * dv1 + by[1] * dv2);
    return isfinite(fp->dudx) && isfinite(fp->dvdx) && isfinite(fp->dudy) && isfinite(fp->dvdy);
}

/* Footprint fp through the 2x3 transform m when transformed (its linear
 * part: rtk_corner_uv's mapping of a change). */
RTK_HD static inline rtk_uv_footprint rtk_uv_footprint_mapped(const rtk_uv_footprint *fp, int transformed,
                                                              const float *m)
{
    rtk_uv_footprint r = *fp;
    if (transformed) {
        r.dudx = m[0] * fp->dudx + m[1] * fp->dvdx;
        r.dvdx = m[3] * fp->dudx + m[4] * fp->dvdx;
        r.dudy = m[0] * fp->dudy + m[1] * fp->dvdy;
        r.dvdy = m[3] * fp->dudy + m[4] * fp->dvdy;
    }
    return r;
}

/* Shading normal *ns bent by a tangent-space normal map's texel (what
 * normalmap.c documents): the tangent frame from the triangle's corners
 * p0, p1, p2 and their texture coordinates in the map's own mapping (t, 6
 * floats), made orthonormal around *ns. 0 when the triangle has no uv
 * parametrisation or the bent normal is degenerate (*ns unchanged). */
RTK_HD static inline int rtk_bend_normal(rtk_vec3 p0, rtk_vec3 p1, rtk_vec3 p2, const float *t, const float *texel,
                                         rtk_vec3 *ns)
{
    rtk_vec3 e1 = rtk_vec3_sub(p1, p0), e2 = rtk_vec3_sub(p2, p0);
    float du1 = t[2] - t[0], dv1 = t[3] - t[1], du2 = t[4] - t[0], dv2 = t[5] - t[1];
    float det = du1 * dv2 - du2 * dv1;
    if (!(fabsf(det) > 0.0f) || !isfinite(det))
        return 0;
    float r = 1.0f / det;
    rtk_vec3 tangent = rtk_vec3_scale(rtk_vec3_sub(rtk_vec3_scale(e1, dv2), rtk_vec3_scale(e2, dv1)), r);
    /* -dp/dv: towards the top of the image. */
    rtk_vec3 bitangent = rtk_vec3_scale(rtk_vec3_sub(rtk_vec3_scale(e1, du2), rtk_vec3_scale(e2, du1)), r);
    rtk_vec3 n = *ns;
    tangent = rtk_vec3_sub(tangent, rtk_vec3_scale(n, rtk_vec3_dot(n, tangent)));
    float tl = rtk_vec3_length(tangent);
    if (!(tl > 0.0f) || !isfinite(tl))
        return 0;
    tangent = rtk_vec3_scale(tangent, 1.0f / tl);
    /* Handedness from the uv mapping (mirrored uvs flip it). */
    float hand = rtk_vec3_dot(rtk_vec3_cross(n, tangent), bitangent) < 0.0f ? -1.0f : 1.0f;
    bitangent = rtk_vec3_scale(rtk_vec3_cross(n, tangent), hand);
    float x = 2.0f * texel[0] - 1.0f, y = 2.0f * texel[1] - 1.0f, z = 2.0f * texel[2] - 1.0f;
    rtk_vec3 bent = rtk_vec3_add(rtk_vec3_add(rtk_vec3_scale(tangent, x), rtk_vec3_scale(bitangent, y)),
                                 rtk_vec3_scale(n, z));
    float bl = rtk_vec3_length(bent);
    if (!(bl > 0.0f) || !isfinite(bl))
        return 0;
    *ns = rtk_vec3_scale(bent, 1.0f / bl);
    return 1;
}

#endif
