/* The conservative ray/box slab test (Ize 2013) on the kernel's binary
 * nodes, the traversal steps built on it (closest hit's ordered descent,
 * occlusion's pop) and the binary tree's closest-hit and any-hit
 * traversals, shared by bvh.c, the top level over instances (instance.c)
 * and the CUDA backend: plain C that nvcc compiles too (RTK_HD,
 * include/rtk/common.h), so that tests/cuda checks the GPU's traversal
 * against the kernel's. */
#ifndef RTK_KERNEL_SLAB_H
#define RTK_KERNEL_SLAB_H

#include "isect.h"

#include <rtk/accelerator.h>
#include <rtk/scene.h>

#include <float.h>
#include <math.h>
#include <stdint.h>

/* Deepest tree traversal accepts; a builder going deeper is refused. */
#define RTK_BVH_MAX_DEPTH 256

/* Per-ray constants of the slab test. */
typedef struct rtk_slab_ray {
    float org[3], inv[3];
    int neg[3];
} rtk_slab_ray;

RTK_HD static inline void rtk_slab_prepare(const rtk_ray *r, rtk_slab_ray *p)
{
    const float d[3] = {r->dir.x, r->dir.y, r->dir.z};
    p->org[0] = r->org.x, p->org[1] = r->org.y, p->org[2] = r->org.z;
    for (int k = 0; k < 3; k++) {
        p->inv[k] = 1.0f / d[k]; /* +-0 gives +-inf, which the slab test handles */
        p->neg[k] = signbit(d[k]) != 0;
    }
}

/* Node i of a tree. On a GPU two 16-byte loads through the read-only
 * cache (device trees are cudaMalloc'ed: nodes 32-byte aligned); the same
 * bits either way. */
RTK_HD static inline rtk_bvh_node rtk_slab_node(const rtk_bvh_node *nodes, uint32_t i)
{
#ifdef __CUDA_ARCH__
    const float4 *q = (const float4 *)(nodes + i);
    const float4 a = __ldg(q), b = __ldg(q + 1);
    rtk_bvh_node n;
    n.lower[0] = a.x, n.lower[1] = a.y, n.lower[2] = a.z, n.offset = __float_as_uint(a.w);
    n.upper[0] = b.x, n.upper[1] = b.y, n.upper[2] = b.z, n.count = __float_as_uint(b.w);
    return n;
#else
    return nodes[i];
#endif
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
RTK_HD static inline float rtk_slab_entry(const rtk_bvh_node *n, const rtk_slab_ray *p, float tmin, float tmax)
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

/* A node the ordered descent put aside, with the distance at which the
 * ray enters its box. */
typedef struct rtk_slab_later {
    uint32_t node;
    float t;
} rtk_slab_later;

/* One step of the ordered descent at inner node n of the tree nodes: the
 * children whose boxes the ray enters within [tmin, tmax], the nearer
 * into *next (which may be n) and the farther pushed on stack with its
 * entry distance when both; 0 when it enters neither (the caller pops
 * next). */
static RTK_HD_INLINE int rtk_slab_descend(const rtk_bvh_node *nodes, const rtk_bvh_node *n,
                                          const rtk_slab_ray *p, float tmin, float tmax, rtk_slab_later *stack,
                                          int *top, rtk_bvh_node *next)
{
    uint32_t i0 = n->offset, i1 = n->offset + 1;
    rtk_bvh_node c0 = rtk_slab_node(nodes, i0), c1 = rtk_slab_node(nodes, i1);
    float t0 = rtk_slab_entry(&c0, p, tmin, tmax);
    float t1 = rtk_slab_entry(&c1, p, tmin, tmax);
    if (t0 != INFINITY && t1 != INFINITY) {
        if (t1 < t0) {
            stack[*top].node = i0, stack[*top].t = t0;
            *next = c1;
        } else {
            stack[*top].node = i1, stack[*top].t = t1;
            *next = c0;
        }
        ++*top;
        return 1;
    }
    if (t0 != INFINITY) {
        *next = c0;
        return 1;
    }
    if (t1 != INFINITY) {
        *next = c1;
        return 1;
    }
    return 0;
}

/* The closest hit's next node: pops stack past the nodes whose box the
 * ray enters beyond rtk_cull_distance(tmax), a hit found since they were
 * pushed (the descent's test would cull their children, which lie inside
 * them, as it culls a leaf entered there), into *out; 0 when the stack
 * runs empty. */
static RTK_HD_INLINE int rtk_slab_next(const rtk_bvh_node *nodes, float tmax, const rtk_slab_later *stack, int *top,
                                       rtk_bvh_node *out)
{
    const float cull = rtk_cull_distance(tmax);
    while (*top > 0) {
        const rtk_slab_later e = stack[--*top];
        if (e.t <= cull) {
            *out = rtk_slab_node(nodes, e.node);
            return 1;
        }
    }
    return 0;
}

/* Occlusion's unordered walk: pops stack until a node whose box the
 * ray enters within [tmin, tmax] and returns 1 with it in *out, or 0 when
 * the stack runs empty. */
static RTK_HD_INLINE int rtk_slab_pop(const rtk_bvh_node *nodes, const rtk_slab_ray *p, float tmin, float tmax,
                                      const uint32_t *stack, int *top, rtk_bvh_node *out)
{
    while (*top > 0) {
        rtk_bvh_node n = rtk_slab_node(nodes, stack[--*top]);
        if (rtk_slab_entry(&n, p, tmin, tmax) != INFINITY) {
            *out = n;
            return 1;
        }
    }
    return 0;
}

/* A leaf's triangle test: 1 when the ray hits the triangle in leaf slot
 * slot within [tmin, tmax] (t, u, v written) and the hit counts (an
 * alpha cut-out may drop it); ctx is the caller's. */
typedef int (*rtk_slab_leaf_fn)(const void *ctx, uint32_t slot, const rtk_ray *ray, float *t, float *u, float *v);

/* Closest hit of ray on the binary tree nodes (leaf slots map to
 * prim_ids): hit as rtk_bvh_closest fills it, except inst; equal
 * distances go to the lowest id whatever the tree. hit must come in
 * with prim RTK_INVALID_ID and t the ray's tmax. Counts into work when
 * not NULL. */
static RTK_HD_INLINE int rtk_slab_closest(const rtk_bvh_node *nodes, const uint32_t *prim_ids,
                                          rtk_slab_leaf_fn leaf, const void *ctx, const rtk_ray *ray_in,
                                          rtk_hit *hit, rtk_trace_work *work)
{
    rtk_ray ray = *ray_in;
    rtk_slab_ray p;
    rtk_slab_prepare(&ray, &p);
    rtk_slab_later stack[RTK_BVH_MAX_DEPTH + 2];
    int top = 0;
    rtk_bvh_node n = rtk_slab_node(nodes, 0);
    if (rtk_slab_entry(&n, &p, ray.tmin, ray.tmax) == INFINITY)
        return 0;
    for (;;) {
        if (n.count > 0) {
            if (work)
                work->triangles += n.count;
            for (uint32_t i = 0; i < n.count; i++) {
                uint32_t slot = n.offset + i;
                float t, u, v;
                if (!leaf(ctx, slot, &ray, &t, &u, &v))
                    continue;
                uint32_t prim = prim_ids[slot];
                if (t < ray.tmax || (t == ray.tmax && prim < hit->prim)) {
                    ray.tmax = t;
                    hit->t = t, hit->u = u, hit->v = v, hit->prim = prim;
                }
            }
        } else {
            if (work)
                work->nodes++;
            if (rtk_slab_descend(nodes, &n, &p, ray.tmin, ray.tmax, stack, &top, &n))
                continue;
        }
        if (!rtk_slab_next(nodes, ray.tmax, stack, &top, &n))
            break;
    }
    return hit->prim != RTK_INVALID_ID;
}

/* Any hit of ray on the binary tree nodes: 1 as soon as a leaf's
 * triangle counts. The closest hit's ordered descent, the nearer child
 * first: its boxes do not shrink, so it reaches the leaves the unordered
 * walk reaches, and it tests each box once, at its parent. Counts into
 * work when not NULL. */
static RTK_HD_INLINE int rtk_slab_any(const rtk_bvh_node *nodes, rtk_slab_leaf_fn leaf, const void *ctx,
                                      const rtk_ray *ray, rtk_trace_work *work)
{
    rtk_slab_ray p;
    rtk_slab_prepare(ray, &p);
    rtk_slab_later stack[RTK_BVH_MAX_DEPTH + 2];
    int top = 0;
    rtk_bvh_node n = rtk_slab_node(nodes, 0);
    if (rtk_slab_entry(&n, &p, ray->tmin, ray->tmax) == INFINITY)
        return 0;
    for (;;) {
        if (n.count > 0) {
            for (uint32_t i = 0; i < n.count; i++) {
                float t, u, v;
                if (work)
                    work->triangles++;
                if (leaf(ctx, n.offset + i, ray, &t, &u, &v))
                    return 1;
            }
        } else {
            if (work)
                work->nodes++;
            if (rtk_slab_descend(nodes, &n, &p, ray->tmin, ray->tmax, stack, &top, &n))
                continue;
        }
        if (top == 0)
            return 0;
        n = rtk_slab_node(nodes, stack[--top].node);
    }
}

#endif
