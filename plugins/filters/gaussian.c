/* gaussian: a Gaussian bump cut off at the radius, g(x) g(y) with
 * g(x) = exp(-x^2 / (2 sigma^2)) - exp(-radius^2 / (2 sigma^2)) for
 * |x| < radius and 0 beyond, so the weight falls to 0 at the edge instead
 * of jumping there. Never negative.
 *
 * Parameters:
 *   sigma   float [0.1, 16]   0.5   standard deviation of the bump, pixels
 *   radius  float [0.5, 16]   1.5   half-width of the square support, pixels
 *
 * Example: filter = { plugin = "gaussian"; sigma = 0.5; radius = 1.5; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct gaussian {
    float sigma, radius;
    float inv_two_var; /* 1 / (2 sigma^2) */
} gaussian;

/* exp(-a^2/(2 s^2)) - exp(-r^2/(2 s^2)) written as
 * -exp(-a^2/(2 s^2)) expm1(-(r - a)(r + a)/(2 s^2)): no cancellation near
 * the edge, where the two exponentials are almost equal. */
static float gaussian_1d(const gaussian *g, float x)
{
    float a = fabsf(x);
    if (!(a < g->radius))
        return 0.0f;
    return -expf(-a * a * g->inv_two_var) * expm1f(-(g->radius - a) * (g->radius + a) * g->inv_two_var);
}

/* 2 int_0^a (exp(-t^2) - exp(-a^2)) dt = sqrt(pi) erf(a) - 2 a exp(-a^2),
 * by its Taylor series below a = 1, where the closed form cancels. */
static double gaussian_cut_integral(double a)
{
    if (a >= 1.0)
        return sqrt(M_PI) * erf(a) - 2.0 * a * exp(-a * a);
    /* sum_{n>=1} (-1)^(n+1) 4n a^(2n+1) / (n! (2n+1)): for a < 1 term n+1
     * is at most 1/n of term n, so 30 terms are far past double rounding. */
    double sum = 0.0, power = a, fact = 1.0;
    for (int n = 1; n <= 30; n++) {
        power *= -a * a;
        fact *= n;
        sum -= 4.0 * n * power / (fact * (2 * n + 1));
    }
    return sum;
}

static rtk_status gaussian_create(const rtk_params *params, void **state)
{
    gaussian *g = malloc(sizeof *g);
    if (!g)
        return rtk_error(RTK_ERR_NOMEM, "gaussian: out of memory");
    g->sigma = (float)rtk_params_float(params, "sigma");
    g->radius = (float)rtk_params_float(params, "radius");
    g->inv_two_var = 1.0f / (2.0f * g->sigma * g->sigma);
    *state = g;
    return RTK_OK;
}

static float gaussian_radius(const void *state)
{
    return ((const gaussian *)state)->radius;
}

static float gaussian_eval(const void *state, float dx, float dy)
{
    const gaussian *g = state;
    return gaussian_1d(g, dx) * gaussian_1d(g, dy);
}

/* Per axis, with u = x / (sigma sqrt 2) and a = radius / (sigma sqrt 2):
 * int_{-r}^{r} g = sigma sqrt(2) (sqrt(pi) erf(a) - 2 a exp(-a^2))
 *              = sigma sqrt(2 pi) erf(a) - 2 r exp(-r^2 / (2 sigma^2)). */
static double gaussian_integral(const void *state)
{
    const gaussian *g = state;
    double s = g->sigma, a = g->radius / (s * M_SQRT2);
    double axis = s * M_SQRT2 * gaussian_cut_integral(a);
    return axis * axis;
}

static void gaussian_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc gaussian_params[] = {
    {.name = "sigma", .type = RTK_PARAM_FLOAT, .def = 0.5, .min = 0.1, .max = 16.0,
     .doc = "standard deviation of the Gaussian in pixels"},
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 1.5, .min = 0.5, .max = 16.0,
     .doc = "half-width of the square support in pixels; the weight reaches 0 there"},
};

static const rtk_filter_fns gaussian_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = gaussian_create,
    .radius = gaussian_radius,
    .eval = gaussian_eval,
    .integral = gaussian_integral,
    .destroy = gaussian_destroy,
};

static const rtk_plugin gaussian_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "gaussian",
    .version = "1.0",
    .summary = "Gaussian filter, shifted to reach 0 at the radius; separable, never negative",
    .params = gaussian_params,
    .param_count = RTK_COUNTOF(gaussian_params),
    .functions = &gaussian_fns,
};

RTK_PLUGIN_ENTRY(gaussian_plugin)
