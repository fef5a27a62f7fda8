/* Light sampling in plain C that nvcc compiles too (RTK_HD): the choice
 * between all lights (slot CDF), the emitters' alias table and a uniform
 * point on the chosen triangle, punctual lights and the environment map
 * as seen from a point, and the densities MIS needs. lights.c and
 * environment.c are wrappers around it, with the scene's triangles and
 * emission textures behind rtk_emitter_fns; a GPU passes its own. tests/cuda
 * checks nvcc's code against the kernel's bit for bit. */
#ifndef RTK_KERNEL_LIGHT_SAMPLE_H
#define RTK_KERNEL_LIGHT_SAMPLE_H

#include "lights.h"
#include "../accel/accel.h"

#include <math.h>
#include <stdint.h>

/* What emitter sampling reads of the scene: emitter light's world corners
 * (in its mesh's order) and whether its instance mirrors them; its
 * emitted radiance at barycentrics (b1, b2) of those corners. */
typedef struct rtk_emitter_fns {
    void (*corners)(const void *ctx, uint32_t light, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c, int *mirrored);
    rtk_rgb (*emission)(const void *ctx, uint32_t light, float b1, float b2);
} rtk_emitter_fns;

/* n, or -n when it faces away from d. */
RTK_HD static inline rtk_vec3 rtk_facing(rtk_vec3 n, rtk_vec3 d)
{
    return rtk_vec3_dot(n, d) < 0.0f ? rtk_vec3_neg(n) : n;
}

/* rtk_shadow_ray: p and q each offset along its own normal turned
 * towards the other. */
RTK_HD static inline rtk_ray rtk_shadow_between(rtk_vec3 p, rtk_vec3 np, rtk_vec3 q, rtk_vec3 nq)
{
    rtk_vec3 d = rtk_vec3_sub(q, p);
    rtk_vec3 from = rtk_offset_point(p, rtk_facing(np, d)), to = rtk_offset_point(q, rtk_facing(nq, rtk_vec3_neg(d)));
    rtk_ray r = {from, 0.0f, rtk_vec3_sub(to, from), 1.0f};
    return r;
}

/* The shadow ray from p (normal ng) towards direction wi at infinity. */
RTK_HD static inline rtk_ray rtk_ray_to_infinity(rtk_vec3 p, rtk_vec3 ng, rtk_vec3 wi)
{
    rtk_ray r = {rtk_offset_point(p, rtk_facing(ng, wi)), 0.0f, wi, INFINITY};
    return r;
}

/* The emitter the alias table gives for u_pick in [0, 1). */
RTK_HD static inline uint32_t rtk_alias_pick(const rtk_lights *l, float u_pick)
{
    float x = u_pick * (float)l->count;
    uint32_t col = (uint32_t)x;
    if (col >= l->count)
        col = l->count - 1;
    float frac = x - (float)col;
    return frac < l->alias_prob[col] ? col : l->alias[col];
}

/* rtk_scene_sample_light on table l (which has emitters). */
static RTK_HD_INLINE void rtk_emitter_sample(const rtk_lights *l, const rtk_emitter_fns *fns, const void *ctx,
                                            float u_pick, rtk_vec2 u, rtk_light_sample *out)
{
    uint32_t light = rtk_alias_pick(l, u_pick);
    rtk_vec3 a, b, c;
    int mirrored;
    fns->corners(ctx, light, &a, &b, &c, &mirrored);
    /* Uniform on the triangle: the square-root warp. */
    float r = sqrtf(u.x);
    float b0 = 1.0f - r, b1 = u.y * r, b2 = 1.0f - b0 - b1;
    out->p = rtk_vec3_make(b0 * a.x + b1 * b.x + b2 * c.x, b0 * a.y + b1 * b.y + b2 * c.y,
                           b0 * a.z + b1 * b.z + b2 * c.z);
    out->n = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a)));
    /* A mirrored instance's corners wind the other way round; the emitting
     * side stays the authored one (see rtk_instance_surface). */
    if (mirrored)
        out->n = rtk_vec3_neg(out->n);
    out->le = fns->emission(ctx, light, b1, b2);
    out->pdf_area = l->pick[light] / l->area[light];
    out->prim = l->prims[light];
    out->inst = l->insts[light];
}

/* The slot of the choice between lights that u_pick falls in, with
 * u_pick rescaled to [0, 1) within it. */
RTK_HD static inline uint32_t rtk_light_slot(const rtk_lights *l, float *u_pick)
{
    uint32_t lo = 0, hi = l->slot_count; /* cdf[lo] <= u < cdf[hi] */
    float u = *u_pick;
    if (!(u < 1.0f))
        u = u >= 1.0f ? 0x1.fffffep-1f : 0.0f; /* NaN as 0 */
    else if (!(u >= 0.0f))
        u = 0.0f;
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (l->slot_cdf[mid] <= u)
            lo = mid;
        else
            hi = mid;
    }
    float r = (u - l->slot_cdf[lo]) / l->slot_pick[lo];
    *u_pick = r < 1.0f ? (r > 0.0f ? r : 0.0f) : 0x1.fffffep-1f;
    return lo;
}

/* An emitter point ls as seen from p (normal ng), chosen with probability
 * pick among all lights. */
RTK_HD static inline int rtk_area_incident(const rtk_light_sample *ls, rtk_vec3 p, rtk_vec3 ng, float pick,
                                           rtk_light_incident *out)
{
    rtk_vec3 d = rtk_vec3_sub(ls->p, p);
    float dist2 = rtk_vec3_dot(d, d);
    if (!(dist2 > 0.0f))
        return 0;
    float inv = 1.0f / sqrtf(dist2);
    out->wi = rtk_vec3_scale(d, inv);
    float cos_l = -rtk_vec3_dot(ls->n, out->wi);
    if (!(cos_l > 0.0f))
        return 0;
    out->pdf = ls->pdf_area * dist2 / cos_l * pick;
    out->dist = dist2 * inv;
    out->li = ls->le;
    out->delta = 0;
    out->shadow = rtk_shadow_between(p, ng, ls->p, ls->n);
    return out->pdf > 0.0f && out->pdf < INFINITY;
}

/* rtk_spot_falloff: smoothstep from the outer cone to the inner one. */
RTK_HD static inline float rtk_spot_factor(const rtk_punctual_light *light, float cos_axis)
{
    if (cos_axis <= light->cos_outer)
        return 0.0f;
    if (cos_axis >= light->cos_inner)
        return 1.0f;
    float t = (cos_axis - light->cos_outer) / (light->cos_inner - light->cos_outer);
    return t * t * (3.0f - 2.0f * t);
}

/* A punctual light as seen from p, chosen with probability pick. */
RTK_HD static inline int rtk_punctual_incident(const rtk_punctual_light *pl, rtk_vec3 p, rtk_vec3 ng, float pick,
                                               rtk_light_incident *out)
{
    out->pdf = pick;
    out->delta = 1;
    if (pl->type == RTK_LIGHT_DIRECTIONAL) {
        out->wi = rtk_vec3_neg(pl->direction);
        out->dist = INFINITY;
        out->li = pl->intensity;
        out->shadow = rtk_ray_to_infinity(p, ng, out->wi);
        return 1;
    }
    rtk_vec3 d = rtk_vec3_sub(pl->position, p);
    float r2 = rtk_vec3_dot(d, d);
    if (!(r2 > 0.0f))
        return 0;
    float dist = sqrtf(r2);
    out->wi = rtk_vec3_scale(d, 1.0f / dist);
    out->dist = dist;
    float scale = 1.0f / r2;
    if (pl->type == RTK_LIGHT_SPOT) {
        float falloff = rtk_spot_factor(pl, -rtk_vec3_dot(out->wi, pl->direction));
        if (!(falloff > 0.0f))
            return 0;
        scale *= falloff;
    }
    out->li = rtk_rgb_scale(pl->intensity, scale);
    out->shadow = rtk_shadow_between(p, ng, pl->position, rtk_vec3_make(0.0f, 0.0f, 0.0f));
    return isfinite(scale);
}

/* ---- the environment (an equirectangular map or a constant) ---- */

/* d turned by -rotation about +y: the map's own frame. */
RTK_HD static inline rtk_vec3 rtk_env_to_map(const rtk_environment *env, rtk_vec3 d)
{
    return rtk_vec3_make(env->cos_rot * d.x - env->sin_rot * d.z, d.y, env->sin_rot * d.x + env->cos_rot * d.z);
}

/* Pixel of unit map-frame direction d; sets sin theta. */
RTK_HD static inline size_t rtk_env_pixel(const rtk_environment *env, rtk_vec3 d, float *sin_theta)
{
    float y = fminf(1.0f, fmaxf(-1.0f, d.y));
    float theta = acosf(y);
    float u = 0.5f + atan2f(d.x, -d.z) * (float)(0.5 / RTK_PI), v = theta * (float)(1.0 / RTK_PI);
    int col = (int)(u * (float)env->width), row = (int)(v * (float)env->height);
    col = col < 0 ? 0 : col >= env->width ? env->width - 1 : col;
    row = row < 0 ? 0 : row >= env->height ? env->height - 1 : row;
    *sin_theta = sqrtf(fmaxf(0.0f, 1.0f - y * y));
    return (size_t)row * (size_t)env->width + (size_t)col;
}

/* rtk_environment_radiance. */
RTK_HD static inline rtk_rgb rtk_env_radiance(const rtk_environment *env, rtk_vec3 dir)
{
    if (!env->width)
        return env->color;
    float len = rtk_vec3_length(dir);
    if (!(len > 0.0f) || !isfinite(len))
        return rtk_rgb_make(0.0f, 0.0f, 0.0f);
    float sin_theta;
    const float *rgb = env->rgb + 3 * rtk_env_pixel(env, rtk_env_to_map(env, rtk_vec3_scale(dir, 1.0f / len)),
                                                    &sin_theta);
    return rtk_rgb_make(rgb[0], rgb[1], rgb[2]);
}

/* Index i of n bins with cdf[i] <= u < cdf[i + 1] (cdf[n] = 1 > u), and
 * u's position within it in [0, 1). */
RTK_HD static inline int rtk_env_bin(const float *cdf, int n, float u, float *within)
{
    int lo = 0, hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] <= u)
            lo = mid;
        else
            hi = mid;
    }
    float w = (u - cdf[lo]) / (cdf[lo + 1] - cdf[lo]);
    *within = w < 1.0f ? (w > 0.0f ? w : 0.0f) : 0x1.fffffep-1f;
    return lo;
}

/* The world direction of map coordinates (u, v), and sin theta. */
RTK_HD static inline rtk_vec3 rtk_env_direction(const rtk_environment *env, float u, float v, float *sin_theta)
{
    float theta = (float)RTK_PI * v, phi = 2.0f * (float)RTK_PI * (u - 0.5f);
    float st = sinf(theta), ct = cosf(theta);
    rtk_vec3 m = rtk_vec3_make(st * sinf(phi), ct, -st * cosf(phi));
    *sin_theta = st;
    return rtk_vec3_make(env->cos_rot * m.x + env->sin_rot * m.z, m.y, -env->sin_rot * m.x + env->cos_rot * m.z);
}

/* rtk_environment_pdf. */
RTK_HD static inline float rtk_env_pdf(const rtk_environment *env, rtk_vec3 dir)
{
    if (!env->width)
        return (float)(1.0 / (4.0 * RTK_PI));
    float len = rtk_vec3_length(dir);
    if (!(len > 0.0f) || !isfinite(len) || !(env->func_mean > 0.0))
        return 0.0f;
    float sin_theta;
    size_t i = rtk_env_pixel(env, rtk_env_to_map(env, rtk_vec3_scale(dir, 1.0f / len)), &sin_theta);
    if (!(sin_theta > 0.0f))
        return 0.0f;
    return (float)(env->func[i] / env->func_mean / (2.0 * RTK_PI * RTK_PI * sin_theta));
}

/* rtk_environment_sample. */
RTK_HD static inline float rtk_env_sample(const rtk_environment *env, rtk_vec2 u, rtk_vec3 *wi, rtk_rgb *radiance)
{
    float u0 = fminf(fmaxf(u.x, 0.0f), 0x1.fffffep-1f), u1 = fminf(fmaxf(u.y, 0.0f), 0x1.fffffep-1f);
    if (!env->width) {
        /* Uniform on the sphere. */
        float z = 1.0f - 2.0f * u0, r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * (float)RTK_PI * u1;
        *wi = rtk_vec3_make(r * cosf(phi), z, r * sinf(phi));
        *radiance = env->color;
        return (float)(1.0 / (4.0 * RTK_PI));
    }
    if (!(env->func_mean > 0.0))
        return 0.0f;
    float dv, du;
    int row = rtk_env_bin(env->row_cdf, env->height, u0, &dv);
    const float *cdf = env->col_cdf + (size_t)row * ((size_t)env->width + 1);
    int col = rtk_env_bin(cdf, env->width, u1, &du);
    float sin_theta;
    *wi = rtk_env_direction(env, ((float)col + du) / (float)env->width, ((float)row + dv) / (float)env->height,
                            &sin_theta);
    /* Radiance and pdf of the direction as lookups see it, so that a
     * sample rounded across a pixel edge still agrees with
     * rtk_environment_pdf and rtk_environment_radiance exactly (one
     * rounded into a black pixel has pdf 0: about 1e-5 of the samples of
     * a map with black rows). */
    *radiance = rtk_env_radiance(env, *wi);
    return rtk_env_pdf(env, *wi);
}

/* ---- all lights ---- */

/* rtk_sample_incident_light over table l (with slots), the punctual
 * lights and the emitters fns reads. */
static RTK_HD_INLINE int rtk_lights_incident(const rtk_lights *l, const rtk_punctual_light *punctual,
                                             uint32_t punctual_count, const rtk_emitter_fns *fns, const void *ctx,
                                             rtk_vec3 p, rtk_vec3 ng, float u_pick, rtk_vec2 u,
                                             rtk_light_incident *out)
{
    rtk_light_sample ls;
    if (l->slot_pick[0] == 1.0f) { /* the emitters alone: u_pick as it is */
        rtk_emitter_sample(l, fns, ctx, u_pick, u, &ls);
        return rtk_area_incident(&ls, p, ng, 1.0f, out);
    }
    uint32_t slot = rtk_light_slot(l, &u_pick);
    float pick = l->slot_pick[slot];
    if (slot == 0) {
        rtk_emitter_sample(l, fns, ctx, u_pick, u, &ls);
        return rtk_area_incident(&ls, p, ng, pick, out);
    }
    if (slot <= punctual_count)
        return rtk_punctual_incident(&punctual[slot - 1], p, ng, pick, out);
    float pdf = rtk_env_sample(l->environment, u, &out->wi, &out->li);
    out->pdf = pdf * pick;
    out->dist = INFINITY;
    out->delta = 0;
    out->shadow = rtk_ray_to_infinity(p, ng, out->wi);
    return out->pdf > 0.0f && isfinite(out->pdf);
}

/* rtk_incident_light_pdf for a hit at distance t along ray on an emitter
 * of unit normal n (its emitting side) and area density pdf_area, the
 * emitters' slot chosen with probability pick. */
RTK_HD static inline float rtk_emitter_solid_pdf(rtk_vec3 n, const rtk_ray *ray, float t, float pdf_area, float pick)
{
    float len2 = rtk_vec3_dot(ray->dir, ray->dir);
    float cos_l = -rtk_vec3_dot(n, ray->dir) / sqrtf(len2);
    if (!(cos_l > 0.0f))
        return 0.0f; /* the back of a one-sided emitter */
    float pdf = pdf_area * t * t * len2 / cos_l * pick;
    return isfinite(pdf) ? pdf : 0.0f;
}

#endif
