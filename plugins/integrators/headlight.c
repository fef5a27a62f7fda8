/* headlight: base colour x |cos| between the shading normal and the view
 * ray, as if a light sat on the camera. The quick look at any scene.
 *
 * Parameters:
 *   ambient  float [0, 1]  0.0   light added regardless of angle
 *
 * Example: integrator = { plugin = "headlight"; ambient = 0.05; };
 */
#include "headlight_estimator.h"

#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct headlight {
    float ambient;
} headlight;

static rtk_status headlight_create(const rtk_params *params, void **state)
{
    headlight *h = malloc(sizeof *h);
    if (!h)
        return rtk_error(RTK_ERR_NOMEM, "headlight: out of memory");
    h->ambient = (float)rtk_params_float(params, "ambient");
    *state = h;
    return RTK_OK;
}

static uint32_t headlight_needs(const void *state)
{
    (void)state;
    return RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES;
}

/* The camera ray's colour at its hit (the current sample's). */
static void shade(const headlight *h, rtk_ctx *ctx, const rtk_ray *ray, rtk_hit hit, rtk_li_result *out)
{
    /* The camera ray's pixel footprint picks the texture detail. */
    rtk_ray_differential diff;
    int has_diff = rtk_ctx_camera_differential(ctx, &diff);
    rtk_surface s;
    rtk_surface_at_footprint(rtk_ctx_scene(ctx), ray, has_diff ? &diff : NULL, &hit, &s);
    out->radiance = rtk_headlight_value(s.base_color, s.ns, ray->dir, h->ambient);
    out->albedo = s.base_color;
    out->normal = s.ns;
    out->depth = hit.t * rtk_vec3_length(ray->dir);
}

static void headlight_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    rtk_hit hit;
    if (rtk_trace(ctx, ray, &hit))
        shade(state, ctx, ray, hit, out);
}

/* The camera rays traced as one batch, then shaded one by one. */
static void headlight_li_batch(const void *state, rtk_ctx *ctx, const rtk_ray *rays, uint32_t count,
                               rtk_li_result *out)
{
    rtk_hit hits[RTK_BATCH_MAX];
    rtk_trace_batch(ctx, rays, count, hits);
    for (uint32_t i = 0; i < count; i++) {
        if (hits[i].prim == RTK_INVALID_ID)
            continue;
        rtk_ctx_select(ctx, i);
        shade(state, ctx, &rays[i], hits[i], &out[i]);
    }
}

/* Device program "headlight" (plugins/integrators/device_programs.h): params ambient. */
static int headlight_device_program(const void *state, rtk_device_program *program)
{
    const headlight *h = state;
    memset(program, 0, sizeof *program);
    strcpy(program->name, "headlight");
    program->params[0] = h->ambient;
    return 1;
}

static void headlight_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc headlight_params[] = {
    {.name = "ambient", .type = RTK_PARAM_FLOAT, .def = 0.0, .min = 0.0, .max = 1.0,
     .doc = "fraction of the base colour shown regardless of the angle"},
};

static const rtk_integrator_fns headlight_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = headlight_create,
    .needs = headlight_needs,
    .li = headlight_li,
    .li_batch = headlight_li_batch,
    .destroy = headlight_destroy,
    .device_program = headlight_device_program,
};

static const rtk_plugin headlight_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "headlight",
    .version = "1.0",
    .summary = "base colour x |cos(shading normal, view ray)|: a light on the camera",
    .params = headlight_params,
    .param_count = RTK_COUNTOF(headlight_params),
    .functions = &headlight_fns,
    .conform = "headlight-shading",
};

RTK_PLUGIN_ENTRY(headlight_plugin)
