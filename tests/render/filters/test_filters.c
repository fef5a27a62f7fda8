/* Filter truths the generic conformance runner cannot know, through the
 * built plugins as the renderer loads them:
 *  - eval of gaussian, mitchell, lanczos and triangle against their
 *    formulas in double, point by point, within a bound derived from the
 *    float operations each plugin performs (u = 2^-24 is float's unit
 *    roundoff; libm's expf, expm1f and sinf are taken as within 1 ulp,
 *    i.e. 2u relative, glibc's documented maximum);
 *  - the integer translates of Mitchell's kernel (spaced radius/2) sum to
 *    1 for every B and C, in 1D and 2D;
 *  - each closed-form integral() against Gauss-Legendre quadrature of the
 *    formula, which the same quadrature at half the panel width confirms;
 *  - every shipped filter: finite for NaN, inf and huge offsets, and a
 *    constant-radiance render gives the constant in every pixel, borders
 *    included. */
#include "render/render.h"
#include "config/config.h"
#include "image/image.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define U 0x1p-24 /* unit roundoff of float */

static int passed, failed;
static rtk_registry *reg;

static void check(int ok, const char *fmt, ...) RTK_PRINTF(2, 3);

static void check(int ok, const char *fmt, ...)
{
    printf("%s  ", ok ? "ok  " : "FAIL");
    va_list ap;
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    putchar('\n');
    ok ? passed++ : failed++;
}

/* One plugin instance. */
typedef struct filter {
    const rtk_filter_fns *f;
    void *state;
} filter;

/* Creates filter `name` with name/value pairs (NULL-terminated) set over
 * its defaults. Returns 1 on success. */
static int make(const char *name, const char *const *set, filter *out)
{
    const rtk_plugin *p = NULL;
    if (rtk_registry_find(reg, RTK_KIND_FILTER, name, &p) != RTK_OK)
        return 0;
    rtk_params *params = rtk_params_defaults(p);
    int ok = params != NULL;
    for (int i = 0; ok && set && set[i]; i += 2)
        ok = rtk_params_set_text(params, set[i], set[i + 1]) == RTK_OK;
    out->f = p->functions;
    out->state = NULL;
    ok = ok && out->f->create(params, &out->state) == RTK_OK;
    rtk_params_destroy(params);
    if (!ok)
        printf("     cannot create %s: %s\n", name, rtk_error_message());
    return ok;
}

/* Worst (|got - want| / bound) over a grid of offsets, for a separable
 * reference k(x) k(y): each 1D factor is off by at most e1, so the float
 * product by e1x |ky| + e1y |kx| + e1x e1y + u |kx ky|. */
typedef double (*ref_1d)(const void *ctx, double x, double *e1);

static double worst_against(const filter *fl, ref_1d ref, const void *ctx, float radius)
{
    double worst = 0.0;
    const int n = 97;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            float dx = (float)(-1.2 * radius + 2.4 * radius * i / (n - 1));
            float dy = (float)(-1.2 * radius + 2.4 * radius * j / (n - 1));
            double ex, ey, kx = ref(ctx, dx, &ex), ky = ref(ctx, dy, &ey);
            /* 2^-149: the float product's rounding once it is subnormal. */
            double want = kx * ky, bound = ex * fabs(ky) + ey * fabs(kx) + ex * ey + U * fabs(want) + 0x1p-149;
            double err = fabs((double)fl->f->eval(fl->state, dx, dy) - want);
            double ratio = bound > 0.0 ? err / bound : (err == 0.0 ? 0.0 : INFINITY);
            if (!(ratio <= worst))
                worst = ratio;
        }
    return worst;
}

/* 8-point Gauss-Legendre nodes and weights on [-1, 1]. */
static const double gl_x[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363};
static const double gl_w[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};

/* int_{-r}^{r} ref over `panels` equal panels (even, so breakpoints at 0
 * and +-r/2 fall on panel borders). */
static double quadrature(ref_1d ref, const void *ctx, double r, int panels)
{
    double h = 2.0 * r / panels, sum = 0.0, e;
    for (int p = 0; p < panels; p++) {
        double mid = -r + (p + 0.5) * h;
        for (int k = 0; k < 4; k++)
            sum += gl_w[k] * (ref(ctx, mid - 0.5 * h * gl_x[k], &e) + ref(ctx, mid + 0.5 * h * gl_x[k], &e));
    }
    return sum * 0.5 * h;
}

/* integral() against the square of the 1D quadrature of the formula. The
 * closed forms round about 1e-15; summing 16 x panels terms in double
 * rounds up to 16 panels 2^-53 of the sum of |terms| (the filters here
 * have sum|f| <= 2 |sum f|). The quadrature's truncation error must hide
 * below that: with half the panels it agrees to the same bound. */
static void check_integral(const char *what, const filter *fl, ref_1d ref, const void *ctx, double r, int panels)
{
    double q1 = quadrature(ref, ctx, r, panels), q2 = quadrature(ref, ctx, r, 2 * panels);
    double closed = fl->f->integral(fl->state), quad = q2 * q2;
    double tol = 2.0 * 16.0 * (2 * panels) * 0x1p-53;
    check(fabs(q1 - q2) <= tol * fabs(q2) && fabs(closed - quad) <= 2.0 * tol * fabs(quad),
          "%s: integral() %.15g, quadrature of the formula %.15g (with half the panels %.15g)", what, closed, quad,
          q1 * q1);
}

/* ---- gaussian ---- */

typedef struct gauss_ref {
    double sigma, radius;
} gauss_ref;

/* exp(-x^2/(2s^2)) - exp(-r^2/(2s^2)) for |x| < r. The plugin rounds the
 * exponent's argument q (4u: x^2, 1/(2s^2) twice, the product), so
 * exp(-q) is off by (4q + 2)u relative; expm1f of an argument with 6u
 * relative error is off by at most 6u + 2u relative; the product adds u.
 * The double formula cancels near the radius: 2^-52 of each term. Below
 * FLT_MIN the float results are subnormal, off by 2^-149 absolute each. */
static double gauss_1d(const void *ctx, double x, double *e1)
{
    const gauss_ref *g = ctx;
    *e1 = 0.0;
    if (!(fabs(x) < g->radius))
        return 0.0;
    double q = x * x / (2.0 * g->sigma * g->sigma), qr = g->radius * g->radius / (2.0 * g->sigma * g->sigma);
    double v = exp(-q) - exp(-qr);
    *e1 = (4.0 * q + 11.0) * U * fabs(v) + 0x1p-52 * (exp(-q) + exp(-qr)) + 0x1p-148;
    return v;
}

static void test_gaussian(void)
{
    const char *sets[][2] = {{"0.5", "1.5"}, {"0.25", "1.5"}, {"1", "0.75"}, {"0.5", "0.5"}, {"2", "3"},
                             {"0.125", "4"}, {"16", "1.5"}};
    for (size_t s = 0; s < sizeof sets / sizeof sets[0]; s++) {
        const char *set[] = {"sigma", sets[s][0], "radius", sets[s][1], NULL};
        filter fl;
        if (!make("gaussian", set, &fl)) {
            check(0, "gaussian sigma=%s radius=%s created", sets[s][0], sets[s][1]);
            continue;
        }
        gauss_ref g = {atof(sets[s][0]), atof(sets[s][1])};
        float r = (float)g.radius;
        double worst = worst_against(&fl, gauss_1d, &g, r);
        check(worst <= 1.0, "gaussian sigma=%s radius=%s: eval matches the formula (worst %.3g of the bound)",
              sets[s][0], sets[s][1], worst);
        float past = nextafterf(r, INFINITY);
        int edge = fl.f->eval(fl.state, r, 0) == 0.0f && fl.f->eval(fl.state, 0, -r) == 0.0f &&
                   fl.f->eval(fl.state, past, 0) == 0.0f;
        check(edge, "gaussian sigma=%s radius=%s: 0 at the radius and past it", sets[s][0], sets[s][1]);
        int negative = 0;
        for (int i = 0; i <= 1000; i++) {
            float x = nextafterf(r, 0.0f) * (float)i / 1000.0f;
            negative += fl.f->eval(fl.state, x, x) < 0.0f || fl.f->eval(fl.state, x, nextafterf(r, 0.0f)) < 0.0f;
        }
        check(negative == 0, "gaussian sigma=%s radius=%s: never negative, up to the radius", sets[s][0], sets[s][1]);
        char what[96];
        snprintf(what, sizeof what, "gaussian sigma=%s radius=%s", sets[s][0], sets[s][1]);
        check_integral(what, &fl, gauss_1d, &g, g.radius, 64 * (int)ceil(g.radius / g.sigma));
        fl.f->destroy(fl.state);
    }
}

/* ---- mitchell ---- */

typedef struct mitchell_ref {
    double b, c, radius;
    double input_roundings; /* float roundings in |t| = 2|x|/r: 2, or 3 when x itself was rounded */
} mitchell_ref;

/* Coefficients of 6k by powers of |t| on the piece holding t (t < 2). */
static void mitchell_piece(double b, double c, double t, double k[4])
{
    if (t < 1.0) {
        k[0] = 6.0 - 2.0 * b, k[1] = 0.0, k[2] = -18.0 + 12.0 * b + 6.0 * c, k[3] = 12.0 - 9.0 * b - 6.0 * c;
    } else {
        k[0] = 8.0 * b + 24.0 * c, k[1] = -12.0 * b - 48.0 * c, k[2] = 6.0 * b + 30.0 * c, k[3] = -b - 6.0 * c;
    }
}

/* k(2x/r). The plugin rounds the coefficients to float (u each) and runs
 * Horner in float (gamma_6 = 6u of sum |c_i| t^i): 7u S(t) in all, S the
 * polynomial with |coefficients|. Rounding in t (2 or 3 roundings) moves
 * the value by at most that many u times t S'(t). The pieces meet with
 * matching slope (the family is C1), so a t rounded across 1 or 2 costs
 * only O(u^2). */
static double mitchell_1d(const void *ctx, double x, double *e1)
{
    const mitchell_ref *m = ctx;
    double t = 2.0 * fabs(x) / m->radius;
    *e1 = 0.0;
    if (!(t < 2.0 + 8.0 * U))
        return 0.0;
    double k[4];
    mitchell_piece(m->b, m->c, fmin(t, 2.0), k);
    double s = 0.0, ds = 0.0;
    for (int i = 3; i >= 0; i--) {
        s = s * t + fabs(k[i]) / 6.0;
        if (i > 0)
            ds = ds * t + i * fabs(k[i]) / 6.0;
    }
    *e1 = 7.01 * U * s + (m->input_roundings + 0.01) * U * t * ds;
    if (!(t < 2.0))
        return 0.0;
    return (k[0] + t * (k[1] + t * (k[2] + t * k[3]))) / 6.0;
}

static void test_mitchell(void)
{
    const char *bc[][2] = {{NULL, NULL}, {"1", "0"}, {"0", "0.5"}, {"0", "1"}, {"1", "1"}, {"0", "0"}, {"0.5", "0.25"}};
    const char *radii[] = {"2", "3", "1"};
    for (size_t s = 0; s < sizeof bc / sizeof bc[0]; s++)
        for (size_t ri = 0; ri < sizeof radii / sizeof radii[0]; ri++) {
            const char *set[] = {"radius", radii[ri], bc[s][0] ? "B" : NULL, bc[s][0], "C", bc[s][1], NULL};
            char what[96];
            snprintf(what, sizeof what, "mitchell B=%s C=%s radius=%s", bc[s][0] ? bc[s][0] : "1/3",
                     bc[s][1] ? bc[s][1] : "1/3", radii[ri]);
            filter fl;
            if (!make("mitchell", set, &fl)) {
                check(0, "%s created", what);
                continue;
            }
            mitchell_ref m = {bc[s][0] ? atof(bc[s][0]) : 1.0 / 3.0, bc[s][1] ? atof(bc[s][1]) : 1.0 / 3.0,
                              atof(radii[ri]), 2.0};
            float r = (float)m.radius, spacing = 0.5f * r;
            double worst = worst_against(&fl, mitchell_1d, &m, r);
            check(worst <= 1.0, "%s: eval matches the formula (worst %.3g of the bound)", what, worst);

            /* Translates by radius/2 (exact in float): x - n s rounds once
             * more. eval(dx, 0) = k(dx) k(0), so the 1D sum is k(0). */
            mitchell_ref m3 = m;
            m3.input_roundings = 3.0;
            double e0, k0 = mitchell_1d(&m3, 0.0, &e0), worst1 = 0.0, worst2 = 0.0;
            for (int i = 0; i < 64; i++) {
                float x = spacing * (float)i / 64.0f, y = spacing * (float)((i * 37) % 64) / 64.0f;
                double sum1 = 0.0, bound1 = 0.0, sum2 = 0.0, bound2 = 0.0;
                for (int a = -3; a <= 3; a++) {
                    double ex, kx = mitchell_1d(&m3, (double)x - a * (double)spacing, &ex);
                    sum1 += fl.f->eval(fl.state, x - (float)a * spacing, 0.0f);
                    bound1 += ex * k0 + e0 * fabs(kx) + ex * e0 + U * fabs(kx * k0);
                    for (int b = -3; b <= 3; b++) {
                        double ey, ky = mitchell_1d(&m3, (double)y - b * (double)spacing, &ey);
                        sum2 += fl.f->eval(fl.state, x - (float)a * spacing, y - (float)b * spacing);
                        bound2 += ex * fabs(ky) + ey * fabs(kx) + ex * ey + U * fabs(kx * ky);
                    }
                }
                worst1 = fmax(worst1, fabs(sum1 / k0 - 1.0) / (bound1 / k0 + 1e-15));
                worst2 = fmax(worst2, fabs(sum2 - 1.0) / (bound2 + 1e-15));
            }
            check(worst1 <= 1.0, "%s: translates by radius/2 sum to 1 in 1D (worst %.3g of the bound)", what, worst1);
            check(worst2 <= 1.0, "%s: translates by radius/2 sum to 1 in 2D (worst %.3g of the bound)", what, worst2);
            check(fl.f->integral(fl.state) == 0.25 * m.radius * m.radius, "%s: integral() is (radius/2)^2", what);
            check_integral(what, &fl, mitchell_1d, &m, m.radius, 64 * (int)ceil(m.radius));
            fl.f->destroy(fl.state);
        }
}

/* ---- lanczos ---- */

static double sinc(double x)
{
    return x == 0.0 ? 1.0 : sin(M_PI * x) / (M_PI * x);
}

/* sinc(x) sinc(x/a). In the plugin sinc(x) = sinf(pi x) / (pi x) with pi x
 * rounded twice (pi, product): the sine moves by |cos| 2u, sinf and the
 * division add 3u |sinc|, 7u in all since |sinc| <= 1; x/a rounds once
 * more, moving sinc(x/a) by |y sinc'(y)| u <= 2u, 9u; the product adds u. */
static double lanczos_1d(const void *ctx, double x, double *e1)
{
    double a = *(const double *)ctx;
    *e1 = 0.0;
    if (!(fabs(x) < a))
        return 0.0;
    double s1 = sinc(x), s2 = sinc(x / a);
    *e1 = 7.0 * U * fabs(s2) + 9.0 * U * fabs(s1) + U * fabs(s1 * s2) + 1e-15;
    return s1 * s2;
}

static void test_lanczos(void)
{
    const char *radii[] = {"2", "0.5", "1", "1.5", "3", "8"};
    for (size_t ri = 0; ri < sizeof radii / sizeof radii[0]; ri++) {
        const char *set[] = {"radius", radii[ri], NULL};
        filter fl;
        if (!make("lanczos", set, &fl)) {
            check(0, "lanczos radius=%s created", radii[ri]);
            continue;
        }
        double a = atof(radii[ri]);
        double worst = worst_against(&fl, lanczos_1d, &a, (float)a);
        check(worst <= 1.0, "lanczos radius=%s: eval matches the formula (worst %.3g of the bound)", radii[ri], worst);
        char what[64];
        snprintf(what, sizeof what, "lanczos radius=%s", radii[ri]);
        check_integral(what, &fl, lanczos_1d, &a, a, 64 * (int)ceil(a));
        fl.f->destroy(fl.state);
    }
}

/* ---- triangle ---- */

/* 1 - |x|/r. The plugin's r - |x| is exact from |x| >= r/2 (Sterbenz) and
 * rounds once below; the division rounds once: 2u relative, 3u with the
 * product's rounding counted by the caller. */
static double triangle_1d(const void *ctx, double x, double *e1)
{
    double r = *(const double *)ctx;
    double v = fabs(x) < r ? 1.0 - fabs(x) / r : 0.0;
    *e1 = 2.0 * U * v;
    return v;
}

static void test_triangle(void)
{
    const char *radii[] = {"1", "0.5", "2.5", "16"};
    for (size_t ri = 0; ri < sizeof radii / sizeof radii[0]; ri++) {
        const char *set[] = {"radius", radii[ri], NULL};
        filter fl;
        if (!make("triangle", set, &fl)) {
            check(0, "triangle radius=%s created", radii[ri]);
            continue;
        }
        double r = atof(radii[ri]);
        double worst = worst_against(&fl, triangle_1d, &r, (float)r);
        check(worst <= 1.0, "triangle radius=%s: eval matches the formula (worst %.3g of the bound)", radii[ri], worst);
        char what[64];
        snprintf(what, sizeof what, "triangle radius=%s", radii[ri]);
        check_integral(what, &fl, triangle_1d, &r, r, 64 * (int)ceil(r));
        fl.f->destroy(fl.state);
    }
}

/* ---- every shipped filter ---- */

static void constant_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state, (void)ctx, (void)ray;
    out->radiance = rtk_rgb_make(0.3f, 1.7f, 42.0f);
}

static const rtk_integrator_fns constant = {.size = sizeof(rtk_integrator_fns), .li = constant_li};

/* Renders constant radiance; products w x L are exact in double, so a
 * pixel is off by its float rounding (2^-24) plus the error of the two
 * double sums, under 2n 2^-53 sum|w| / |sum w| for n terms: 1e-5 holds
 * unless a pixel's summed weight is 0 or cancels below n 2e-11 of sum|w|. */
static void check_constant(const char *name, const filter *fl, uint32_t w, uint32_t h, uint32_t spp,
                           rtk_reconstruction recon)
{
    const float want[3] = {0.3f, 1.7f, 42.0f};
    rtk_scene *scene = rtk_scene_new("constant", 0);
    rtk_camera_desc d = {rtk_vec3_make(0, 0, 1), rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 1, 0), 60.0f};
    rtk_camera cam;
    float *px = malloc(sizeof(float) * RTK_FILM_CHANNELS * w * h);
    rtk_status st = scene && px ? rtk_camera_init(&cam, &d, w, h) : RTK_ERR_NOMEM;
    rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
    job.scene = scene;
    job.camera = &cam;
    job.integrator = &constant;
    job.filter = fl->f;
    job.filter_state = fl->state;
    job.spp = spp;
    job.reconstruction = recon;
    job.seed = 9;
    job.threads = 2;
    if (st == RTK_OK)
        st = rtk_render_film(&job, px, NULL);
    uint32_t bad = 0, border_bad = 0;
    double worst = 0.0;
    for (uint32_t i = 0; st == RTK_OK && i < w * h; i++) {
        uint32_t x = i % w, y = i / w;
        for (int c = 0; c < 3; c++) {
            double err = fabs((double)px[(size_t)i * RTK_FILM_CHANNELS + c] - want[c]) / want[c];
            worst = fmax(worst, err);
            if (!(err <= 1e-5)) {
                bad++;
                border_bad += x == 0 || y == 0 || x == w - 1 || y == h - 1;
                break;
            }
        }
    }
    check(st == RTK_OK && bad == 0,
          "%s, %s: constant radiance at %ux%u, %u spp is the constant in every pixel (worst relative error %.3g; "
          "%u pixels off, %u on the border)",
          name, recon == RTK_RECON_IMPORTANCE ? "importance" : "splat", w, h, spp, worst, bad, border_bad);
    free(px);
    rtk_scene_free(scene);
}

static void test_every_filter(void)
{
    const char *expected[] = {"box", "gaussian", "lanczos", "mitchell", "triangle"};
    int found[5] = {0};
    size_t n = rtk_registry_count(reg);
    for (size_t i = 0; i < n; i++) {
        const rtk_plugin_info *info = rtk_registry_at(reg, i);
        if (!info->plugin || info->plugin->kind != RTK_KIND_FILTER)
            continue;
        const char *name = info->plugin->name;
        for (int k = 0; k < 5; k++)
            found[k] |= strcmp(name, expected[k]) == 0;
        filter fl;
        if (!make(name, NULL, &fl)) {
            check(0, "%s created with its defaults", name);
            continue;
        }
        const float odd[] = {NAN, INFINITY, -INFINITY, FLT_MAX, -FLT_MAX, FLT_MIN, 0x1p-149f, -0.0f};
        int finite = 1;
        for (int a = 0; a < 8; a++)
            for (int b = 0; b < 8; b++)
                finite &= isfinite(fl.f->eval(fl.state, odd[a], odd[b])) && isfinite(fl.f->eval(fl.state, odd[a], 0.25f));
        check(finite, "%s: eval is finite for NaN, inf, huge and denormal offsets", name);
        for (int recon = RTK_RECON_SPLAT; recon <= RTK_RECON_IMPORTANCE; recon++) {
            check_constant(name, &fl, 37, 29, 1, (rtk_reconstruction)recon);
            check_constant(name, &fl, 37, 29, 4, (rtk_reconstruction)recon);
            check_constant(name, &fl, 16, 16, 2, (rtk_reconstruction)recon);
        }
        fl.f->destroy(fl.state);
    }
    for (int k = 0; k < 5; k++)
        check(found[k], "shipped filter %s is in the build tree", expected[k]);
}

int main(void)
{
    if (rtk_registry_create(&reg) != RTK_OK) {
        printf("FAIL  registry: %s\n", rtk_error_message());
        return 1;
    }
    test_gaussian();
    test_mitchell();
    test_lanczos();
    test_triangle();
    test_every_filter();
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
