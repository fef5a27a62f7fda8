/* triangle: a tent, (1 - |x|/r)(1 - |y|/r) inside the square of radius r
 * and 0 beyond. Never negative.
 *
 * Parameters:
 *   radius  float [0.5, 16]  1     half-width of the square support, pixels
 *
 * Example: filter = { plugin = "triangle"; radius = 1; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct triangle {
    float radius;
} triangle;

static float triangle_1d(float radius, float x)
{
    float a = fabsf(x);
    return a < radius ? (radius - a) / radius : 0.0f;
}

static rtk_status triangle_create(const rtk_params *params, void **state)
{
    triangle *t = malloc(sizeof *t);
    if (!t)
        return rtk_error(RTK_ERR_NOMEM, "triangle: out of memory");
    t->radius = (float)rtk_params_float(params, "radius");
    *state = t;
    return RTK_OK;
}

static float triangle_radius(const void *state)
{
    return ((const triangle *)state)->radius;
}

static float triangle_eval(const void *state, float dx, float dy)
{
    float r = ((const triangle *)state)->radius;
    return triangle_1d(r, dx) * triangle_1d(r, dy);
}

/* Each axis integrates to r (a triangle of base 2r and height 1). */
static double triangle_integral(const void *state)
{
    double r = ((const triangle *)state)->radius;
    return r * r;
}

static void triangle_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc triangle_params[] = {
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.5, .max = 16.0,
     .doc = "half-width of the square support in pixels; the weight falls linearly to 0 there"},
};

static const rtk_filter_fns triangle_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = triangle_create,
    .radius = triangle_radius,
    .eval = triangle_eval,
    .integral = triangle_integral,
    .destroy = triangle_destroy,
};

static const rtk_plugin triangle_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "triangle",
    .version = "1.0",
    .summary = "triangle (tent) filter: weight falls linearly to 0 at the radius; separable",
    .params = triangle_params,
    .param_count = RTK_COUNTOF(triangle_params),
    .functions = &triangle_fns,
};

RTK_PLUGIN_ENTRY(triangle_plugin)
