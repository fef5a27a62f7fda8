/* lanczos: the sinc windowed by a wider sinc, L(x) L(y) with
 * L(x) = sinc(x) sinc(x / a) for |x| < a and 0 beyond, sinc(x) =
 * sin(pi x) / (pi x), a = radius. The window reaches 0 at the radius for
 * any a, so the weight is continuous there. The window is positive inside
 * the support, so the weight is negative where sinc is (1 < |x| < 2,
 * 3 < |x| < 4, ... when a > 1); it is returned as it is.
 *
 * integral() is exact in terms of the sine integral Si (see
 * lanczos_integral), and Si is evaluated to about 1e-15 relative: by its
 * Taylor series up to 4, by the continued fraction of E1(ix) beyond.
 *
 * Parameters:
 *   radius  float [0.5, 8]  2     half-width of the support, pixels, and
 *                                 the width a of the window (Lanczos-a)
 *
 * Example: filter = { plugin = "lanczos"; radius = 2; };
 */
#include <rtk/rtk.h>

#include <complex.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>

typedef struct lanczos {
    float radius;
} lanczos;

static float sinc(float x)
{
    float px = (float)M_PI * x;
    /* Below 1e-3 the series 1 - px^2/6 is exact to float rounding. */
    return px < 1e-3f ? 1.0f - px * px / 6.0f : sinf(px) / px;
}

static float lanczos_1d(float radius, float x)
{
    float a = fabsf(x);
    if (!(a < radius))
        return 0.0f;
    return sinc(a) * sinc(a / radius);
}

/* Si(x) = int_0^x sin(t)/t dt. */
static double sine_integral(double x)
{
    if (x < 0.0)
        return -sine_integral(-x);
    if (x <= 4.0) {
        /* sum_k (-1)^k x^(2k+1) / ((2k+1) (2k+1)!): at x = 4 the largest
         * term is 3.6, so cancellation costs under one digit; term 20 is
         * below 1e-20. */
        double term = x, sum = x;
        for (int k = 1; k <= 20; k++) {
            term *= -x * x / ((2.0 * k) * (2.0 * k + 1.0));
            sum += term / (2.0 * k + 1.0);
        }
        return sum;
    }
    /* Si(x) = pi/2 + Im(e^(-ix) E1(ix)), E1 by its continued fraction
     * (modified Lentz; Numerical Recipes' cisi), converging fast for x > 2. */
    double complex b = 1.0 + I * x, c = 1.0 / DBL_MIN, d = 1.0 / b, h = d;
    for (int i = 2; i < 1000; i++) {
        double a = -(double)(i - 1) * (i - 1);
        b += 2.0;
        d = 1.0 / (a * d + b);
        c = b + a / c;
        double complex del = c * d;
        h *= del;
        if (cabs(del - 1.0) < 4.0 * DBL_EPSILON)
            break;
    }
    h *= cos(x) - I * sin(x);
    return M_PI_2 + cimag(h);
}

static rtk_status lanczos_create(const rtk_params *params, void **state)
{
    lanczos *l = malloc(sizeof *l);
    if (!l)
        return rtk_error(RTK_ERR_NOMEM, "lanczos: out of memory");
    l->radius = (float)rtk_params_float(params, "radius");
    *state = l;
    return RTK_OK;
}

static float lanczos_radius(const void *state)
{
    return ((const lanczos *)state)->radius;
}

static float lanczos_eval(const void *state, float dx, float dy)
{
    float r = ((const lanczos *)state)->radius;
    return lanczos_1d(r, dx) * lanczos_1d(r, dy);
}

/* sin(pi x) sin(pi x/a) = (cos(pi (1 - 1/a) x) - cos(pi (1 + 1/a) x)) / 2,
 * and int_0^a (cos(p x) - cos(q x)) / x^2 dx = q Si(q a) - p Si(p a) once
 * integrated by parts (the boundary term vanishes: cos(pi (a - 1)) =
 * cos(pi (a + 1))). Per axis that gives
 *   int_{-a}^{a} L = ((a + 1) Si(pi (a + 1)) - (a - 1) Si(pi (a - 1))) / pi,
 * which tends to 1, the integral of the sinc, as a grows. */
static double lanczos_integral(const void *state)
{
    double a = ((const lanczos *)state)->radius;
    double axis = ((a + 1.0) * sine_integral(M_PI * (a + 1.0)) - (a - 1.0) * sine_integral(M_PI * (a - 1.0))) / M_PI;
    return axis * axis;
}

static void lanczos_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc lanczos_params[] = {
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 2.0, .min = 0.5, .max = 8.0,
     .doc = "half-width of the support in pixels and width of the sinc window (Lanczos-a)"},
};

static const rtk_filter_fns lanczos_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = lanczos_create,
    .radius = lanczos_radius,
    .eval = lanczos_eval,
    .integral = lanczos_integral,
    .destroy = lanczos_destroy,
};

static const rtk_plugin lanczos_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "lanczos",
    .version = "1.0",
    .summary = "Lanczos windowed-sinc filter; separable, negative lobes kept",
    .params = lanczos_params,
    .param_count = RTK_COUNTOF(lanczos_params),
    .functions = &lanczos_fns,
};

RTK_PLUGIN_ENTRY(lanczos_plugin)
