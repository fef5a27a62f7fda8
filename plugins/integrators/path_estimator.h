/* path's estimator in plain C that nvcc compiles too (RTK_HD), on the SDK's
 * types only: path.c and device programs (plugins/integrators/device_programs.h,
 * program "path") both run it. The caller finds the surface, its BSDF and a
 * light sample and draws the numbers; these functions weigh what a bounce
 * finds and choose how the path goes on, in one order for both. */
#ifndef RTK_PATH_ESTIMATOR_H
#define RTK_PATH_ESTIMATOR_H

#include <rtk/bsdf.h>
#include <rtk/lights.h>
#include <rtk/math.h>
#include <rtk/ray.h>

#include <math.h>

/* The BSDF's functions: the SDK's (librtk) by default; device programs,
 * which cannot call into librtk, define RTK_PATH_BSDF_INLINE first and
 * get the kernel's own lobes (kernel/scene/bsdf_lobes.h), the same code. */
#ifdef RTK_PATH_BSDF_INLINE
#include "scene/bsdf_lobes.h"
#define RTK_PATH_BSDF(fn) rtk_lobes_##fn
#else
#define RTK_PATH_BSDF(fn) rtk_bsdf_##fn
#endif

/* Sampler dimensions each bounce reserves (7 used: light pick, light
 * point, lobe, direction, roulette). */
#define RTK_PATH_DIMS_PER_BOUNCE 8

typedef struct rtk_path_params {
    int max_depth;
    int rr_depth;
    float clamp;
} rtk_path_params;

RTK_HD static inline float rtk_path_power_heuristic(float f, float g)
{
    return f * f / (f * f + g * g);
}

RTK_HD static inline float rtk_path_max3(rtk_rgb c)
{
    return fmaxf(c.r, fmaxf(c.g, c.b));
}

RTK_HD static inline int rtk_path_is_black(rtk_rgb c)
{
    return c.r <= 0.0f && c.g <= 0.0f && c.b <= 0.0f;
}

/* beta x c, scaled down to the clamp when one is set: what a
 * contribution adds to the radiance. */
RTK_HD static inline rtk_rgb rtk_path_weighted(const rtk_path_params *pt, rtk_rgb beta, rtk_rgb c)
{
    rtk_rgb v = rtk_rgb_mul(beta, c);
    float m = rtk_path_max3(v);
    if (pt->clamp > 0.0f && m > pt->clamp)
        v = rtk_rgb_scale(v, pt->clamp / m);
    return v;
}

/* One vertex's shading frame: the shading normal on the side the ray came
 * from, or, for BSDFs that transmit, on the side the surface was authored
 * to face (rtk/bsdf.h: inside is -z), with the geometric normal to match. */
typedef struct rtk_path_vertex {
    rtk_frame frame;
    rtk_vec3 ng; /* geometric normal on the frame's side */
    rtk_vec3 wo; /* local, towards where the ray came from */
} rtk_path_vertex;

/* The vertex of a surface (normals ng and ns on the ray's side, front_face
 * as rtk_surface's) with BSDF bsdf, reached along ray_dir. */
RTK_HD static inline rtk_path_vertex rtk_path_vertex_at(rtk_vec3 ng, rtk_vec3 ns, int front_face, const rtk_bsdf *bsdf,
                                                        rtk_vec3 ray_dir)
{
    rtk_path_vertex v;
    int flip = (RTK_PATH_BSDF(flags)(bsdf) & RTK_BSDF_TRANSMISSION) && !front_face;
    v.ng = flip ? rtk_vec3_neg(ng) : ng;
    v.frame = rtk_frame_from_normal(flip ? rtk_vec3_neg(ns) : ns);
    v.wo = rtk_frame_to_local(&v.frame, rtk_vec3_neg(rtk_vec3_normalize(ray_dir)));
    return v;
}

/* 1 when the world direction w lies on the side of the geometric surface
 * that the local direction's z says: no light through shading normals. */
RTK_HD static inline int rtk_path_same_side(const rtk_path_vertex *v, rtk_vec3 w, float local_z)
{
    float g = rtk_vec3_dot(w, v->ng);
    return (g > 0.0f && local_z > 0.0f) || (g < 0.0f && local_z < 0.0f);
}

/* Light sample li at vertex v, weighted against the BSDF's own sampling:
 * 1 with its contribution c when its shadow ray finds nothing, 0 when it
 * adds nothing whatever the shadow ray finds. */
RTK_HD static inline int rtk_path_light(const rtk_path_vertex *v, const rtk_bsdf *bsdf, const rtk_light_incident *li,
                                        rtk_rgb *c)
{
    if (!(li->pdf > 0.0f))
        return 0;
    rtk_vec3 wi = rtk_frame_to_local(&v->frame, li->wi);
    if (!rtk_path_same_side(v, li->wi, wi.z))
        return 0;
    rtk_rgb f = RTK_PATH_BSDF(eval)(bsdf, v->wo, wi);
    if (rtk_path_is_black(f))
        return 0;
    float w = li->delta ? 1.0f : rtk_path_power_heuristic(li->pdf, RTK_PATH_BSDF(pdf)(bsdf, v->wo, wi));
    *c = rtk_rgb_scale(rtk_rgb_mul(f, li->li), fabsf(wi.z) * w / li->pdf);
    return 1;
}

/* What the path has carried to the current ray: its throughput and how
 * the ray's direction was chosen, for weighting what the ray finds. */
typedef struct rtk_path_state {
    rtk_rgb beta;
    int depth;
    int delta;      /* camera ray or delta lobe: what it finds counts whole */
    float bsdf_pdf; /* else the solid-angle density it was sampled with */
    rtk_vec3 from;  /* and the point it left */
} rtk_path_state;

/* The state of a path that starts with camera ray org. */
RTK_HD static inline rtk_path_state rtk_path_start(rtk_vec3 org)
{
    rtk_path_state ps = {rtk_rgb_make(1.0f, 1.0f, 1.0f), 0, 1, 0.0f, org};
    return ps;
}

/* Weight of light the ray finds (an emitter, the environment) that
 * sampling lights from ps.from gives with solid-angle density light_pdf;
 * a ray of a delta lobe (or the camera's) takes it whole. */
RTK_HD static inline float rtk_path_found_weight(const rtk_path_state *ps, float light_pdf)
{
    return light_pdf > 0.0f ? rtk_path_power_heuristic(ps->bsdf_pdf, light_pdf) : 1.0f;
}

/* The BSDF sample bs at vertex v of surface point p (geometric normal ng)
 * takes the path on: its state updated and the next ray's direction set
 * in *ray; *side is the normal to offset the ray's origin along (p offset
 * along it). 0 when the path ends here. */
RTK_HD static inline int rtk_path_scatter(rtk_path_state *ps, const rtk_path_vertex *v, rtk_vec3 p, rtk_vec3 ng,
                                          const rtk_bsdf_sample_out *bs, rtk_ray *ray, rtk_vec3 *side)
{
    rtk_vec3 wi = rtk_frame_to_world(&v->frame, bs->wi);
    if (!rtk_path_same_side(v, wi, bs->wi.z))
        return 0;
    ps->beta = rtk_rgb_mul(ps->beta, rtk_rgb_scale(bs->f, fabsf(bs->wi.z) / bs->pdf));
    ps->delta = (bs->flags & RTK_BSDF_DELTA) != 0;
    ps->bsdf_pdf = bs->pdf;
    ps->from = p;
    if (!(rtk_path_max3(ps->beta) > 0.0f))
        return 0;
    *side = rtk_vec3_dot(wi, ng) > 0.0f ? ng : rtk_vec3_neg(ng);
    ray->dir = wi;
    ray->tmin = 0.0f;
    ray->tmax = INFINITY;
    return 1;
}

/* Whether Russian roulette decides if the path goes on after its last
 * scatter (then it survives with probability *m). */
RTK_HD static inline int rtk_path_roulette_due(const rtk_path_params *pt, const rtk_path_state *ps, float *m)
{
    *m = rtk_path_max3(ps->beta);
    return ps->depth + 1 >= pt->rr_depth && *m < 1.0f;
}

/* Russian roulette with draw u: 0 ends the path, 1 goes on, its
 * throughput divided by the survival probability m. */
RTK_HD static inline int rtk_path_survives(rtk_path_state *ps, float m, float u)
{
    if (u >= m)
        return 0;
    ps->beta = rtk_rgb_scale(ps->beta, 1.0f / m);
    return 1;
}

#endif
