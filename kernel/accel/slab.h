/* The conservative ray/box slab test (Ize 2013) on the kernel's binary
 * nodes, shared by the binary traversal (bvh.c) and the top level over
 * instances (instance.c). */
#ifndef RTK_KERNEL_SLAB_H
#define RTK_KERNEL_SLAB_H

#include "bvh_wide.h"

#include <float.h>
#include <math.h>

/* Deepest tree traversal accepts; a builder going deeper is refused. */
#define RTK_BVH_MAX_DEPTH 256

/* Per-ray constants of the slab test. */
typedef struct rtk_slab_ray {
    float org[3], inv[3];
    int neg[3];
} rtk_slab_ray;

static inline void rtk_slab_prepare(const rtk_ray *r, rtk_slab_ray *p)
{
    const float d[3] = {r->dir.x, r->dir.y, r->dir.z};
    p->org[0] = r->org.x, p->org[1] = r->org.y, p->org[2] = r->org.z;
    for (int k = 0; k < 3; k++) {
        p->inv[k] = 1.0f / d[k]; /* +-0 gives +-inf, which the slab test handles */
        p->neg[k] = signbit(d[k]) != 0;
    }
}

/* 1 + 2 gamma(3): each slab distance carries three roundings (subtract,
 * reciprocal, multiply); Ize 2013 widens the far distance by this much. */
static const float rtk_slab_slack = 1.0f + 2.0f * (3.0f * 0.5f * FLT_EPSILON) / (1.0f - 3.0f * 0.5f * FLT_EPSILON);

/* Entry distance into the node's box, or +inf when the ray misses it. The
 * far end is widened by rtk_slab_slack so that rounding never culls a box the
 * ray crosses, and the ray's tmax (a hit found so far) by
 * rtk_cull_distance, so that no triangle whose float t ties with that hit
 * is culled. NaN from 0 * inf fails both comparisons and is dropped, which
 * only widens the interval. */
static inline float rtk_slab_entry(const rtk_bvh_node *n, const rtk_slab_ray *p, float tmin, float tmax)
{
    float t0 = tmin, t1 = INFINITY;
    for (int k = 0; k < 3; k++) {
        float lo = p->neg[k] ? n->upper[k] : n->lower[k];
        float hi = p->neg[k] ? n->lower[k] : n->upper[k];
        float a = (lo - p->org[k]) * p->inv[k];
        float b = (hi - p->org[k]) * p->inv[k];
        t0 = a > t0 ? a : t0;
        t1 = b < t1 ? b : t1;
    }
    t1 = t1 >= 0.0f ? t1 * rtk_slab_slack : t1 / rtk_slab_slack;
    float cull = rtk_cull_distance(tmax);
    t1 = cull < t1 ? cull : t1;
    return t0 <= t1 ? t0 : INFINITY;
}

#endif
