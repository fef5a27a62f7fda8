/* A device accelerator's tree (rtk_device_tree: binary nodes, leaf order,
 * each slot's corners; an instanced scene's top level and meshes) and its
 * closest-hit and any-hit traversals, the kernel's slab.h and
 * two_level.h over flat corners: plain C that nvcc compiles too (RTK_HD),
 * so the cuda plugin's GPU code, its CPU fallback and the tests run the
 * kernel's traversal. */
#ifndef RTK_KERNEL_DEVICE_TREE_H
#define RTK_KERNEL_DEVICE_TREE_H

#include "two_level.h"

#include <stddef.h>
#include <stdint.h>

/* The arrays a traversal reads, wherever they live (host or device). */
typedef struct rtk_flat_tree {
    const rtk_bvh_node *nodes;
    const uint32_t *prim_ids;
    const float *corners; /* 9 floats a leaf slot */
} rtk_flat_tree;

/* The leaf test of slab.h on slot's flat corners (no alpha: device
 * accelerators take no scene with cut-outs); on a GPU the corners come
 * through the read-only cache. */
RTK_HD static inline int rtk_flat_leaf(const void *ctx, uint32_t slot, const rtk_ray *ray, float *t, float *u,
                                       float *v)
{
    const float *c = ((const rtk_flat_tree *)ctx)->corners + 9 * (size_t)slot;
#ifdef __CUDA_ARCH__
    float k[9];
    for (int i = 0; i < 9; i++)
        k[i] = __ldg(c + i);
    c = k;
#endif
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

/* A whole scene: its own triangles' tree (nodes NULL when it has none),
 * each placed mesh's and the top level (two_level.h; tlas_node_count 0
 * when nothing is placed). Pointers are the device's or the host's alike. */
typedef struct rtk_flat_scene {
    rtk_flat_tree own;
    const rtk_flat_tree *meshes;
    rtk_two_level top;
} rtk_flat_scene;

/* tree's view on the host, its meshes' flat trees in meshes (room for
 * tree->mesh_count): what a device's CPU code traverses. */
static inline void rtk_flat_scene_of(const rtk_device_tree *tree, rtk_flat_tree *meshes, rtk_flat_scene *out)
{
    for (uint32_t i = 0; i < tree->mesh_count; i++) {
        const rtk_device_tree *m = &tree->meshes[i];
        meshes[i].nodes = m->nodes, meshes[i].prim_ids = m->prim_ids, meshes[i].corners = m->corners;
    }
    out->own.nodes = tree->nodes, out->own.prim_ids = tree->prim_ids, out->own.corners = tree->corners;
    out->meshes = meshes;
    out->top.own = tree->node_count > 0;
    out->top.tlas = tree->tlas_nodes;
    out->top.tlas_node_count = tree->tlas_node_count;
    out->top.order = tree->tlas_order;
    out->top.instances = tree->instances;
}

RTK_HD static inline int rtk_flat_mesh_closest(const void *ctx, uint32_t mesh, const rtk_ray *ray, rtk_hit *hit,
                                               rtk_trace_work *work)
{
    const rtk_flat_scene *f = (const rtk_flat_scene *)ctx;
    (void)work;
    rtk_flat_closest(mesh == RTK_INVALID_ID ? &f->own : &f->meshes[mesh], ray, hit);
    return hit->prim != RTK_INVALID_ID;
}

RTK_HD static inline int rtk_flat_mesh_any(const void *ctx, uint32_t mesh, const rtk_ray *ray, rtk_trace_work *work)
{
    const rtk_flat_scene *f = (const rtk_flat_scene *)ctx;
    (void)work;
    return rtk_flat_any(mesh == RTK_INVALID_ID ? &f->own : &f->meshes[mesh], ray);
}

/* Closest hit over the whole scene, as rtk_bvh_closest gives it (hit->inst
 * the instance, RTK_INVALID_ID for the scene's own triangles). */
RTK_HD static inline void rtk_flat_scene_closest(const rtk_flat_scene *f, const rtk_ray *ray, rtk_hit *hit)
{
    rtk_two_level_closest(&f->top, rtk_flat_mesh_closest, f, ray, hit, NULL);
}

/* 1 when ray hits anything in the scene, as rtk_bvh_any. */
RTK_HD static inline int rtk_flat_scene_any(const rtk_flat_scene *f, const rtk_ray *ray)
{
    return rtk_two_level_any(&f->top, rtk_flat_mesh_any, f, ray, NULL);
}

#endif
