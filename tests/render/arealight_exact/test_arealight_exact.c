/* arealight and path at max_depth 1 (the shipped plugins, loaded from the
 * build tree) against the exact irradiance of a polygon light and against
 * each other, at points that see the light
 * edge-on as well as ordinary points. The scene is the Cornell box's
 * ceiling light (y = 0.5487, facing down, radiance L), the ceiling 0.1 mm
 * above it and the back wall (z = 0.5592, albedo rho, Lambertian). A wall
 * point x receives (Lambert's formula)
 *   E = L/2 |sum_i beta_i n . (v_i x v_i+1) / |v_i x v_i+1||,
 * v_i the unit directions from x to the light's corners in order, beta_i
 * the angle between v_i and v_i+1, n the wall's normal: the sum is
 * positive when the corners circle n counter-clockwise (right-handed) and
 * negative the other way round, hence |.|. The wall sends Lo = rho E / pi.
 * Probes just under the light see it at |cos| < 1/256, where an offset
 * along the shadow ray rounds to nothing and the ray hits the emitter
 * itself. Each probe takes 20,000 camera rays straight at it and passes
 * within 5 standard errors of their mean (the samples' own variance; a
 * false failure has probability 6e-7 per check): the probe's hit point and
 * the light's corners are exact in y, so float rounding adds no bias. */
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../check.h"

static const float light_y = 0.5487f, ceiling_y = 0.5488f, wall_z = 0.5592f;
static const float light_x0 = 0.213f, light_x1 = 0.343f, light_z0 = 0.227f, light_z1 = 0.332f;
static const float light_l = 10.0f, rho = 0.5f;
static const int samples = 20000;

static uint32_t add_material(rtk_scene *s, float albedo, float le)
{
    rtk_material m = rtk_material_default();
    m.base_color = rtk_rgb_make(albedo, albedo, albedo);
    m.emission = rtk_rgb_make(le, le, le);
    uint32_t id = RTK_INVALID_ID;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

/* Quad p[0..3]; its front side is (p1 - p0) x (p2 - p0). */
static void add_quad(rtk_scene *s, const rtk_vec3 p[4], uint32_t material)
{
    uint32_t i[4];
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, NULL, material);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, NULL, material);
}

/* The light's corners, its front facing down. */
static void light_corners(rtk_vec3 p[4])
{
    p[0] = rtk_vec3_make(light_x0, light_y, light_z0);
    p[1] = rtk_vec3_make(light_x1, light_y, light_z0);
    p[2] = rtk_vec3_make(light_x1, light_y, light_z1);
    p[3] = rtk_vec3_make(light_x0, light_y, light_z1);
}

static rtk_scene *make_scene(uint32_t needs)
{
    rtk_scene *s = rtk_scene_new("arealight-exact", needs);
    if (!s)
        return NULL;
    rtk_vec3 light[4];
    light_corners(light);
    add_quad(s, light, add_material(s, 0.0f, light_l));
    const rtk_vec3 ceiling[4] = {{0.0f, ceiling_y, 0.0f}, {0.556f, ceiling_y, 0.0f},
                                 {0.556f, ceiling_y, wall_z}, {0.0f, ceiling_y, wall_z}};
    add_quad(s, ceiling, add_material(s, rho, 0.0f));
    const rtk_vec3 wall[4] = {{0.0f, 0.0f, wall_z}, {0.0f, ceiling_y, wall_z},
                              {0.556f, ceiling_y, wall_z}, {0.556f, 0.0f, wall_z}};
    add_quad(s, wall, add_material(s, rho, 0.0f));
    if (rtk_scene_finish(s) != RTK_OK) {
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

/* Lambert's formula at x with receiver normal n, in double. */
static double polygon_irradiance(const double x[3], const double n[3])
{
    rtk_vec3 c[4];
    light_corners(c);
    double v[4][3];
    for (int i = 0; i < 4; i++) {
        double d[3] = {(double)c[i].x - x[0], (double)c[i].y - x[1], (double)c[i].z - x[2]};
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int k = 0; k < 3; k++)
            v[i][k] = d[k] / len;
    }
    double sum = 0.0;
    for (int i = 0; i < 4; i++) {
        const double *a = v[i], *b = v[(i + 1) % 4];
        double cr[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        double s = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
        double beta = atan2(s, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
        sum += beta * (n[0] * cr[0] + n[1] * cr[1] + n[2] * cr[2]) / s;
    }
    return 0.5 * (double)light_l * fabs(sum);
}

/* Largest |cos| at the light of the directions to x: at the light's point
 * nearest x, its corners lying in one plane y = light_y. */
static double max_cos_at_light(const double x[3])
{
    double px = fmin(fmax(x[0], (double)light_x0), (double)light_x1);
    double pz = fmin(fmax(x[2], (double)light_z0), (double)light_z1);
    double dy = (double)light_y - x[1], dx = px - x[0], dz = pz - x[2];
    return fabs(dy) / sqrt(dx * dx + dy * dy + dz * dz);
}

/* Mean and standard error of the green radiance along ray over samples
 * camera samples drawn with seed. */
static double li_mean(const rtk_integrator_fns *f, void *state, const rtk_scene *scene, const rtk_ray *ray,
                      uint64_t seed, double *se)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = scene;
    ctx.gen.seed = seed;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < samples; i++) {
        rtk_ctx_start_sample(&ctx, (uint64_t)i, 0);
        rtk_li_result r = {.depth = INFINITY};
        f->li(state, &ctx, ray, &r);
        sum += r.radiance.g;
        sum2 += (double)r.radiance.g * r.radiance.g;
    }
    double mean = sum / samples;
    *se = sqrt(fmax(0.0, sum2 / samples - mean * mean) / samples);
    return mean;
}

/* Wall points: height below the light and x. */
typedef struct probe {
    float below, x;
} probe;

static const probe probes[] = {
    {1e-4f, 0.278f}, {3e-4f, 0.278f}, {8e-4f, 0.278f}, {3e-4f, 0.1f}, /* edge-on: |cos| < 1/256 */
    {0.02f, 0.278f}, {0.1f, 0.278f},  {0.3f, 0.2f},                    /* ordinary */
};
#define PROBES (sizeof probes / sizeof probes[0])

/* One integrator's settings: the plugin and up to two parameters. */
typedef struct mode {
    const char *plugin;
    const char *key[2], *value[2];
    char label[64];
} mode;

/* Renders every probe with mode m and seed; the means and standard errors
 * go to mean[] and se[]. 0 when the plugin could not be set up. */
static int run_mode(rtk_registry *reg, const rtk_plugin *accel, mode *m, uint64_t seed, double mean[PROBES],
                    double se[PROBES])
{
    const rtk_plugin *p = NULL;
    if (m->key[1])
        snprintf(m->label, sizeof m->label, "%s %s=%s %s=%s", m->plugin, m->key[0], m->value[0], m->key[1],
                 m->value[1]);
    else
        snprintf(m->label, sizeof m->label, "%s %s=%s", m->plugin, m->key[0], m->value[0]);
    rtk_status st = rtk_registry_find(reg, RTK_KIND_INTEGRATOR, m->plugin, &p);
    const rtk_integrator_fns *f = st == RTK_OK ? p->functions : NULL;
    rtk_params *params = st == RTK_OK ? rtk_params_defaults(p) : NULL, *ap = rtk_params_defaults(accel);
    void *state = NULL;
    rtk_scene *scene = NULL;
    if (st == RTK_OK && !(params && ap))
        st = rtk_error(RTK_ERR_NOMEM, "out of memory");
    for (int k = 0; k < 2 && m->key[k] && st == RTK_OK; k++)
        st = rtk_params_set_text(params, m->key[k], m->value[k]);
    if (st == RTK_OK)
        st = f->create(params, &state);
    if (st == RTK_OK && !(scene = make_scene(f->needs(state))))
        st = rtk_error(RTK_ERR_NOMEM, "the scene could not be made");
    if (st == RTK_OK)
        st = rtk_bvh_build(scene, accel, ap, 1);
    if (st == RTK_OK && f->prepare)
        st = f->prepare(state, scene);
    check(st == RTK_OK, "%s: set up%s%s", m->label, st == RTK_OK ? "" : ": ", st == RTK_OK ? "" : rtk_error_message());
    for (size_t k = 0; st == RTK_OK && k < PROBES; k++) {
        float y = light_y - probes[k].below;
        double x[3] = {probes[k].x, y, wall_z}, n[3] = {0.0, 0.0, -1.0};
        double truth = rho * polygon_irradiance(x, n) / M_PI, cmax = max_cos_at_light(x);
        rtk_ray ray = {rtk_vec3_make(probes[k].x, y, wall_z - 0.01f), 0.0f, rtk_vec3_make(0.0f, 0.0f, 1.0f), INFINITY};
        mean[k] = li_mean(f, state, scene, &ray, seed, &se[k]);
        check(fabs(mean[k] - truth) <= 5.0 * se[k],
              "%s, wall at x %.3f, %.4f below the light (|cos| at the light <= %.2e%s): "
              "Lo %.7g, exact rho E / pi %.7g, ratio %.4f (5 SE = %.2e)",
              m->label, probes[k].x, probes[k].below, cmax, cmax < 1.0 / 256.0 ? ", edge-on" : "", mean[k], truth,
              mean[k] / truth, 5.0 * se[k]);
    }
    if (state)
        f->destroy(state);
    rtk_scene_free(scene);
    rtk_params_destroy(params);
    rtk_params_destroy(ap);
    return st == RTK_OK;
}

int main(void)
{
    rtk_registry *reg = NULL;
    const rtk_plugin *accel = NULL;
    if (rtk_registry_create(&reg) != RTK_OK || rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &accel)) {
        printf("FAIL  shipped plugins found: %s\n", rtk_error_message());
        return 1;
    }
    /* path at max_depth 1 is direct light: equal to arealight within the
     * two estimates' noise, and both to the exact value. */
    mode modes[] = {
        {"arealight", {"light_samples", "mis"}, {"1", "false"}, ""},
        {"arealight", {"light_samples", "mis"}, {"4", "true"}, ""},
        {"path", {"max_depth", NULL}, {"1", NULL}, ""},
    };
    double mean[3][PROBES], se[3][PROBES];
    int ok[3];
    for (int i = 0; i < 3; i++)
        ok[i] = run_mode(reg, accel, &modes[i], 11u + (uint64_t)i, mean[i], se[i]); /* independent estimates */
    for (int a = 0; a < 2 && ok[2]; a++)
        for (size_t k = 0; ok[a] && k < PROBES; k++) {
            double tol = 5.0 * sqrt(se[a][k] * se[a][k] + se[2][k] * se[2][k]);
            check(fabs(mean[2][k] - mean[a][k]) <= tol,
                  "%s equals %s within noise, %.4f below the light at x %.3f: %.7g vs %.7g (5 SE = %.2e)", modes[2].label, modes[a].label, probes[k].below, probes[k].x, mean[2][k], mean[a][k], tol);
        }
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
