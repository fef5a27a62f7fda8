/* path: unidirectional path tracing with next-event estimation. Every
 * vertex samples one light of all (emissive triangles, point, spot,
 * directional, environment; chosen by power) and one direction of the
 * surface's BSDF (the kernel's material mapping, rtk/bsdf.h); the two are
 * combined by multiple importance sampling with the power heuristic, delta
 * lights and delta lobes taking their one strategy whole. Paths end by
 * Russian roulette from rr_depth on (survival = the path throughput's
 * largest channel, at most 1), at max_depth, or on leaving the scene,
 * where they see the environment. Each bounce reads its random numbers
 * from its own block of 8 sampler dimensions (rtk_sample_seek), so
 * stratified and Sobol draws stay stratified along paths of any length.
 *
 * Parameters:
 *   max_depth  int [0, 1024]  8  bounces: 0 = emitters only, 1 = direct light
 *   rr_depth   int [1, 1024]  3  first bounce at which Russian roulette may end a path
 *   clamp      float >= 0     0  largest channel of one contribution (0 = no clamping; biased)
 *
 * Example: integrator = { plugin = "path"; max_depth = 8; };
 */
#include "path_estimator.h"

#include <rtk/rtk.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static rtk_status path_create(const rtk_params *params, void **state)
{
    rtk_path_params *p = malloc(sizeof *p);
    if (!p)
        return rtk_error(RTK_ERR_NOMEM, "path: out of memory");
    p->max_depth = (int)rtk_params_int(params, "max_depth");
    p->rr_depth = (int)rtk_params_int(params, "rr_depth");
    p->clamp = (float)rtk_params_float(params, "clamp");
    *state = p;
    return RTK_OK;
}

static uint32_t path_needs(const void *state)
{
    (void)state;
    return RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
}

/* A scene with nothing that emits renders black: say so once, up front. */
static rtk_status path_prepare(void *state, const rtk_scene *scene)
{
    (void)state;
    rtk_light_incident sky;
    const rtk_vec2 mid = {0.5f, 0.5f};
    if (!rtk_scene_light_count(scene) && !rtk_scene_punctual_count(scene) &&
        !rtk_sample_incident_light(scene, rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 0, 0), 0.5f, mid, &sky))
        rtk_log(RTK_LOG_WARN, "path: the scene has no lights (emissive triangles: MTL Ke, glTF emissive; config "
                              "lights or environment): the image will be black");
    return RTK_OK;
}

/* The device program of this instance (device_programs.h, "path"). */
static int path_device_program(const void *state, rtk_device_program *out)
{
    const rtk_path_params *p = state;
    memset(out, 0, sizeof *out);
    snprintf(out->name, sizeof out->name, "path");
    out->params[0] = (float)p->max_depth;
    out->params[1] = (float)p->rr_depth;
    out->params[2] = p->clamp;
    return 1;
}

/* Adds beta x c to L (weighted). */
static void add(const rtk_path_params *pt, rtk_rgb *L, rtk_rgb beta, rtk_rgb c)
{
    *L = rtk_rgb_add(*L, rtk_path_weighted(pt, beta, c));
}

/* Weight of light the ray finds (an emitter it hits, or the environment
 * when hit is NULL) against sampling that light from where the ray left. */
static float found_weight(const rtk_scene *scene, const rtk_path_state *ps, const rtk_ray *ray, const rtk_hit *hit)
{
    return ps->delta ? 1.0f : rtk_path_found_weight(ps, rtk_incident_light_pdf(scene, ps->from, ray, hit));
}

/* A path between two traces: its state, radiance so far, and a light
 * sample's contribution waiting for its shadow ray. */
typedef struct path_vertex {
    rtk_path_state ps;
    rtk_rgb L;
    int shadowed;    /* 1: nee and shadow hold a pending light sample */
    rtk_rgb nee;     /* added to L when shadow is unoccluded */
    rtk_ray shadow;
} path_vertex;

/* Bounce pv->ps.depth of the current sample, whose ray found hit (or
 * missed: hit NULL): adds what it finds to pv->L, samples a light (left
 * pending in pv) and the next direction. Returns 1 with the next ray in
 * *ray, 0 when the path ends. */
static int bounce(const rtk_path_params *pt, rtk_ctx *ctx, path_vertex *pv, rtk_ray *ray, const rtk_hit *hit,
                  rtk_li_result *out)
{
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_path_state *ps = &pv->ps;
    pv->shadowed = 0;
    if (!hit) {
        rtk_rgb env = rtk_scene_environment(scene, ray->dir);
        if (!rtk_path_is_black(env))
            add(pt, &pv->L, ps->beta, rtk_rgb_scale(env, found_weight(scene, ps, ray, NULL)));
        return 0;
    }
    rtk_surface s;
    rtk_ray_differential diff;
    if (ps->depth == 0 && rtk_ctx_camera_differential(ctx, &diff))
        rtk_surface_at_footprint(scene, ray, &diff, hit, &s);
    else
        rtk_surface_at(scene, ray, hit, &s);
    if (ps->depth == 0) {
        out->albedo = s.base_color;
        out->normal = s.ns;
        out->depth = hit->t * rtk_vec3_length(ray->dir);
    }
    if (s.front_face && !rtk_path_is_black(s.emission))
        add(pt, &pv->L, ps->beta, rtk_rgb_scale(s.emission, found_weight(scene, ps, ray, hit)));
    if (ps->depth >= pt->max_depth)
        return 0;
    rtk_bsdf bsdf;
    rtk_surface_bsdf(scene, hit, &s, &bsdf);
    if (bsdf.count == 0)
        return 0;
    rtk_path_vertex v = rtk_path_vertex_at(s.ng, s.ns, s.front_face, &bsdf, ray->dir);
    if (rtk_bsdf_flags(&bsdf) & (RTK_BSDF_DIFFUSE | RTK_BSDF_GLOSSY)) {
        float u_pick = rtk_sample_1d(ctx);
        rtk_vec2 u = rtk_sample_2d(ctx);
        rtk_light_incident li;
        rtk_rgb c;
        if (rtk_sample_incident_light(scene, s.p, s.ng, u_pick, u, &li) && rtk_path_light(&v, &bsdf, &li, &c)) {
            pv->nee = rtk_path_weighted(pt, ps->beta, c);
            pv->shadow = li.shadow;
            pv->shadowed = 1;
        }
    }
    float u_lobe = rtk_sample_1d(ctx);
    rtk_vec2 u = rtk_sample_2d(ctx);
    rtk_bsdf_sample_out bs;
    rtk_vec3 side;
    float m;
    if (!rtk_bsdf_sample(&bsdf, v.wo, u_lobe, u, &bs) || !(bs.pdf > 0.0f) ||
        !rtk_path_scatter(ps, &v, s.p, s.ng, &bs, ray, &side) ||
        (rtk_path_roulette_due(pt, ps, &m) && !rtk_path_survives(ps, m, rtk_sample_1d(ctx))))
        return 0;
    ray->org = rtk_offset_ray_origin(s.p, side);
    return 1;
}

static void start(path_vertex *pv, const rtk_ray *camera_ray)
{
    pv->ps = rtk_path_start(camera_ray->org);
    pv->L = rtk_rgb_make(0, 0, 0);
    pv->shadowed = 0;
}

static void path_li(const void *state, rtk_ctx *ctx, const rtk_ray *camera_ray, rtk_li_result *out)
{
    path_vertex pv;
    start(&pv, camera_ray);
    rtk_ray ray = *camera_ray;
    for (int more = 1; more; pv.ps.depth++) {
        rtk_sample_seek(ctx, (uint32_t)pv.ps.depth * RTK_PATH_DIMS_PER_BOUNCE);
        rtk_hit hit;
        more = bounce(state, ctx, &pv, &ray, rtk_trace(ctx, &ray, &hit) ? &hit : NULL, out);
        if (pv.shadowed && !rtk_occluded(ctx, &pv.shadow))
            pv.L = rtk_rgb_add(pv.L, pv.nee);
    }
    out->radiance = pv.L;
}

/* The batch as a wavefront: each bounce traces the live paths' rays in
 * one batch, shades them sample by sample, then traces their shadow rays
 * in one batch; the sums are li's, in li's order. */
static void path_li_batch(const void *state, rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, rtk_li_result *out)
{
    path_vertex pv[RTK_BATCH_MAX];
    rtk_ray ray[RTK_BATCH_MAX], shadow[RTK_BATCH_MAX];
    rtk_hit hit[RTK_BATCH_MAX];
    uint16_t who[RTK_BATCH_MAX], shadow_who[RTK_BATCH_MAX];
    uint8_t blocked[RTK_BATCH_MAX];
    uint32_t live = count;
    for (uint32_t i = 0; i < count; i++) {
        start(&pv[i], &rays[i]);
        ray[i] = rays[i];
        who[i] = (uint16_t)i;
    }
    for (uint32_t depth = 0; live; depth++) {
        /* At depth 0 slot i is sample i: rtk_trace_batch knows the camera rays. */
        rtk_trace_batch(ctx, ray, live, hit);
        uint32_t next = 0, shadows = 0;
        for (uint32_t k = 0; k < live; k++) {
            uint32_t i = who[k];
            rtk_ctx_select(ctx, i);
            rtk_sample_seek(ctx, depth * RTK_PATH_DIMS_PER_BOUNCE);
            rtk_ray r = ray[k];
            int more = bounce(state, ctx, &pv[i], &r, hit[k].prim != RTK_INVALID_ID ? &hit[k] : NULL, &out[i]);
            pv[i].ps.depth++;
            if (pv[i].shadowed) {
                shadow[shadows] = pv[i].shadow;
                shadow_who[shadows++] = (uint16_t)i;
            }
            if (more) {
                ray[next] = r;
                who[next++] = (uint16_t)i;
            }
        }
        rtk_occluded_batch(ctx, shadow, shadows, blocked);
        for (uint32_t k = 0; k < shadows; k++)
            if (!blocked[k])
                pv[shadow_who[k]].L = rtk_rgb_add(pv[shadow_who[k]].L, pv[shadow_who[k]].nee);
        live = next;
    }
    for (uint32_t i = 0; i < count; i++)
        out[i].radiance = pv[i].L;
}

static void path_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc path_params[] = {
    {.name = "max_depth", .type = RTK_PARAM_INT, .def = 8, .min = 0, .max = 1024,
     .doc = "bounces (0 = emitters only, 1 = direct light)"},
    {.name = "rr_depth", .type = RTK_PARAM_INT, .def = 3, .min = 1, .max = 1024,
     .doc = "first bounce at which Russian roulette may end a path"},
    {.name = "clamp", .type = RTK_PARAM_FLOAT, .def = 0, .min = 0, .max = INFINITY,
     .doc = "largest channel of one light contribution, 0 = no clamping (clamping is biased)"},
};

static const rtk_integrator_fns path_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = path_create,
    .needs = path_needs,
    .prepare = path_prepare,
    .li = path_li,
    .destroy = path_destroy,
    .li_batch = path_li_batch,
    .device_program = path_device_program,
};

static const rtk_plugin path_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "path",
    .version = "1.0",
    .summary = "path tracing: BSDFs, every light type, next-event estimation with MIS, Russian roulette",
    .params = path_params,
    .param_count = RTK_COUNTOF(path_params),
    .functions = &path_fns,
    .conform = "path-tracing,environment-light",
};

RTK_PLUGIN_ENTRY(path_plugin)
