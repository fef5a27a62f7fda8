/* ao against analytic answers. With cosine-weighted rays each occlusion
 * ray is a Bernoulli trial with success probability A (the unoccluded
 * fraction), so an estimate from N rays has standard error
 * sqrt(A (1 - A) / N); a check passes within 5 standard errors, and exactly
 * when A is 0 or 1. */
#include "internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int passed, failed;

static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2)
{
    uint32_t i[4];
    rtk_vec3 p[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, NULL, RTK_INVALID_ID);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, NULL, RTK_INVALID_ID);
}

static const rtk_plugin *ao_plugin, *median;

/* Estimates AO at the floor point `target` (normal +y) seen from above. */
static double estimate(rtk_scene *s, rtk_vec3 target, const char *rays, const char *distance, long *trials)
{
    rtk_params *ap = rtk_params_defaults(median);
    rtk_params *ip = rtk_params_defaults(ao_plugin);
    const rtk_integrator_fns *f = ao_plugin->functions;
    void *state = NULL;
    double sum = -1.0;
    if (rtk_scene_finish(s) == RTK_OK && rtk_bvh_build(s, median, ap, 1) == RTK_OK &&
        rtk_params_set_text(ip, "rays", rays) == RTK_OK && rtk_params_set_text(ip, "distance", distance) == RTK_OK &&
        f->create(ip, &state) == RTK_OK) {
        rtk_ctx ctx = {0};
        ctx.scene = s;
        ctx.seed = 11;
        const int samples = 2000;
        sum = 0.0;
        rtk_ray ray;
        ray.org = rtk_vec3_add(target, rtk_vec3_make(0.0f, 0.01f, 0.0f));
        ray.dir = rtk_vec3_make(0.0f, -1.0f, 0.0f);
        ray.tmin = 0.0f;
        ray.tmax = INFINITY;
        for (int i = 0; i < samples; i++) {
            rtk_ctx_start_sample(&ctx, (uint64_t)i, 0);
            rtk_li_result r = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, INFINITY};
            f->li(state, &ctx, &ray, &r);
            sum += r.radiance.r;
        }
        sum /= samples;
        *trials = (long)samples * atol(rays);
        f->destroy(state);
    } else {
        printf("     set-up failed: %s\n", rtk_error_message());
    }
    rtk_params_destroy(ap);
    rtk_params_destroy(ip);
    rtk_scene_free(s);
    return sum;
}

static void expect(const char *what, double got, double truth, long n)
{
    double se = sqrt(truth * (1.0 - truth) / (double)n);
    int ok = (truth == 0.0 || truth == 1.0) ? got == truth : fabs(got - truth) <= 5.0 * se;
    printf("%s  %s: %.6f, truth %.6f (5 SE = %.6f, %ld rays)\n", ok ? "ok  " : "FAIL", what, got, truth, 5.0 * se, n);
    ok ? passed++ : failed++;
}

int main(void)
{
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK || rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "ao", &ao_plugin) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK) {
        printf("FAIL  plugins: %s\n", rtk_error_message());
        return 1;
    }
    const float big = 1e4f;
    long n = 0;
    rtk_scene *s;
    double a;

    s = rtk_scene_new("plane", RTK_NEED_NORMALS);
    add_quad(s, rtk_vec3_make(-big, 0, -big), rtk_vec3_make(0, 0, 2 * big), rtk_vec3_make(2 * big, 0, 0));
    a = estimate(s, rtk_vec3_make(0.3f, 0, -0.2f), "16", "inf", &n);
    expect("unoccluded plane", a, 1.0, n);

    /* Floor y = 0 for x < 0, wall x = 0 facing -x: at its foot the wall
     * hides exactly the half of the hemisphere with dx > 0. */
    s = rtk_scene_new("wall", RTK_NEED_NORMALS);
    add_quad(s, rtk_vec3_make(-big, 0, -big), rtk_vec3_make(0, 0, 2 * big), rtk_vec3_make(big, 0, 0));
    add_quad(s, rtk_vec3_make(0, 0, -big), rtk_vec3_make(0, big, 0), rtk_vec3_make(0, 0, 2 * big));
    a = estimate(s, rtk_vec3_make(-1e-3f, 0, 0), "64", "inf", &n);
    expect("foot of an infinite wall", a, 0.5, n);

    /* Inner corner of the floor and two walls: a quarter stays open. */
    s = rtk_scene_new("corner", RTK_NEED_NORMALS);
    add_quad(s, rtk_vec3_make(-big, 0, -big), rtk_vec3_make(0, 0, big), rtk_vec3_make(big, 0, 0));
    add_quad(s, rtk_vec3_make(0, 0, -big), rtk_vec3_make(0, big, 0), rtk_vec3_make(0, 0, big));
    add_quad(s, rtk_vec3_make(-big, 0, 0), rtk_vec3_make(big, 0, 0), rtk_vec3_make(0, big, 0));
    a = estimate(s, rtk_vec3_make(-1e-3f, 0, -1e-3f), "64", "inf", &n);
    expect("inner corner of floor and two walls", a, 0.25, n);

    /* Under a ceiling at height h with AO distance R: a ray escapes when
     * h / cos(theta) >= R, which for cosine weighting has probability (h/R)^2. */
    const char *radii[] = {"1", "0.625", "0.4"};
    for (int k = 0; k < 3; k++) {
        s = rtk_scene_new("ceiling", RTK_NEED_NORMALS);
        add_quad(s, rtk_vec3_make(-big, 0, -big), rtk_vec3_make(0, 0, 2 * big), rtk_vec3_make(2 * big, 0, 0));
        add_quad(s, rtk_vec3_make(-big, 0.5f, -big), rtk_vec3_make(2 * big, 0, 0), rtk_vec3_make(0, 0, 2 * big));
        a = estimate(s, rtk_vec3_make(0, 0, 0), "64", radii[k], &n);
        double r = atof(radii[k]), truth = fmin(1.0, (0.5 / r) * (0.5 / r));
        char what[128];
        snprintf(what, sizeof what, "under a ceiling at h = 0.5 with distance R = %s", radii[k]);
        expect(what, a, truth, n);
    }

    /* Inside a closed box nothing escapes. */
    s = rtk_scene_new("box", RTK_NEED_NORMALS);
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(0, 0, 2), rtk_vec3_make(2, 0, 0));
    add_quad(s, rtk_vec3_make(-1, 2, -1), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 0, 2));
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 2, 0));
    add_quad(s, rtk_vec3_make(-1, 0, 1), rtk_vec3_make(0, 2, 0), rtk_vec3_make(2, 0, 0));
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(0, 2, 0), rtk_vec3_make(0, 0, 2));
    add_quad(s, rtk_vec3_make(1, 0, -1), rtk_vec3_make(0, 0, 2), rtk_vec3_make(0, 2, 0));
    a = estimate(s, rtk_vec3_make(0.2f, 0, 0.1f), "64", "inf", &n);
    expect("inside a closed box", a, 0.0, n);

    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
