/* The conservative ray/box slab test (Ize 2013) on the kernel's binary
 * nodes and the traversal steps built on it (closest hit's ordered
 * descent, occlusion's pop), shared by the binary traversal (bvh.c) and
 * the top level over instances (instance.c). */
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

/* One step of the ordered descent at inner node n of the tree nodes: the
 * children whose boxes the ray enters within [tmin, tmax], the nearer into
 * *node and the farther pushed on stack when both; 0 when it enters
 * neither (the caller pops next). */
static inline __attribute__((always_inline)) int rtk_slab_descend(const rtk_bvh_node *nodes,
                                                                   const rtk_bvh_node *n, const rtk_slab_ray *p,
                                                                   float tmin, float tmax, uint32_t *stack,
                                                                   int *top, uint32_t *node)
{
    uint32_t c0 = n->offset, c1 = n->offset + 1;
    float t0 = rtk_slab_entry(&nodes[c0], p, tmin, tmax);
    float t1 = rtk_slab_entry(&nodes[c1], p, tmin, tmax);
    if (t0 != INFINITY && t1 != INFINITY) {
        if (t1 < t0) {
            uint32_t tmp = c0;
            c0 = c1;
            c1 = tmp;
        }
        stack[(*top)++] = c1;
        *node = c0;
        return 1;
    }
    if (t0 != INFINITY) {
        *node = c0;
        return 1;
    }
    if (t1 != INFINITY) {
        *node = c1;
        return 1;
    }
    return 0;
}

/* Occlusion's unordered walk: pops stack until a node whose box the
 * ray enters within [tmin, tmax] and returns it, or NULL when the stack
 * runs empty. */
static inline __attribute__((always_inline)) const rtk_bvh_node *rtk_slab_pop(const rtk_bvh_node *nodes,
                                                                               const rtk_slab_ray *p, float tmin,
                                                                               float tmax, const uint32_t *stack,
                                                                               int *top)
{
    while (*top > 0) {
        const rtk_bvh_node *n = &nodes[stack[--*top]];
        if (rtk_slab_entry(n, p, tmin, tmax) != INFINITY)
            return n;
    }
    return NULL;
}

#endif
