/* A device accelerator's tree (rtk_device_tree: binary nodes, leaf order,
 * each slot's corners) and its closest-hit and any-hit traversals, the
 * kernel's slab.h over flat corners: plain C that nvcc compiles too
 * (RTK_HD), so the cuda plugin's GPU code, its CPU fallback and the tests
 * run the kernel's traversal. */
#ifndef RTK_KERNEL_DEVICE_TREE_H
#define RTK_KERNEL_DEVICE_TREE_H

#include "slab.h"

#include <stddef.h>
#include <stdint.h>

/* The arrays a traversal reads, wherever they live (host or device). */
typedef struct rtk_flat_tree {
    const rtk_bvh_node *nodes;
    const uint32_t *prim_ids;
    const float *corners; /* 9 floats a leaf slot */
} rtk_flat_tree;

/* The leaf test of slab.h on slot's flat corners (no alpha: device
 * accelerators take no scene with cut-outs). */
RTK_HD static inline int rtk_flat_leaf(const void *ctx, uint32_t slot, const rtk_ray *ray, float *t, float *u,
                                       float *v)
{
    const float *c = ((const rtk_flat_tree *)ctx)->corners + 9 * (size_t)slot;
    const rtk_vec3 a = {c[0], c[1], c[2]}, b = {c[3], c[4], c[5]}, d = {c[6], c[7], c[8]};
    return rtk_isect_triangle(ray, a, b, d, t, u, v);
}

/* Closest hit as rtk_bvh_closest gives it on the kernel's tree (hit->inst
 * RTK_INVALID_ID; a miss leaves prim RTK_INVALID_ID, t the ray's tmax,
 * u = v = 0). */
RTK_HD static inline void rtk_flat_closest(const rtk_flat_tree *f, const rtk_ray *ray, rtk_hit *hit)
{
    hit->prim = RTK_INVALID_ID;
    hit->inst = RTK_INVALID_ID;
    hit->t = ray->tmax;
    hit->u = hit->v = 0.0f;
    rtk_slab_closest(f->nodes, f->prim_ids, rtk_flat_leaf, f, ray, hit, NULL);
}

/* 1 when ray hits anything, as rtk_bvh_any. */
RTK_HD static inline int rtk_flat_any(const rtk_flat_tree *f, const rtk_ray *ray)
{
    return rtk_slab_any(f->nodes, rtk_flat_leaf, f, ray, NULL);
}

#endif
