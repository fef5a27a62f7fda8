/* oot_tent: a tent filter built outside the tree, with cc and pkg-config
 * alone, by tests/install (the way README's "Install and use as a library"
 * builds a plugin).
 *
 * Parameters:
 *   radius  float [0.5, 8]  1   half-width of the support, pixels
 *
 * Example: filter = { plugin = "oot_tent"; radius = 1.5; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct oot_tent {
    float radius;
} oot_tent;

static rtk_status tent_create(const rtk_params *params, void **state)
{
    oot_tent *t = malloc(sizeof *t);
    if (!t)
        return rtk_error(RTK_ERR_NOMEM, "oot_tent: out of memory");
    t->radius = (float)rtk_params_float(params, "radius");
    *state = t;
    return RTK_OK;
}

static float tent_radius(const void *state)
{
    return ((const oot_tent *)state)->radius;
}

static float tent_eval(const void *state, float dx, float dy)
{
    float r = ((const oot_tent *)state)->radius;
    return fmaxf(0.0f, 1.0f - fabsf(dx) / r) * fmaxf(0.0f, 1.0f - fabsf(dy) / r);
}

static double tent_integral(const void *state)
{
    double r = ((const oot_tent *)state)->radius;
    return r * r;
}

static void tent_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc tent_params[] = {
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.5, .max = 8.0,
     .doc = "half-width of the support in pixels"},
};

static const rtk_filter_fns tent_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = tent_create,
    .radius = tent_radius,
    .eval = tent_eval,
    .integral = tent_integral,
    .destroy = tent_destroy,
};

static const rtk_plugin tent_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "oot_tent",
    .version = "1.0",
    .summary = "tent filter built out of the tree (tests/install)",
    .params = tent_params,
    .param_count = RTK_COUNTOF(tent_params),
    .functions = &tent_fns,
};

RTK_PLUGIN_ENTRY(tent_plugin)
