/* mitchell: the Mitchell-Netravali cubic family (Mitchell and Netravali,
 * "Reconstruction filters in computer graphics", 1988), k(2x/r) k(2y/r)
 * where k is the canonical kernel on |t| < 2:
 *   6 k(t) = (12 - 9B - 6C)|t|^3 + (-18 + 12B + 6C)t^2 + (6 - 2B)           |t| < 1
 *   6 k(t) = (-B - 6C)|t|^3 + (6B + 30C)t^2 + (-12B - 48C)|t| + (8B + 24C)  1 <= |t| < 2
 * Its integer translates sum to 1 for every B and C (at radius 2 the
 * translates are one pixel apart). On 1 <= |t| < 2 it equals
 * B (2 - |t|)^3 / 6 - C (|t| - 1)(2 - |t|)^2, which dips below 0 towards
 * |t| = 2 whenever C > 0; the negative values are returned as they are.
 *
 * Parameters:
 *   B       float [0, 1]   1/3   blur: 1 is the cubic B-spline, 0 sharpest
 *   C       float [0, 1]   1/3   ringing: larger C, deeper negative lobes
 *   radius  float [1, 16]  2     half-width of the support, pixels (2 = the
 *                                standard kernel; at 1 and above a sample
 *                                in a pixel never lands in that pixel's
 *                                negative lobe)
 *
 * Example: filter = { plugin = "mitchell"; B = 0.2; C = 0.4; radius = 2; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct mitchell {
    float radius, scale; /* scale = 2 / radius maps offsets to t */
    float inner[4];      /* k on |t| < 1, by powers of |t| */
    float outer[4];      /* k on 1 <= |t| < 2, by powers of |t| */
} mitchell;

static float mitchell_1d(const mitchell *m, float x)
{
    float a = fabsf(x);
    if (!(a < m->radius))
        return 0.0f;
    float t = a * m->scale;
    if (t < 1.0f)
        return m->inner[0] + t * (m->inner[1] + t * (m->inner[2] + t * m->inner[3]));
    if (t < 2.0f)
        return m->outer[0] + t * (m->outer[1] + t * (m->outer[2] + t * m->outer[3]));
    return 0.0f;
}

static rtk_status mitchell_create(const rtk_params *params, void **state)
{
    mitchell *m = malloc(sizeof *m);
    if (!m)
        return rtk_error(RTK_ERR_NOMEM, "mitchell: out of memory");
    double b = rtk_params_float(params, "B"), c = rtk_params_float(params, "C");
    m->radius = (float)rtk_params_float(params, "radius");
    m->scale = 2.0f / m->radius;
    m->inner[0] = (float)((6.0 - 2.0 * b) / 6.0);
    m->inner[1] = 0.0f;
    m->inner[2] = (float)((-18.0 + 12.0 * b + 6.0 * c) / 6.0);
    m->inner[3] = (float)((12.0 - 9.0 * b - 6.0 * c) / 6.0);
    m->outer[0] = (float)((8.0 * b + 24.0 * c) / 6.0);
    m->outer[1] = (float)((-12.0 * b - 48.0 * c) / 6.0);
    m->outer[2] = (float)((6.0 * b + 30.0 * c) / 6.0);
    m->outer[3] = (float)((-b - 6.0 * c) / 6.0);
    *state = m;
    return RTK_OK;
}

static float mitchell_radius(const void *state)
{
    return ((const mitchell *)state)->radius;
}

static float mitchell_eval(const void *state, float dx, float dy)
{
    const mitchell *m = state;
    return mitchell_1d(m, dx) * mitchell_1d(m, dy);
}

/* The canonical kernel integrates to 1 over |t| < 2 for every B and C:
 * int_0^1 6k = 3 - B/4 + C/2 and int_1^2 6k = B/4 - C/2, so the two sides
 * give 2 * 3 / 6. Then int k(2x/r) dx over |x| < r is r/2, and the
 * separable product integrates to (r/2)^2. */
static double mitchell_integral(const void *state)
{
    double half = 0.5 * ((const mitchell *)state)->radius;
    return half * half;
}

static void mitchell_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc mitchell_params[] = {
    {.name = "B", .type = RTK_PARAM_FLOAT, .def = 1.0 / 3.0, .min = 0.0, .max = 1.0,
     .doc = "blur: 1 is the cubic B-spline, 0 the sharpest; B + 2C = 1 is the recommended line"},
    {.name = "C", .type = RTK_PARAM_FLOAT, .def = 1.0 / 3.0, .min = 0.0, .max = 1.0,
     .doc = "ringing: larger C gives deeper negative lobes"},
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 2.0, .min = 1.0, .max = 16.0,
     .doc = "half-width of the square support in pixels (2 = the standard kernel)"},
};

static const rtk_filter_fns mitchell_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = mitchell_create,
    .radius = mitchell_radius,
    .eval = mitchell_eval,
    .integral = mitchell_integral,
    .destroy = mitchell_destroy,
};

static const rtk_plugin mitchell_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "mitchell",
    .version = "1.0",
    .summary = "Mitchell-Netravali cubic filter (B, C); separable, negative lobes kept",
    .params = mitchell_params,
    .param_count = RTK_COUNTOF(mitchell_params),
    .functions = &mitchell_fns,
};

RTK_PLUGIN_ENTRY(mitchell_plugin)
