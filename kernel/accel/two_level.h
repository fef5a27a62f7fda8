/* Two-level traversal (instancing): the scene's own triangles, then a
 * top-level tree over placed meshes, each entered in its own space (the
 * ray transformed in double precision, t kept as the parameter). Plain C
 * that nvcc compiles too (RTK_HD): instance.c traverses with it, the
 * meshes through the kernel's trees, and a device accelerator with the
 * same code over its flat trees (device_tree.h), so both give the same
 * hits. */
#ifndef RTK_KERNEL_TWO_LEVEL_H
#define RTK_KERNEL_TWO_LEVEL_H

#include "slab.h"

#include <math.h>
#include <stdint.h>

/* Closest hit of ray on mesh (RTK_INVALID_ID: the scene's own triangles):
 * 1 with hit filled as rtk_bvh_closest_own fills it (hit->inst need not
 * be set), counting into work when not NULL; the any-hit twin. */
typedef int (*rtk_mesh_closest_fn)(const void *ctx, uint32_t mesh, const rtk_ray *ray, rtk_hit *hit,
                                   rtk_trace_work *work);
typedef int (*rtk_mesh_any_fn)(const void *ctx, uint32_t mesh, const rtk_ray *ray, rtk_trace_work *work);

/* The top level a traversal reads. */
typedef struct rtk_two_level {
    int own;                            /* the scene has triangles of its own */
    const rtk_bvh_node *tlas;           /* tlas_node_count 0: no instances */
    uint32_t tlas_node_count;
    const uint32_t *order;              /* top-level leaf slot -> instance */
    const rtk_device_instance *instances;
} rtk_two_level;

/* 1 if ray has finite origin and direction, a non-zero direction and
 * tmin <= tmax (rtk_ray_valid). */
RTK_HD static inline int rtk_ray_usable(const rtk_ray *r)
{
    if (!isfinite(r->org.x) || !isfinite(r->org.y) || !isfinite(r->org.z))
        return 0;
    if (!isfinite(r->dir.x) || !isfinite(r->dir.y) || !isfinite(r->dir.z))
        return 0;
    if (r->dir.x == 0.0f && r->dir.y == 0.0f && r->dir.z == 0.0f)
        return 0;
    return !isnan(r->tmin) && !isnan(r->tmax) && r->tmin <= r->tmax;
}

/* m (3x4, row-major) applied to a point and to a vector, in double. */
RTK_HD static inline void rtk_affine_point(const double m[12], double x, double y, double z, double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[4 * r] * x + m[4 * r + 1] * y + m[4 * r + 2] * z + m[4 * r + 3];
}

RTK_HD static inline void rtk_affine_vector(const double m[12], double x, double y, double z, double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[4 * r] * x + m[4 * r + 1] * y + m[4 * r + 2] * z;
}

/* r in the space to_object maps to (t kept as the parameter); 0 when it
 * is not a usable ray there (a transform too small or large for float). */
RTK_HD static inline int rtk_local_ray(const double to_object[12], const rtk_ray *r, rtk_ray *out)
{
    double o[3], d[3];
    rtk_affine_point(to_object, r->org.x, r->org.y, r->org.z, o);
    rtk_affine_vector(to_object, r->dir.x, r->dir.y, r->dir.z, d);
    out->org.x = (float)o[0], out->org.y = (float)o[1], out->org.z = (float)o[2];
    out->dir.x = (float)d[0], out->dir.y = (float)d[1], out->dir.z = (float)d[2];
    out->tmin = r->tmin;
    out->tmax = r->tmax;
    return rtk_ray_usable(out);
}

/* Whether instance inst's triangle prim wins a tie at the same t against
 * best: the scene's own triangles first, then the lowest instance, then
 * the lowest triangle. */
RTK_HD static inline int rtk_wins_tie(uint32_t inst, uint32_t prim, const rtk_hit *best)
{
    if (best->prim == RTK_INVALID_ID)
        return 1;
    if (best->inst == RTK_INVALID_ID)
        return 0;
    return inst < best->inst || (inst == best->inst && prim < best->prim);
}

/* Closest hit of ray over the scene's own triangles and every instance:
 * equal distances go to the own triangles, then to the lowest instance,
 * then to the lowest triangle id. work, if not NULL, gets the counts of
 * both levels (cleared first). */
static RTK_HD_INLINE int rtk_two_level_closest(const rtk_two_level *tl, rtk_mesh_closest_fn mesh_closest,
                                               const void *ctx, const rtk_ray *ray, rtk_hit *hit,
                                               rtk_trace_work *work)
{
    rtk_ray r = *ray;
    hit->prim = hit->inst = RTK_INVALID_ID;
    hit->t = r.tmax;
    hit->u = hit->v = 0.0f;
    rtk_trace_work w = {0, 0};
    if (work)
        work->nodes = work->triangles = 0;
    if (tl->own) {
        rtk_hit h;
        if (mesh_closest(ctx, RTK_INVALID_ID, &r, &h, work ? &w : NULL)) {
            *hit = h;
            hit->inst = RTK_INVALID_ID;
            r.tmax = h.t;
        }
        if (work)
            work->nodes += w.nodes, work->triangles += w.triangles;
    }
    if (tl->tlas_node_count == 0)
        return hit->prim != RTK_INVALID_ID;
    rtk_slab_ray p;
    rtk_slab_prepare(&r, &p);
    rtk_slab_later stack[RTK_BVH_MAX_DEPTH + 2];
    int top = 0;
    rtk_bvh_node n = rtk_slab_node(tl->tlas, 0);
    if (rtk_slab_entry(&n, &p, r.tmin, r.tmax) == INFINITY)
        return hit->prim != RTK_INVALID_ID;
    for (;;) {
        if (work)
            work->nodes++;
        if (n.count > 0) {
            for (uint32_t i = 0; i < n.count; i++) {
                uint32_t id = tl->order[n.offset + i];
                const rtk_device_instance *in = &tl->instances[id];
                rtk_ray lr;
                /* A leaf may hold several instances: each box first. */
                if ((n.count > 1 && rtk_slab_entry(&in->box, &p, r.tmin, r.tmax) == INFINITY) ||
                    !rtk_local_ray(in->to_object, &r, &lr))
                    continue;
                rtk_hit h;
                int found = mesh_closest(ctx, in->mesh, &lr, &h, work ? &w : NULL);
                if (work)
                    work->nodes += w.nodes, work->triangles += w.triangles;
                if (found && (h.t < r.tmax || (h.t == r.tmax && rtk_wins_tie(id, h.prim, hit)))) {
                    *hit = h;
                    hit->inst = id;
                    r.tmax = h.t;
                }
            }
        } else if (rtk_slab_descend(tl->tlas, &n, &p, r.tmin, r.tmax, stack, &top, &n)) {
            continue;
        }
        if (!rtk_slab_next(tl->tlas, r.tmax, stack, &top, &n))
            break;
    }
    return hit->prim != RTK_INVALID_ID;
}

/* 1 when ray hits the scene's own triangles or any instance. */
static RTK_HD_INLINE int rtk_two_level_any(const rtk_two_level *tl, rtk_mesh_any_fn mesh_any, const void *ctx,
                                           const rtk_ray *ray, rtk_trace_work *work)
{
    rtk_trace_work w = {0, 0};
    if (work)
        work->nodes = work->triangles = 0;
    if (tl->own) {
        int found = mesh_any(ctx, RTK_INVALID_ID, ray, work ? &w : NULL);
        if (work)
            work->nodes += w.nodes, work->triangles += w.triangles;
        if (found)
            return 1;
    }
    if (tl->tlas_node_count == 0)
        return 0;
    rtk_slab_ray p;
    rtk_slab_prepare(ray, &p);
    uint32_t stack[RTK_BVH_MAX_DEPTH + 2];
    int top = 0;
    stack[top++] = 0;
    for (rtk_bvh_node n; rtk_slab_pop(tl->tlas, &p, ray->tmin, ray->tmax, stack, &top, &n);) {
        if (work)
            work->nodes++;
        if (n.count == 0) {
            stack[top++] = n.offset + 1;
            stack[top++] = n.offset;
            continue;
        }
        for (uint32_t i = 0; i < n.count; i++) {
            const rtk_device_instance *in = &tl->instances[tl->order[n.offset + i]];
            rtk_ray lr;
            if ((n.count > 1 && rtk_slab_entry(&in->box, &p, ray->tmin, ray->tmax) == INFINITY) ||
                !rtk_local_ray(in->to_object, ray, &lr))
                continue;
            int found = mesh_any(ctx, in->mesh, &lr, work ? &w : NULL);
            if (work)
                work->nodes += w.nodes, work->triangles += w.triangles;
            if (found)
                return 1;
        }
    }
    return 0;
}

#endif
