/* heatmap: the classic BVH heat map. Each camera ray is coloured by the
 * work its closest-hit traversal did (rtk_trace_measure): BVH nodes
 * visited, triangles tested, or both, on a perceptual ramp (Turbo) from
 * dark blue at 0 to dark red at `max` and beyond. Misses are coloured too:
 * a ray that leaves the scene's box early is cheap, one that grazes
 * geometry is not. The legend's range is logged once per render.
 *
 * Parameters:
 *   measure  string nodes|triangles|both  both   what is counted
 *   max      float [1, 1e6]               100.0  count shown at the top of the ramp
 *
 * Example: integrator = { plugin = "heatmap"; measure = "nodes"; max = 40; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef enum heatmap_measure { MEASURE_NODES, MEASURE_TRIANGLES, MEASURE_BOTH } heatmap_measure;

typedef struct heatmap {
    heatmap_measure measure;
    float max;
} heatmap;

static const char *const measure_names[] = {"nodes", "triangles", "nodes+triangles"};

static rtk_status heatmap_create(const rtk_params *params, void **state)
{
    heatmap *h = malloc(sizeof *h);
    if (!h)
        return rtk_error(RTK_ERR_NOMEM, "heatmap: out of memory");
    const char *m = rtk_params_string(params, "measure");
    h->measure = strcmp(m, "nodes") == 0 ? MEASURE_NODES : strcmp(m, "triangles") == 0 ? MEASURE_TRIANGLES : MEASURE_BOTH;
    h->max = (float)rtk_params_float(params, "max");
    *state = h;
    return RTK_OK;
}

static uint32_t heatmap_needs(const void *state)
{
    (void)state;
    return 0;
}

static rtk_status heatmap_prepare(void *state, const rtk_scene *scene)
{
    const heatmap *h = state;
    (void)scene;
    rtk_log(RTK_LOG_INFO, "heatmap: dark blue = 0, dark red = %g or more %s per camera ray", (double)h->max,
            measure_names[h->measure]);
    return RTK_OK;
}

/* sRGB-encoded value to linear (the film is linear; PNG output encodes). */
static float srgb_to_linear(float c)
{
    c = c < 0.0f ? 0.0f : c > 1.0f ? 1.0f : c;
    return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
}

/* Turbo colour map (Mikhailov 2019), polynomial fit, x in [0, 1]. */
static rtk_rgb turbo(float x)
{
    x = x < 0.0f ? 0.0f : x > 1.0f ? 1.0f : x;
    float r = 0.13572138f + x * (4.61539260f + x * (-42.66032258f + x * (132.13108234f + x * (-152.94239396f + x * 59.28637943f))));
    float g = 0.09140261f + x * (2.19418839f + x * (4.84296658f + x * (-14.18503333f + x * (4.27729857f + x * 2.82956604f))));
    float b = 0.10667330f + x * (12.64194608f + x * (-60.58204836f + x * (110.36276771f + x * (-89.90310912f + x * 27.34824973f))));
    return rtk_rgb_make(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b));
}

static void heatmap_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    const heatmap *h = state;
    rtk_hit hit;
    rtk_trace_work work;
    int found = rtk_trace_measure(ctx, ray, &hit, &work);
    float count = h->measure == MEASURE_NODES       ? (float)work.nodes
                  : h->measure == MEASURE_TRIANGLES ? (float)work.triangles
                                                    : (float)work.nodes + (float)work.triangles;
    out->radiance = turbo(count / h->max);
    out->albedo = out->radiance;
    if (found)
        out->depth = hit.t * rtk_vec3_length(ray->dir);
}

static void heatmap_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc heatmap_params[] = {
    {.name = "measure", .type = RTK_PARAM_STRING, .def_string = "both", .choices = "nodes|triangles|both",
     .doc = "count BVH nodes visited, triangles tested, or their sum"},
    {.name = "max", .type = RTK_PARAM_FLOAT, .def = 100.0, .min = 1.0, .max = 1e6,
     .doc = "count shown at the top (dark red) of the colour ramp"},
};

static const rtk_integrator_fns heatmap_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = heatmap_create,
    .needs = heatmap_needs,
    .prepare = heatmap_prepare,
    .li = heatmap_li,
    .destroy = heatmap_destroy,
};

static const rtk_plugin heatmap_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "heatmap",
    .version = "1.0",
    .summary = "BVH heat map: colour by nodes visited and triangles tested per camera ray",
    .params = heatmap_params,
    .param_count = RTK_COUNTOF(heatmap_params),
    .functions = &heatmap_fns,
};

RTK_PLUGIN_ENTRY(heatmap_plugin)
