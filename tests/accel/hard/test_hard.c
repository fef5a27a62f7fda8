/* The hard cases of the accelerator checks at full size, for every
 * accelerator among the plugin files given (others are skipped):
 *   test_hard full PLUGIN...     the closed icosphere with 1e6 rays per
 *                                placement (`rtk conform` traces 1e5), and
 *                                AO from cameras inside closed meshes, which
 *                                must be exactly 0 (needs the ao plugin)
 *   test_hard paths PLUGIN...    every hard case, for the default parameters,
 *                                on the traversal the environment picks
 *                                (RTK_SIMD), so that each traversal path sees
 *                                them, not only the best
 * Output is rtk conform's: one line per check, then "N passed, N failed". */
#include "config/config.h"
#include "conform/conform.h"
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int passed, failed;

static void check(int ok, const char *what)
{
    printf("%s  %s\n", ok ? "ok  " : "FAIL", what);
    ok ? passed++ : failed++;
}

static rtk_status unit_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static void unit_destroy(void *state)
{
    (void)state;
}

static float unit_radius(const void *state)
{
    (void)state;
    return 0.5f;
}

static float unit_eval(const void *state, float dx, float dy)
{
    (void)state;
    return fabsf(dx) <= 0.5f && fabsf(dy) <= 0.5f ? 1.0f : 0.0f;
}

static double unit_integral(const void *state)
{
    (void)state;
    return 1.0;
}

static const rtk_filter_fns unit_box = {.size = sizeof(rtk_filter_fns),
                                        .create = unit_create,
                                        .radius = unit_radius,
                                        .eval = unit_eval,
                                        .integral = unit_integral,
                                        .destroy = unit_destroy};

/* A closed UV sphere (poles and seam shared) of radius r around c. */
static rtk_scene *closed_sphere(uint32_t needs, double cx, double cy, double cz, double r)
{
    rtk_scene *s = rtk_scene_new("closed sphere", needs);
    if (!s)
        return NULL;
    const int nu = 96, nv = 48;
    uint32_t north = 0, south = 0, *ring = malloc(sizeof *ring * (size_t)nu * (nv - 1));
    int ok = ring != NULL;
    ok = ok && rtk_scene_add_vertex(s, cx, cy + r, cz, &north) == RTK_OK;
    ok = ok && rtk_scene_add_vertex(s, cx, cy - r, cz, &south) == RTK_OK;
    for (int j = 1; j < nv && ok; j++)
        for (int i = 0; i < nu && ok; i++) {
            double th = M_PI * j / nv, ph = 2.0 * M_PI * i / nu;
            ok = rtk_scene_add_vertex(s, cx + r * sin(th) * cos(ph), cy + r * cos(th), cz + r * sin(th) * sin(ph),
                                      &ring[(j - 1) * nu + i]) == RTK_OK;
        }
    for (int i = 0; i < nu && ok; i++) {
        int i1 = (i + 1) % nu;
        ok = rtk_scene_add_triangle(s, north, ring[i1], ring[i], NULL, NULL, RTK_INVALID_ID) == RTK_OK &&
             rtk_scene_add_triangle(s, south, ring[(nv - 2) * nu + i], ring[(nv - 2) * nu + i1], NULL, NULL,
                                    RTK_INVALID_ID) == RTK_OK;
        for (int j = 0; j + 1 < nv - 1 && ok; j++) {
            uint32_t a = ring[j * nu + i], b = ring[j * nu + i1], c = ring[(j + 1) * nu + i1], d = ring[(j + 1) * nu + i];
            ok = rtk_scene_add_triangle(s, a, b, c, NULL, NULL, RTK_INVALID_ID) == RTK_OK &&
                 rtk_scene_add_triangle(s, a, c, d, NULL, NULL, RTK_INVALID_ID) == RTK_OK;
        }
    }
    free(ring);
    if (!ok || rtk_scene_finish(s) != RTK_OK) {
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

/* AO seen from cameras inside a closed sphere: every camera ray hits the
 * inside, every occlusion ray from there hits the sphere again, so every
 * pixel is exactly 0 (ao's distance is infinite by default). */
static void ao_inside(const rtk_plugin *accel, const rtk_plugin *ao)
{
    static const double places[2][4] = {{0, 0, 0, 1}, {1e5, -1e5, 1e5, 10}};
    const rtk_integrator_fns *f = ao->functions;
    for (int k = 0; k < 2; k++) {
        char what[256];
        snprintf(what, sizeof what, "ao from inside a closed sphere (radius %g at (%g, %g, %g)) is 0 in every pixel [%s]",
                 places[k][3], places[k][0], places[k][1], places[k][2], accel->name);
        void *state = NULL;
        rtk_params *ip = rtk_params_defaults(ao), *ap = rtk_params_defaults(accel);
        rtk_scene *s = NULL;
        rtk_status st = ip && ap ? f->create(ip, &state) : RTK_ERR_NOMEM;
        if (st == RTK_OK) {
            s = closed_sphere(f->needs(state), places[k][0], places[k][1], places[k][2], places[k][3]);
            st = s ? rtk_bvh_build(s, accel, ap, 2) : RTK_ERR_NOMEM;
        }
        if (st == RTK_OK && f->prepare)
            st = f->prepare(state, s);
        const uint32_t w = 40, h = 30;
        float *px = malloc(sizeof(float) * RTK_FILM_CHANNELS * w * h);
        size_t lit = 0;
        rtk_render_stats stats = {0, 0, 0};
        for (int cam_i = 0; cam_i < 3 && st == RTK_OK; cam_i++) {
            static const double eye[3][3] = {{0, 0, 0}, {0.5, -0.3, 0.2}, {-0.9, 0, 0}};
            static const double look[3][3] = {{0, 0, 1}, {1, 1, -1}, {1, 0, 0}};
            rtk_camera_desc d;
            double r = places[k][3];
            d.position = rtk_vec3_make((float)(places[k][0] + r * eye[cam_i][0]), (float)(places[k][1] + r * eye[cam_i][1]),
                                       (float)(places[k][2] + r * eye[cam_i][2]));
            d.look_at = rtk_vec3_make((float)(d.position.x + look[cam_i][0]), (float)(d.position.y + look[cam_i][1]),
                                      (float)(d.position.z + look[cam_i][2]));
            d.up = rtk_vec3_make(0, 1, 0.25f);
            d.fov_deg = 100.0f;
            rtk_camera cam;
            st = px ? rtk_camera_init(&cam, &d, w, h) : RTK_ERR_NOMEM;
            rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
            job.scene = s;
            job.camera = &cam;
            job.integrator = f;
            job.integrator_state = state;
            job.filter = &unit_box;
            job.spp = 4;
            job.seed = 9;
            job.threads = 2;
            if (st == RTK_OK)
                st = rtk_render_film(&job, px, &stats);
            for (size_t i = 0; st == RTK_OK && i < (size_t)w * h; i++)
                for (int c = 0; c < 3; c++)
                    lit += px[i * RTK_FILM_CHANNELS + (size_t)c] != 0.0f;
        }
        if (st != RTK_OK)
            printf("      %s\n", rtk_error_message());
        else if (lit || stats.bad_samples)
            printf("      %zu pixel values are not 0, %llu bad samples\n", lit, (unsigned long long)stats.bad_samples);
        check(st == RTK_OK && lit == 0 && stats.bad_samples == 0, what);
        free(px);
        if (state)
            f->destroy(state);
        rtk_scene_free(s);
        rtk_params_destroy(ip);
        rtk_params_destroy(ap);
    }
}

int main(int argc, char **argv)
{
    if (argc < 2 || (strcmp(argv[1], "full") != 0 && strcmp(argv[1], "paths") != 0)) {
        fprintf(stderr, "usage: test_hard full|paths PLUGIN.so...\n");
        return 2;
    }
    int full = strcmp(argv[1], "full") == 0;
    const rtk_plugin *ao = NULL;
    for (int i = 2; i < argc; i++) {
        const rtk_plugin *p = NULL;
        if (rtk_plugin_open(argv[i], 0, &p) == RTK_OK && p->kind == RTK_KIND_INTEGRATOR && strcmp(p->name, "ao") == 0)
            ao = p;
    }
    if (full && !ao)
        printf("# no ao plugin among the arguments: AO inside a closed mesh not checked\n");
    const char *simd = getenv("RTK_SIMD");
    if (!full)
        printf("# traversal path: RTK_SIMD=%s\n", simd ? simd : "(unset: the best the CPU runs)");
    for (int i = 2; i < argc; i++) {
        const rtk_plugin *p = NULL;
        if (rtk_plugin_open(argv[i], 0, &p) != RTK_OK) {
            check(0, rtk_error_message());
            continue;
        }
        if (p->kind != RTK_KIND_ACCELERATOR)
            continue;
        rtk_conform_options o = {0, 0, 0, 0};
        o.cases = full ? RTK_CONFORM_ICOSPHERE : RTK_CONFORM_ALL & ~(uint32_t)RTK_CONFORM_BASIC;
        o.icosphere_rays = full ? 1000000 : 0;
        o.defaults_only = !full;
        int p_ok = 0, p_bad = 0;
        /* RTK_ERR_UNSUPPORTED: a device accelerator without its device (a "skip" line says so). */
        const rtk_status st = rtk_conform_run(argv[i], &o, stdout, &p_ok, &p_bad);
        passed += p_ok;
        failed += p_bad;
        if (full && ao && st != RTK_ERR_UNSUPPORTED)
            ao_inside(p, ao);
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
