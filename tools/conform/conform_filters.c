/* Conformance checks for filter plugins, for every parameter set: a finite
 * radius, finite and symmetric weights that vanish past it and integrate
 * to the closed form, and a constant-radiance render through the film. */
#include "conform.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Radiance of every camera ray in the constant-radiance render. */
static const float constant_radiance[3] = {0.3f, 1.7f, 42.0f};

static void constant_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state, (void)ctx, (void)ray;
    out->radiance = rtk_rgb_make(constant_radiance[0], constant_radiance[1], constant_radiance[2]);
}

/* rtk_render_film calls only li. */
static const rtk_integrator_fns constant_integrator = {.size = sizeof(rtk_integrator_fns), .li = constant_li};

/* Renders constant radiance through the film at 1 spp (every pixel then
 * depends on its neighbours' samples) on 2 threads and an image that is
 * not a whole number of tiles. Products w x L are exact in double, so a
 * pixel is off by the float rounding of its value (2^-24) plus the error
 * of the two double sums, under 2n 2^-53 sum|w| / |sum w| for n terms:
 * 1e-5 relative fails a pixel only if its summed weight is 0 (no sample
 * reached it; it resolves to 0) or cancels below n 2e-11 of sum|w|, which
 * is why this check cannot see a merely small or negative sum (see
 * note_weight_sums). A pixel's own samples lie within 0.5 of its centre
 * on each axis, so only a radius of 0.5 or more can promise every pixel a
 * sample; below that, black pixels are counted in a note. */
static void check_constant_render(rtk_conform_runner *r, const rtk_filter_fns *f, void *state, float rad, const char *label)
{
    char name[256];
    const uint32_t w = 37, h = 29;
    rtk_scene *scene = rtk_scene_new("conform constant", 0);
    rtk_camera_desc d = {rtk_vec3_make(0, 0, 1), rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 1, 0), 60.0f};
    rtk_camera cam;
    float *px = rtk_alloc((size_t)w * h * RTK_FILM_CHANNELS * sizeof(float));
    rtk_status st = scene && px ? rtk_camera_init(&cam, &d, w, h) : RTK_ERR_NOMEM;
    rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
    job.scene = scene;
    job.camera = &cam;
    job.integrator = &constant_integrator;
    job.filter = f;
    job.filter_state = state;
    job.seed = 3;
    job.threads = 2;
    if (st == RTK_OK)
        st = rtk_render_film(&job, px, NULL);
    snprintf(name, sizeof name, "constant radiance gives the constant in every pixel, borders included [%s]", label);
    if (st != RTK_OK) {
        rtk_conform_check(r, 0, name, "render failed: %s", rtk_error_message());
    } else {
        uint32_t bad = 0, black = 0, worst_x = 0, worst_y = 0;
        double worst = 0.0;
        for (uint32_t i = 0; i < w * h; i++) {
            const float *v = px + (size_t)i * RTK_FILM_CHANNELS;
            if (rad < 0.5f && v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f) {
                black++;
                continue;
            }
            for (int c = 0; c < 3; c++) {
                double err = fabs((double)v[c] - constant_radiance[c]) / constant_radiance[c];
                if (!(err <= 1e-5)) {
                    bad++;
                    if (!(err <= worst))
                        worst = err, worst_x = i % w, worst_y = i / w;
                    break;
                }
            }
        }
        rtk_conform_check(r, bad == 0, name, "%u of %u pixels off, worst relative error %g at (%u, %u)", bad, w * h, worst,
                          worst_x, worst_y);
        if (black)
            fprintf(r->out, "# [%s] radius %g < 0.5: %u of %u pixels got no sample weight and stay black\n", label,
                    rad, black, w * h);
    }
    free(px);
    rtk_scene_free(scene);
}

/* |eval| of a wrapped filter, to splat sum |w| next to sum w. */
typedef struct abs_filter {
    const rtk_filter_fns *f;
    const void *state;
} abs_filter;

static float abs_filter_eval(const void *state, float dx, float dy)
{
    const abs_filter *a = state;
    return fabsf(a->f->eval(a->state, dx, dy));
}

/* Summed filter weight per pixel at 1 spp, samples placed exactly as the
 * renderer places them; printed as a note. The film divides by this sum:
 * sum|w| / sum w bounds how far a pixel can leave the range of its
 * samples' values (1 for a filter without negative lobes), and where the
 * sum is near 0 or negative it turns noise into arbitrary values. */
static void note_weight_sums(rtk_conform_runner *r, const rtk_filter_fns *f, void *state, float rad, const char *label)
{
    const uint32_t w = 128, h = 128;
    const abs_filter wrap = {f, state};
    const rtk_filter_fns abs_fns = {.size = sizeof(rtk_filter_fns), .eval = abs_filter_eval};
    rtk_film film[2];
    rtk_film_tile tile[2];
    int ready = 0;
    for (; ready < 2; ready++) {
        if (rtk_film_init(&film[ready], w, h, 1, 0, 1) != RTK_OK)
            break;
        if (rtk_film_tile_init(&tile[ready], &film[ready], 0, 0, w, h, rad) != RTK_OK) {
            rtk_film_free(&film[ready]);
            break;
        }
    }
    if (ready == 2) {
        rtk_ctx ctx;
        memset(&ctx, 0, sizeof ctx);
        ctx.gen.seed = 3;
        const float one = 1.0f;
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++) {
                rtk_ctx_start_sample(&ctx, (uint64_t)y * w + x, 0);
                rtk_vec2 j = rtk_sample_2d(&ctx);
                float fx = (float)x + j.x, fy = (float)y + j.y;
                rtk_film_tile_splat(&tile[0], &film[0], fx, fy, &one, f, state, rad);
                rtk_film_tile_splat(&tile[1], &film[1], fx, fy, &one, &abs_fns, &wrap, rad);
            }
        rtk_film_merge(&film[0], &tile[0]);
        rtk_film_merge(&film[1], &tile[1]);
        double amplification = 1.0;
        uint32_t nonpositive = 0;
        for (uint32_t i = 0; i < w * h; i++) {
            if (film[0].weight[i] <= 0.0)
                nonpositive++;
            else
                amplification = fmax(amplification, film[1].weight[i] / film[0].weight[i]);
        }
        fprintf(r->out, "# [%s] summed weight at 1 spp, %ux%u pixels: %u <= 0, elsewhere sum|w| / sum w <= %.3g\n",
                label, w, h, nonpositive, amplification);
    }
    for (int i = 0; i < ready; i++) {
        rtk_film_tile_free(&tile[i]);
        rtk_film_free(&film[i]);
    }
}

/* The checks of one instance of the filter p, label its parameter set. */
static void check_filter(rtk_conform_runner *r, const rtk_plugin *p, void *state, const char *label)
{
    const rtk_filter_fns *f = p->functions;
    char name[256];
    float rad = f->radius(state);
    snprintf(name, sizeof name, "radius is finite and in (0, 64] [%s]", label);
    rtk_conform_check(r, rad > 0.0f && rad <= 64.0f, name, "radius %g", rad);
    if (!(rad > 0.0f && rad <= 64.0f)) {
        return;
    }
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 5u, 11u);
    int outside = 0, asym = 0, nonfinite = 0;
    float worst = 0.0f;
    for (int i = 0; i < 20000; i++) {
        float x = rtk_conform_frand(&rng, -rad, rad), y = rtk_conform_frand(&rng, -rad, rad);
        float w = f->eval(state, x, y);
        if (!isfinite(w))
            nonfinite++;
        float w2 = f->eval(state, -x, y), w3 = f->eval(state, x, -y);
        float tol = 1e-6f * (fabsf(w) + 1e-6f);
        if (fabsf(w - w2) > tol || fabsf(w - w3) > tol) {
            asym++;
            worst = fmaxf(worst, fmaxf(fabsf(w - w2), fabsf(w - w3)));
        }
        /* A point past the radius on one axis or both. */
        float s = 1.0f + 1e-3f + 2.0f * rtk_pcg32_float(&rng);
        float ox = (i % 3 == 1) ? x : (x < 0 ? -s * rad : s * rad);
        float oy = (i % 3 == 2) ? y : (y < 0 ? -s * rad : s * rad);
        if (f->eval(state, ox, oy) != 0.0f)
            outside++;
    }
    snprintf(name, sizeof name, "finite inside the support [%s]", label);
    rtk_conform_check(r, nonfinite == 0 && isfinite(f->eval(state, 0, 0)), name, "%d non-finite values", nonfinite);
    snprintf(name, sizeof name, "zero past the radius [%s]", label);
    rtk_conform_check(r, outside == 0, name, "%d of 20000 points past the radius have non-zero weight", outside);
    snprintf(name, sizeof name, "symmetric in x and y [%s]", label);
    rtk_conform_check(r, asym == 0, name, "%d points differ from their mirror images (by up to %g)", asym, worst);
    /* Midpoint rule on a 1024^2 grid; error O(h^2) for smooth filters,
     * exact for the box whose edges fall on cell borders. */
    const int n = 1024;
    double h = 2.0 * rad / n, sum = 0.0;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++)
            sum += f->eval(state, (float)(-rad + (i + 0.5) * h), (float)(-rad + (j + 0.5) * h));
    sum *= h * h;
    double closed = f->integral(state);
    snprintf(name, sizeof name, "weights integrate to the closed form [%s]", label);
    rtk_conform_check(r, isfinite(closed) && closed != 0.0 && fabs(sum - closed) <= 2e-3 * fabs(closed) + 1e-9, name,
                      "numeric integral %.9g, closed form %.9g", sum, closed);
    check_constant_render(r, f, state, rad, label);
    note_weight_sums(r, f, state, rad, label);
}

void rtk_conform_filter(rtk_conform_runner *r, const rtk_plugin *p)
{
    const rtk_filter_fns *f = p->functions;
    rtk_conform_each_variant(r, p, f->create, f->destroy, check_filter);
}
