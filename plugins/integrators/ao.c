/* ao: ambient occlusion with cosine-weighted rays around the shading
 * normal. A pixel shows the fraction of rays that travel `distance`
 * without hitting anything (times the albedo when asked).
 *
 * Parameters:
 *   rays      int [1, 4096]        16     occlusion rays per camera ray
 *   distance  float (0, inf]       inf    how far a ray must get to count as open
 *   albedo    bool                 false  multiply by the surface's base colour
 *
 * Example: integrator = { plugin = "ao"; rays = 64; distance = 0.5; };
 */
#include "ao_estimator.h"

#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct ao {
    int rays;
    float distance;
    int albedo;
} ao;

static rtk_status ao_create(const rtk_params *params, void **state)
{
    ao *a = malloc(sizeof *a);
    if (!a)
        return rtk_error(RTK_ERR_NOMEM, "ao: out of memory");
    a->rays = (int)rtk_params_int(params, "rays");
    a->distance = (float)rtk_params_float(params, "distance");
    a->albedo = rtk_params_bool(params, "albedo");
    *state = a;
    return RTK_OK;
}

static uint32_t ao_needs(const void *state)
{
    const ao *a = state;
    return RTK_NEED_NORMALS | (a->albedo ? RTK_NEED_MATERIALS | RTK_NEED_TEXTURES : 0u);
}

/* The hit's surface (the current sample's camera ray) into out's AOVs. */
static void surface(const ao *a, rtk_ctx *ctx, const rtk_ray *ray, const rtk_hit *hit, rtk_surface *s,
                    rtk_li_result *out)
{
    /* Textures only matter with albedo: then the pixel footprint picks their detail. */
    rtk_ray_differential diff;
    int has_diff = a->albedo && rtk_ctx_camera_differential(ctx, &diff);
    rtk_surface_at_footprint(rtk_ctx_scene(ctx), ray, has_diff ? &diff : NULL, hit, s);
    out->albedo = s->base_color;
    out->normal = s->ns;
    out->depth = hit->t * rtk_vec3_length(ray->dir);
}

/* The next occlusion ray around s (the current sample's next draw);
 * 0 when it points below the surface (rtk_ao_ray). */
static int occlusion_ray(const ao *a, rtk_ctx *ctx, const rtk_surface *s, rtk_vec3 b1, rtk_vec3 b2, rtk_ray *r)
{
    return rtk_ao_ray(rtk_sample_2d(ctx), rtk_offset_ray_origin(s->p, s->ng), s->ng, s->ns, b1, b2, a->distance, r);
}

static void finish(const ao *a, int open, rtk_rgb base_color, rtk_li_result *out)
{
    out->radiance = rtk_ao_value(open, a->rays, a->albedo, base_color);
}

static void ao_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    const ao *a = state;
    rtk_hit hit;
    if (!rtk_trace(ctx, ray, &hit))
        return;
    rtk_surface s;
    surface(a, ctx, ray, &hit, &s, out);
    rtk_vec3 b1, b2;
    rtk_ao_basis(s.ns, &b1, &b2);
    int open = 0;
    for (int i = 0; i < a->rays; i++) {
        rtk_ray r;
        if (occlusion_ray(a, ctx, &s, b1, b2, &r) && !rtk_occluded(ctx, &r))
            open++;
    }
    finish(a, open, s.base_color, out);
}

/* Occlusion rays gathered from several samples before one batch call. */
#define AO_WAVE 1024u

/* The camera rays traced as a batch; then every hit's occlusion rays,
 * sample after sample, traced in waves of AO_WAVE. */
static void ao_li_batch(const void *state, rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, rtk_li_result *out)
{
    const ao *a = state;
    rtk_hit hits[RTK_BATCH_MAX];
    int open[RTK_BATCH_MAX] = {0};
    rtk_ray wave[AO_WAVE];
    uint16_t owner[AO_WAVE];
    uint8_t blocked[AO_WAVE];
    uint32_t n = 0;
    rtk_trace_batch(ctx, rays, count, hits);
    for (uint32_t i = 0; i < count; i++) {
        if (hits[i].prim == RTK_INVALID_ID)
            continue;
        rtk_ctx_select(ctx, i);
        rtk_surface s;
        surface(a, ctx, &rays[i], &hits[i], &s, &out[i]);
        rtk_vec3 b1, b2;
        rtk_ao_basis(s.ns, &b1, &b2);
        for (int k = 0; k < a->rays; k++) {
            if (!occlusion_ray(a, ctx, &s, b1, b2, &wave[n]))
                continue;
            owner[n++] = (uint16_t)i;
            if (n == AO_WAVE) {
                rtk_occluded_batch(ctx, wave, n, blocked);
                for (uint32_t j = 0; j < n; j++)
                    open[owner[j]] += !blocked[j];
                n = 0;
            }
        }
    }
    rtk_occluded_batch(ctx, wave, n, blocked);
    for (uint32_t j = 0; j < n; j++)
        open[owner[j]] += !blocked[j];
    for (uint32_t i = 0; i < count; i++)
        if (hits[i].prim != RTK_INVALID_ID)
            finish(a, open[i], out[i].albedo, &out[i]);
}

/* Device program "ao" (plugins/integrators/device_programs.h): params
 * rays, distance and albedo (0 or 1). */
static int ao_device_program(const void *state, rtk_device_program *program)
{
    const ao *a = state;
    memset(program, 0, sizeof *program);
    strcpy(program->name, "ao");
    program->params[0] = (float)a->rays;
    program->params[1] = a->distance;
    program->params[2] = a->albedo ? 1.0f : 0.0f;
    return 1;
}

static void ao_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc ao_params[] = {
    {.name = "rays", .type = RTK_PARAM_INT, .def = 16, .min = 1, .max = 4096,
     .doc = "occlusion rays per camera ray"},
    {.name = "distance", .type = RTK_PARAM_FLOAT, .def = INFINITY, .min = 1e-30, .max = INFINITY,
     .doc = "length an occlusion ray must travel unblocked (inf = any distance)"},
    {.name = "albedo", .type = RTK_PARAM_BOOL, .def = 0,
     .doc = "multiply the occlusion by the surface's base colour"},
};

static const rtk_integrator_fns ao_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = ao_create,
    .needs = ao_needs,
    .li = ao_li,
    .li_batch = ao_li_batch,
    .destroy = ao_destroy,
    .device_program = ao_device_program,
};

static const rtk_plugin ao_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "ao",
    .version = "1.0",
    .summary = "ambient occlusion: fraction of cosine-weighted rays that escape",
    .params = ao_params,
    .param_count = RTK_COUNTOF(ao_params),
    .functions = &ao_fns,
    .conform = "ambient-occlusion",
};

RTK_PLUGIN_ENTRY(ao_plugin)
