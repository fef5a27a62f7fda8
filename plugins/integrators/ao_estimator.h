/* ao's estimator in plain C that nvcc compiles too (RTK_HD), on the SDK's
 * types only: ao.c and device programs (plugins/integrators/device_programs.h,
 * program "ao") both run it, so a device renders ao's image. */
#ifndef RTK_AO_ESTIMATOR_H
#define RTK_AO_ESTIMATOR_H

#include <rtk/math.h>
#include <rtk/ray.h>

#include <math.h>

/* Orthonormal basis around unit n (Duff et al. 2017). */
RTK_HD static inline void rtk_ao_basis(rtk_vec3 n, rtk_vec3 *b1, rtk_vec3 *b2)
{
    float s = copysignf(1.0f, n.z);
    float a = -1.0f / (s + n.z);
    float b = n.x * n.y * a;
    *b1 = rtk_vec3_make(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
    *b2 = rtk_vec3_make(b, s + n.y * n.y * a, -n.y);
}

/* The occlusion ray for draw u: cosine-weighted about ns (basis b1, b2)
 * from org (the hit, offset off its surface) to distance; 0 when it
 * points below the geometric normal ng (possible with interpolated
 * normals): it would start inside and counts as blocked. */
RTK_HD static inline int rtk_ao_ray(rtk_vec2 u, rtk_vec3 org, rtk_vec3 ng, rtk_vec3 ns, rtk_vec3 b1, rtk_vec3 b2,
                                    float distance, rtk_ray *r)
{
    float rad = sqrtf(u.x), phi = 2.0f * (float)RTK_PI * u.y;
    float z = sqrtf(fmaxf(0.0f, 1.0f - u.x));
    r->org = org;
    r->tmin = 0.0f;
    r->tmax = distance;
    r->dir = rtk_vec3_add(rtk_vec3_add(rtk_vec3_scale(b1, rad * cosf(phi)), rtk_vec3_scale(b2, rad * sinf(phi))),
                          rtk_vec3_scale(ns, z));
    return rtk_vec3_dot(r->dir, ng) > 0.0f;
}

/* The pixel value: the open fraction of rays, times base when albedo. */
RTK_HD static inline rtk_rgb rtk_ao_value(int open, int rays, int albedo, rtk_rgb base)
{
    float v = (float)open / (float)rays;
    return albedo ? rtk_rgb_scale(base, v) : rtk_rgb_make(v, v, v);
}

#endif
