/* Device programs: integrators' estimators that a device accelerator runs
 * whole for each camera sample (rtk_accelerator_fns.shade), in plain C
 * that nvcc compiles too (RTK_HD), over the kernel's flat trees
 * (kernel/accel/device_tree.h) with its sampler (kernel/render/sample.h)
 * and surface geometry (kernel/scene/surface_geom.h). Device accelerators
 * (plugins/accelerators/cuda, tests/plugins/device) and `rtk conform`
 * run them.
 *
 * Programs (rtk_device_program.name, then its params):
 *   "ao"         ao (plugins/integrators/ao_estimator.h): params[0] rays
 *                (1 to 4096), params[1] distance (> 0), params[2] albedo
 *                (0 or 1).
 *   "headlight"  headlight (plugins/integrators/headlight_estimator.h):
 *                params[0] ambient (0 to 1).
 * Surfaces: position, normals and base colour (material factor times
 * vertex colour), no textures. Scenes: a device accelerator's (no
 * cut-outs, no single-sided materials), without instances, textures or
 * lights to sample (the kernel offers no others: rtk_device_runs).
 *
 * Run on a CPU, a program gives what the integrator's li gives, bit for
 * bit (tests/plugins/device checks it); on a GPU, hits are still the
 * CPU's (tests/cuda), while cosf and sinf may round differently. */
#ifndef RTK_DEVICE_PROGRAMS_H
#define RTK_DEVICE_PROGRAMS_H

#include "ao_estimator.h"
#include "headlight_estimator.h"

/* The kernel's shared code: its folder must be on the include path. */
#include "accel/accel.h"
#include "accel/device_tree.h"
#include "render/sample.h"
#include "scene/surface_geom.h"

#include <rtk/integrator.h>

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef enum rtk_program_kind { RTK_PROGRAM_NONE = 0, RTK_PROGRAM_AO = 1, RTK_PROGRAM_HEADLIGHT = 2 } rtk_program_kind;

/* A program checked and unpacked from its description. */
typedef struct rtk_program {
    rtk_program_kind kind;
    int rays;       /* ao */
    float distance; /* ao */
    int albedo;     /* ao */
    float ambient;  /* headlight */
} rtk_program;

/* What a program reads: the scene's tree, each triangle's leaf slot (to
 * find its corners), the corners' normals, the materials' base colours
 * and vertex colours (rtk_device_tree's) and the default material's
 * colour. Pointers are the device's or the host's alike. */
typedef struct rtk_program_scene {
    rtk_flat_scene flat;
    const uint32_t *slot_of;       /* triangle id -> leaf slot of flat.own */
    const float *normals;          /* 9 floats a triangle id; NULL: none */
    const uint32_t *tri_materials; /* NULL: materials not read */
    const rtk_rgb *base_colors;
    uint32_t material_count;
    const float *colors;           /* 12 floats a triangle id; NULL: none */
    rtk_rgb albedo;
} rtk_program_scene;

/* The program d describes, or kind RTK_PROGRAM_NONE when it is not one
 * of the list above (or its parameters are out of range). */
static inline rtk_program rtk_program_of(const rtk_device_program *d)
{
    rtk_program p;
    memset(&p, 0, sizeof p);
    const float *v = d->params;
    if (strncmp(d->name, "ao", sizeof d->name) == 0 && v[0] >= 1.0f && v[0] <= 4096.0f && v[1] > 0.0f &&
        (v[2] == 0.0f || v[2] == 1.0f)) {
        p.kind = RTK_PROGRAM_AO;
        p.rays = (int)v[0];
        p.distance = v[1];
        p.albedo = v[2] == 1.0f;
    } else if (strncmp(d->name, "headlight", sizeof d->name) == 0 && v[0] >= 0.0f && v[0] <= 1.0f) {
        p.kind = RTK_PROGRAM_HEADLIGHT;
        p.ambient = v[0];
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
    out->tri_materials = tree->tri_materials;
    out->base_colors = tree->base_colors;
    out->material_count = tree->material_count;
    out->colors = tree->colors;
    return 0;
}

/* Rays a sample traced and how many of them were invalid (what rtk_trace
 * and rtk_occluded count). */
typedef struct rtk_program_count {
    uint32_t traced, invalid;
} rtk_program_count;

/* A camera ray's first hit as rtk_trace and rtk_surface_at give it:
 * 0 when it misses (or is invalid, counted); else its point, normals and
 * base colour, with out's AOVs set. */
typedef struct rtk_program_hit {
    rtk_vec3 p, ng, ns;
    rtk_rgb base;
} rtk_program_hit;

RTK_HD static inline int rtk_program_camera_hit(const rtk_program_scene *s, const rtk_ray *ray, rtk_li_result *out,
                                                rtk_program_count *count, rtk_program_hit *h)
{
    count->traced++;
    if (!rtk_ray_usable(ray)) {
        count->invalid++;
        return 0;
    }
    rtk_hit hit;
    rtk_flat_scene_closest(&s->flat, ray, &hit);
    if (hit.prim == RTK_INVALID_ID)
        return 0;
    const float *c = s->flat.own.corners + 9 * (size_t)s->slot_of[hit.prim];
    rtk_vec3 p0 = {c[0], c[1], c[2]}, p1 = {c[3], c[4], c[5]}, p2 = {c[6], c[7], c[8]};
    int front;
    rtk_surface_geometry(p0, p1, p2, s->normals ? s->normals + 9 * (size_t)hit.prim : NULL, hit.u, hit.v, ray->dir,
                         &h->p, &h->ng, &h->ns, &front);
    h->base = s->albedo;
    const float *colors = NULL;
    if (s->tri_materials) {
        const uint32_t id = s->tri_materials[hit.prim];
        if (id < s->material_count)
            h->base = s->base_colors[id];
        colors = s->colors ? s->colors + 12 * (size_t)hit.prim : NULL;
    }
    h->base = rtk_surface_base_color(h->base, colors, hit.u, hit.v);
    out->albedo = h->base;
    out->normal = h->ns;
    out->depth = hit.t * rtk_vec3_length(ray->dir);
    return 1;
}

/* ao's li (plugins/integrators/ao.c) for camera ray ray, drawing from pos. */
RTK_HD static inline void rtk_program_ao(const rtk_program *p, const rtk_program_scene *s, const rtk_sample_gen *g,
                                         rtk_sample_pos pos, const rtk_ray *ray, rtk_li_result *out,
                                         rtk_program_count *count)
{
    rtk_program_hit h;
    if (!rtk_program_camera_hit(s, ray, out, count, &h))
        return;
    rtk_vec3 b1, b2;
    rtk_ao_basis(h.ns, &b1, &b2);
    const rtk_vec3 org = rtk_offset_point(h.p, h.ng);
    int open = 0;
    for (int i = 0; i < p->rays; i++) {
        rtk_ray r;
        if (!rtk_ao_ray(rtk_sample_next_2d(g, &pos), org, h.ng, h.ns, b1, b2, p->distance, &r))
            continue;
        count->traced++;
        if (!rtk_ray_usable(&r)) {
            count->invalid++;
            open++; /* rtk_occluded: an invalid ray is not blocked */
            continue;
        }
        open += !rtk_flat_scene_any(&s->flat, &r);
    }
    out->radiance = rtk_ao_value(open, p->rays, p->albedo, h.base);
}

/* headlight's li (plugins/integrators/headlight.c) for camera ray ray. */
RTK_HD static inline void rtk_program_headlight(const rtk_program *p, const rtk_program_scene *s, const rtk_ray *ray,
                                                rtk_li_result *out, rtk_program_count *count)
{
    rtk_program_hit h;
    if (rtk_program_camera_hit(s, ray, out, count, &h))
        out->radiance = rtk_headlight_value(h.base, h.ns, ray->dir, p->ambient);
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
    else if (p->kind == RTK_PROGRAM_HEADLIGHT)
        rtk_program_headlight(p, s, ray, out, count);
}

#endif
