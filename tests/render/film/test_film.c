/* The film (kernel/render/film.c) and its two reconstructions, splatting and
 * filter importance sampling:
 * - 1e6 samples of radiance 0.1 average to 0.1 within 1e-6 relative;
 * - injected NaN/Inf samples are dropped and counted, exactly;
 * - a radiance that is linear in film position is reproduced at every
 *   pixel centre by both reconstructions with every shipped filter (the
 *   filters are symmetric), within 5 standard errors over 16 seeds;
 * - a pixel whose signed weights cancel resolves with |weights|: never
 *   outside the range of its samples;
 * - the filter sampler's weights f / pdf average to the filter's integral;
 * - the image is the same, bit for bit, on 1 to 8 threads, with filters
 *   whose tiles' buffers reach one and two tiles over. */
#include "config/config.h"
#include "render/render.h"

#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

static void constant_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state, (void)ctx, (void)ray;
    out->radiance = rtk_rgb_make(0.1f, 0.1f, 0.1f);
}

static atomic_ullong poisoned;

/* 0.1, except one sample in about 64 (chosen by the sample stream) that
 * is NaN or +-Inf; each poisoned sample is counted. */
static void poisoned_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state, (void)ray;
    float u = rtk_sample_1d(ctx);
    out->radiance = rtk_rgb_make(0.1f, 0.1f, 0.1f);
    if (u < 1.0f / 64.0f) {
        float bad = u < 1.0f / 192.0f ? NAN : u < 2.0f / 192.0f ? INFINITY : -INFINITY;
        out->radiance.g = bad;
        atomic_fetch_add(&poisoned, 1);
    }
}

static rtk_camera camera;

/* The film position (fx, fy) a ray came through, recovered from its
 * direction: forward, right and up are orthogonal. */
static void film_position(const rtk_ray *ray, double *fx, double *fy)
{
    double d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    const rtk_vec3 *f = &camera.forward, *r = &camera.right, *u = &camera.up;
    double df = (d[0] * f->x + d[1] * f->y + d[2] * f->z) / ((double)f->x * f->x + (double)f->y * f->y + (double)f->z * f->z);
    double dr = (d[0] * r->x + d[1] * r->y + d[2] * r->z) / ((double)r->x * r->x + (double)r->y * r->y + (double)r->z * r->z);
    double du = (d[0] * u->x + d[1] * u->y + d[2] * u->z) / ((double)u->x * u->x + (double)u->y * u->y + (double)u->z * u->z);
    double sx = dr / df, sy = du / df;
    *fx = (sx + 1.0) * camera.width / 2.0, *fy = (1.0 - sy) * camera.height / 2.0;
}

/* Radiance 1 + 0.25 fx - 0.125 fy at the film position the ray came
 * through. */
static void ramp_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state, (void)ctx;
    double fx, fy;
    film_position(ray, &fx, &fy);
    float v = (float)(1.0 + 0.25 * fx - 0.125 * fy);
    out->radiance = rtk_rgb_make(v, v, v);
}

/* Three values from the sample stream, so that every sample differs;
 * slow in the first row of tiles from the fourth tile on, so that tiles
 * of the next row that share pixels with them finish first. */
static void noisy_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state;
    double fx, fy;
    film_position(ray, &fx, &fy);
    if (fy < 16.0 && fx >= 48.0)
        for (volatile int i = 0; i < 400; i++)
            ;
    float a = rtk_sample_1d(ctx), b = rtk_sample_1d(ctx);
    out->radiance = rtk_rgb_make(a, 3.0f * b, a * b + 0.1f);
}

static const rtk_integrator_fns constant = {.size = sizeof(rtk_integrator_fns), .li = constant_li};
static const rtk_integrator_fns poisoned_fns = {.size = sizeof(rtk_integrator_fns), .li = poisoned_li};
static const rtk_integrator_fns ramp = {.size = sizeof(rtk_integrator_fns), .li = ramp_li};
static const rtk_integrator_fns noisy = {.size = sizeof(rtk_integrator_fns), .li = noisy_li};

/* A tent filter of the radius its state points to. */
static float tent_radius(const void *state)
{
    return *(const float *)state;
}
static float tent_eval(const void *state, float dx, float dy)
{
    const float r = *(const float *)state;
    return fmaxf(r - fabsf(dx), 0.0f) * fmaxf(r - fabsf(dy), 0.0f);
}
static double tent_integral(const void *state)
{
    const double r = *(const float *)state;
    return r * r * r * r;
}
static const rtk_filter_fns tent = {
    .size = sizeof(rtk_filter_fns), .radius = tent_radius, .eval = tent_eval, .integral = tent_integral};

static uint32_t render_threads = 2;

typedef struct filter {
    const char *name;
    const rtk_filter_fns *f;
    void *state;
} filter;

static const char *const recon_name[] = {"splat", "importance"};

static rtk_status render(const rtk_integrator_fns *ifn, const filter *fl, uint32_t w, uint32_t h, uint32_t spp,
                         rtk_reconstruction recon, uint64_t seed, float *px, rtk_render_stats *stats)
{
    rtk_scene *scene = rtk_scene_new("film", 0);
    rtk_camera_desc d = {rtk_vec3_make(0, 0, 1), rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 1, 0), 60.0f};
    rtk_status st = rtk_camera_init(&camera, &d, w, h);
    rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
    job.scene = scene;
    job.camera = &camera;
    job.integrator = ifn;
    job.filter = fl->f;
    job.filter_state = fl->state;
    job.spp = spp;
    job.reconstruction = recon;
    job.seed = seed;
    job.threads = render_threads;
    if (st == RTK_OK)
        st = rtk_render_film(&job, px, stats);
    rtk_scene_free(scene);
    return st;
}

static void test_million(const filter *fl, rtk_reconstruction recon)
{
    /* 4 x 4 pixels x 62,500 samples = 1e6. */
    float px[16 * RTK_FILM_CHANNELS];
    rtk_status st = render(&constant, fl, 4, 4, 62500, recon, 1, px, NULL);
    double worst = 0.0, mean = 0.0;
    for (int i = 0; i < 16; i++) {
        worst = fmax(worst, fabs(px[i * RTK_FILM_CHANNELS] - 0.1) / 0.1);
        mean += px[i * RTK_FILM_CHANNELS] / 16.0;
    }
    check(st == RTK_OK && worst <= 1e-6 && fabs(mean - 0.1) / 0.1 <= 1e-6,
          "%s, %s: 1e6 samples of 0.1 give 0.1 (worst pixel %.2g relative, mean %.9g)", fl->name,
          recon_name[recon], worst, mean);
}

static void test_poisoned(const filter *fl, rtk_reconstruction recon)
{
    enum { W = 24, H = 16 };
    static float px[W * H * RTK_FILM_CHANNELS];
    atomic_store(&poisoned, 0);
    rtk_render_stats stats;
    rtk_status st = render(&poisoned_fns, fl, W, H, 64, recon, 5, px, &stats);
    int finite = 1;
    double worst = 0.0;
    for (int i = 0; i < W * H * RTK_FILM_CHANNELS; i++)
        finite &= isfinite(px[i]) != 0;
    for (int i = 0; i < W * H; i++)
        for (int c = 0; c < 3; c++)
            worst = fmax(worst, fabs(px[i * RTK_FILM_CHANNELS + c] - 0.1) / 0.1);
    unsigned long long n = atomic_load(&poisoned);
    check(st == RTK_OK && n > 0 && stats.bad_samples == n && finite && worst <= 1e-5,
          "%s, %s: %llu NaN/Inf samples injected, %llu dropped and counted; every pixel finite and 0.1 (worst %.2g)",
          fl->name, recon_name[recon], n, (unsigned long long)stats.bad_samples, worst);
}

static void test_ramp(const filter *fl, rtk_reconstruction recon)
{
    enum { W = 8, H = 6, SEEDS = 16 };
    static float px[SEEDS][W * H * RTK_FILM_CHANNELS];
    rtk_status st = RTK_OK;
    for (int k = 0; k < SEEDS && st == RTK_OK; k++)
        st = render(&ramp, fl, W, H, 256, recon, 100 + (uint64_t)k, px[k], NULL);
    /* Interior pixels: the support lies inside the film. */
    int r = (int)ceilf(fl->f->radius(fl->state) - 0.5f), bad = 0, tested = 0;
    double worst = 0.0;
    for (int y = r; y < H - r; y++)
        for (int x = r; x < W - r; x++) {
            double m = 0.0, m2 = 0.0;
            for (int k = 0; k < SEEDS; k++) {
                double v = px[k][(y * W + x) * RTK_FILM_CHANNELS];
                m += v / SEEDS;
                m2 += v * v / SEEDS;
            }
            double se = sqrt(fmax(m2 - m * m, 0.0) / (SEEDS - 1));
            double truth = 1.0 + 0.25 * (x + 0.5) - 0.125 * (y + 0.5);
            /* 5 standard errors, plus float rounding of the radiance. */
            double allowed = 5.0 * se + 1e-5 * truth;
            worst = fmax(worst, fabs(m - truth) / (allowed > 0 ? allowed : 1));
            bad += !(fabs(m - truth) <= allowed);
            tested++;
        }
    check(st == RTK_OK && bad == 0 && tested > 0,
          "%s, %s: a radiance linear in film position is its value at each of %d interior pixel centres, within 5 "
          "standard errors over %d seeds (worst %.2f of that)", fl->name, recon_name[recon], tested, SEEDS, worst);
}

static void test_sampler_weights(const filter *fl)
{
    rtk_filter_sampler fs;
    float radius = fl->f->radius(fl->state);
    if (rtk_filter_sampler_init(&fs, fl->f, fl->state, radius) != RTK_OK) {
        check(0, "%s: filter sampler: %s", fl->name, rtk_error_message());
        return;
    }
    /* Stratified u over a 4096^2 grid: the mean of f / pdf is the
     * integral of f up to the quadrature error of 2^24 points (measured
     * falling with the grid: Mitchell 5e-3, 1.2e-3, 4e-4, 3e-4 relative at
     * 512^2 .. 4096^2; a biased sampler would not converge). */
    const int n = 4096;
    double sum = 0.0;
    int outside = 0;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            rtk_vec2 u = {((float)i + 0.5f) / n, ((float)j + 0.5f) / n};
            float dx, dy, w;
            rtk_filter_sampler_sample(&fs, u, &dx, &dy, &w);
            outside += fabsf(dx) > radius || fabsf(dy) > radius || !isfinite(w);
            sum += w;
        }
    double mean = sum / ((double)n * n), integral = fl->f->integral(fl->state);
    check(outside == 0 && fabs(mean - integral) <= 1e-3 * fabs(integral),
          "%s: filter sampler: every offset inside the support, mean f / pdf %.6f = integral %.6f (1e-3)", fl->name,
          mean, integral);
    rtk_filter_sampler_free(&fs);
}

static void test_cancel(void)
{
    /* One pixel, samples 1.0 (weight 1) and 0.0 (weight -0.97): signed,
     * 1 / 0.03 = 33; with |weights| 1 / 1.97. */
    rtk_film film;
    if (rtk_film_init(&film, 1, 1, 1, 1, 1) != RTK_OK) {
        check(0, "film init");
        return;
    }
    rtk_film_tile tile;
    rtk_film_tile_init(&tile, &film, 0, 0, 1, 1, 0.5f);
    const float one = 1.0f, zero = 0.0f;
    rtk_film_tile_add(&tile, 0, 0, 1.0f, &one);
    rtk_film_tile_add(&tile, 0, 0, -0.97f, &zero);
    rtk_film_merge(&film, &tile);
    float out;
    rtk_film_resolve(&film, &out, 1);
    check(fabsf(out - 1.0f / 1.97f) < 1e-6f, "cancelling weights (1, -0.97) resolve with |weights|: %.6f within [0, 1]",
          out);
    rtk_film_tile_free(&tile);
    rtk_film_free(&film);
    /* Weights (1, -0.5): the signed average 2, kept (0.5 > 1.5 / 16). */
    rtk_film_init(&film, 1, 1, 1, 1, 1);
    rtk_film_tile_init(&tile, &film, 0, 0, 1, 1, 0.5f);
    rtk_film_tile_add(&tile, 0, 0, 1.0f, &one);
    rtk_film_tile_add(&tile, 0, 0, -0.5f, &zero);
    rtk_film_merge(&film, &tile);
    rtk_film_resolve(&film, &out, 1);
    check(fabsf(out - 2.0f) < 1e-6f, "weights (1, -0.5) keep the signed average: %.6f", out);
    rtk_film_tile_free(&tile);
    rtk_film_free(&film);
}

/* Tiles merge into the film on several threads at once, but every pixel
 * must sum the tiles that reach it in tile order (kernel/render/render.c):
 * with noisy samples any other order or a race changes some pixel's
 * bits. Radius 1.5: buffers 2 pixels past 16-pixel tiles, neighbours
 * share pixels; radius 8.5: tiles two apart do. */
static void test_threads(void)
{
    enum { W = 83, H = 61 };
    static float px[2][W * H * RTK_FILM_CHANNELS];
    const float radii[] = {1.5f, 8.5f};
    for (size_t i = 0; i < RTK_COUNTOF(radii); i++) {
        filter fl = {"tent", &tent, (void *)&radii[i]};
        for (int recon = RTK_RECON_SPLAT; recon <= RTK_RECON_IMPORTANCE; recon++) {
            render_threads = 1;
            rtk_status st = render(&noisy, &fl, W, H, 4, (rtk_reconstruction)recon, 9, px[0], NULL);
            uint32_t t = 2;
            for (; st == RTK_OK && t <= 8; t++) {
                render_threads = t;
                int round = 0;
                for (; round < 4; round++)
                    if ((st = render(&noisy, &fl, W, H, 4, (rtk_reconstruction)recon, 9, px[1], NULL)) != RTK_OK ||
                        memcmp(px[0], px[1], sizeof px[0]) != 0)
                        break;
                if (round < 4)
                    break;
            }
            char why[512] = "";
            if (st != RTK_OK)
                snprintf(why, sizeof why, ": a render failed: %s", rtk_error_message());
            else if (t <= 8)
                snprintf(why, sizeof why, ": differs on %u threads", t);
            check(t > 8, "tent radius %g, %s: %dx%d, 4 spp on 2 to 8 threads (4 renders each) equal the 1-thread image bit for bit%s",
                  (double)radii[i], recon_name[recon], W, H, why);
        }
    }
    render_threads = 2;
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK) {
        printf("FAIL  registry: %s\n", rtk_error_message());
        return 1;
    }
    const char *names[] = {"box", "triangle", "gaussian", "mitchell", "lanczos"};
    for (size_t i = 0; i < RTK_COUNTOF(names); i++) {
        const rtk_plugin *p = NULL;
        if (rtk_registry_find(reg, RTK_KIND_FILTER, names[i], &p) != RTK_OK) {
            check(0, "filter %s found: %s", names[i], rtk_error_message());
            continue;
        }
        filter fl = {names[i], p->functions, NULL};
        rtk_params *params = rtk_params_defaults(p);
        if (fl.f->create(params, &fl.state) != RTK_OK) {
            check(0, "filter %s created: %s", names[i], rtk_error_message());
            rtk_params_destroy(params);
            continue;
        }
        test_sampler_weights(&fl);
        for (int recon = RTK_RECON_SPLAT; recon <= RTK_RECON_IMPORTANCE; recon++) {
            test_million(&fl, (rtk_reconstruction)recon);
            test_poisoned(&fl, (rtk_reconstruction)recon);
            test_ramp(&fl, (rtk_reconstruction)recon);
        }
        fl.f->destroy(fl.state);
        rtk_params_destroy(params);
    }
    test_cancel();
    test_threads();
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
