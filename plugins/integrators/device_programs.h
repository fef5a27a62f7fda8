/* Device programs: integrators' estimators that a device accelerator runs
 * whole for each camera sample (rtk_accelerator_fns.shade), in plain C
 * that nvcc compiles too (RTK_HD), over the kernel's flat trees
 * (kernel/accel/device_tree.h) with its sampler (kernel/render/sample.h)
 * and surface geometry (kernel/scene/surface_geom.h). Device accelerators
 * (plugins/accelerators/cuda, tests/plugins/device) and `rtk conform`
 * run them.
 *
 * Programs (rtk_device_program.name, then its params):
 *   "ao"  ao without albedo (plugins/integrators/ao_estimator.h):
 *         params[0] rays (1 to 4096), params[1] distance (> 0).
 * Scenes: a device accelerator's (no cut-outs, no single-sided
 * materials), without instances, materials, textures or lights (the
 * kernel offers no others: rtk_device_runs).
 *
 * Run on a CPU, a program gives what the integrator's li gives, bit for
 * bit (tests/plugins/device checks it); on a GPU, hits are still the
 * CPU's (tests/cuda), while cosf and sinf may round differently. */
#ifndef RTK_DEVICE_PROGRAMS_H
#define RTK_DEVICE_PROGRAMS_H

#include "ao_estimator.h"

/* The kernel's shared code: its folder must be on the include path. */
#include "accel/accel.h"
#include "accel/device_tree.h"
#include "render/sample.h"
#include "scene/surface_geom.h"

#include <rtk/integrator.h>

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef enum rtk_program_kind { RTK_PROGRAM_NONE = 0, RTK_PROGRAM_AO = 1 } rtk_program_kind;

/* A program checked and unpacked from its description. */
typedef struct rtk_program {
    rtk_program_kind kind;
    int rays;
    float distance;
} rtk_program;

/* What a program reads: the scene's tree, each triangle's leaf slot (to
 * find its corners), the corners' normals and the colour of a surface
 * without material. Pointers are the device's or the host's alike. */
typedef struct rtk_program_scene {
    rtk_flat_scene flat;
    const uint32_t *slot_of; /* triangle id -> leaf slot of flat.own */
    const float *normals;    /* 9 floats a triangle id; NULL: none */
    rtk_rgb albedo;
} rtk_program_scene;

/* The program d describes, or kind RTK_PROGRAM_NONE when it is not one
 * of the list above (or its parameters are out of range). */
static inline rtk_program rtk_program_of(const rtk_device_program *d)
{
    rtk_program p = {RTK_PROGRAM_NONE, 0, 0.0f};
    if (strncmp(d->name, "ao", sizeof d->name) == 0 && d->params[0] >= 1.0f && d->params[0] <= 4096.0f &&
        d->params[1] > 0.0f) {
        p.kind = RTK_PROGRAM_AO;
        p.rays = (int)d->params[0];
        p.distance = d->params[1];
    }
    return p;
}

/* The leaf slot of every triangle of tree (slot_of has tree->slot_count
 * entries), for rtk_program_scene.slot_of. */
static inline void rtk_program_slots(const rtk_device_tree *tree, uint32_t *slot_of)
{
    for (uint32_t slot = 0; slot < tree->slot_count; slot++)
        slot_of[tree->prim_ids[slot]] = slot;
}

/* What programs read of tree, flat its traversal's view (host pointers):
 * *slot_of made here (NULL when tree has no triangles of its own) [caller
 * frees]; albedo left for each batch. 0, or -1 out of memory. */
static inline int rtk_program_scene_of(const rtk_device_tree *tree, const rtk_flat_scene *flat, uint32_t **slot_of,
                                       rtk_program_scene *out)
{
    *slot_of = NULL;
    if (tree->slot_count) {
        if (!(*slot_of = (uint32_t *)malloc(sizeof **slot_of * tree->slot_count)))
            return -1;
        rtk_program_slots(tree, *slot_of);
    }
    memset(out, 0, sizeof *out);
    out->flat = *flat;
    out->slot_of = *slot_of;
    out->normals = tree->normals;
    return 0;
}

/* Rays a sample traced and how many of them were invalid (what rtk_trace
 * and rtk_occluded count). */
typedef struct rtk_program_count {
    uint32_t traced, invalid;
} rtk_program_count;

/* ao's li (plugins/integrators/ao.c) for camera ray ray, drawing from pos. */
RTK_HD static inline void rtk_program_ao(const rtk_program *p, const rtk_program_scene *s, const rtk_sample_gen *g,
                                         rtk_sample_pos pos, const rtk_ray *ray, rtk_li_result *out,
                                         rtk_program_count *count)
{
    count->traced = 1;
    count->invalid = 0;
    if (!rtk_ray_usable(ray)) {
        count->invalid = 1;
        return;
    }
    rtk_hit hit;
    rtk_flat_scene_closest(&s->flat, ray, &hit);
    if (hit.prim == RTK_INVALID_ID)
        return;
    const float *c = s->flat.own.corners + 9 * (size_t)s->slot_of[hit.prim];
    rtk_vec3 p0 = {c[0], c[1], c[2]}, p1 = {c[3], c[4], c[5]}, p2 = {c[6], c[7], c[8]};
    rtk_vec3 at, ng, ns;
    int front;
    rtk_surface_geometry(p0, p1, p2, s->normals ? s->normals + 9 * (size_t)hit.prim : NULL, hit.u, hit.v, ray->dir,
                         &at, &ng, &ns, &front);
    out->albedo = s->albedo;
    out->normal = ns;
    out->depth = hit.t * rtk_vec3_length(ray->dir);
    rtk_vec3 b1, b2;
    rtk_ao_basis(ns, &b1, &b2);
    const rtk_vec3 org = rtk_offset_point(at, ng);
    int open = 0;
    for (int i = 0; i < p->rays; i++) {
        rtk_ray r;
        if (!rtk_ao_ray(rtk_sample_next_2d(g, &pos), org, ng, ns, b1, b2, p->distance, &r))
            continue;
        count->traced++;
        if (!rtk_ray_usable(&r)) {
            count->invalid++;
            open++; /* rtk_occluded: an invalid ray is not blocked */
            continue;
        }
        open += !rtk_flat_scene_any(&s->flat, &r);
    }
    out->radiance = rtk_ao_value(open, p->rays, 0, s->albedo);
}

/* Program p on one sample: out as the kernel pre-fills li's (all 0, depth
 * infinite), then as the program sets it. */
RTK_HD static inline void rtk_program_run(const rtk_program *p, const rtk_program_scene *s, const rtk_sample_gen *g,
                                          const rtk_sample_pos *pos, const rtk_ray *ray, rtk_li_result *out,
                                          rtk_program_count *count)
{
    out->radiance = out->albedo = rtk_rgb_make(0.0f, 0.0f, 0.0f);
    out->normal = rtk_vec3_make(0.0f, 0.0f, 0.0f);
    out->depth = INFINITY;
    count->traced = count->invalid = 0;
    if (p->kind == RTK_PROGRAM_AO)
        rtk_program_ao(p, s, g, *pos, ray, out, count);
}

#endif
