/* box: every sample within the radius counts equally.
 *
 * Parameters:
 *   radius  float [0.001, 16]  0.5   half-width of the square support, pixels
 *
 * Example: filter = { plugin = "box"; radius = 0.5; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct box {
    float radius;
} box;

static rtk_status box_create(const rtk_params *params, void **state)
{
    box *b = malloc(sizeof *b);
    if (!b)
        return rtk_error(RTK_ERR_NOMEM, "box: out of memory");
    b->radius = (float)rtk_params_float(params, "radius");
    *state = b;
    return RTK_OK;
}

static float box_radius(const void *state)
{
    return ((const box *)state)->radius;
}

static float box_eval(const void *state, float dx, float dy)
{
    float r = ((const box *)state)->radius;
    return fabsf(dx) <= r && fabsf(dy) <= r ? 1.0f : 0.0f;
}

static double box_integral(const void *state)
{
    double side = 2.0 * ((const box *)state)->radius;
    return side * side;
}

static void box_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc box_params[] = {
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 0.5, .min = 0.001, .max = 16.0,
     .doc = "half-width of the square support in pixels (0.5 = one pixel)"},
};

static const rtk_filter_fns box_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = box_create,
    .radius = box_radius,
    .eval = box_eval,
    .integral = box_integral,
    .destroy = box_destroy,
};

static const rtk_plugin box_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "box",
    .version = "1.0",
    .summary = "box filter: equal weight over a square of the given radius",
    .params = box_params,
    .param_count = RTK_COUNTOF(box_params),
    .functions = &box_fns,
};

RTK_PLUGIN_ENTRY(box_plugin)
