/* whitted (the shipped plugin, loaded from the build tree) against answers
 * computed here in double, independently of the plugin and of the BSDF
 * service: whitted is deterministic per ray, so each check is one ray and
 * the tolerances cover float rounding.
 * - every punctual light counts: two points, a spot in its smoothstep
 *   band and a directional light over a Lambertian floor give
 *   rho / pi sum E_k cos_k; a blocker hides one of them (hard shadow);
 * - the default max_depth is 4: between two facing emissive mirrors of
 *   reflectance R a ray sees Le (1 + R + ... + R^4);
 * - a smooth coat (GGX alpha <= mirror_alpha) reflects as a mirror
 *   weighted by Schlick's F at wo, f0 = 0.04; a rougher one, or
 *   mirror_alpha 0, shows nothing of the emitter;
 * - diffuse = "oren-nayar" turns a glTF plastic's base into Fujii's
 *   Oren-Nayar with sigma = the roughness, "lambert" keeps it Lambert;
 * - ambient shows ambient x the diffuse albedo, none on a metal;
 * - a ray that leaves the scene sees the environment. */
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../check.h"

static const rtk_plugin *whitted, *median;

/* Quad o, o + e1, o + e1 + e2, o + e2; its front is e1 x e2. */
static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t material)
{
    uint32_t i[4];
    rtk_vec3 p[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, NULL, material);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, NULL, material);
}

static uint32_t add_material(rtk_scene *s, rtk_material m)
{
    uint32_t id = RTK_INVALID_ID;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

/* A material made in memory: Lambert of albedo rho, emitting le. */
static rtk_material lambert(float rho, float le)
{
    rtk_material m = rtk_material_default();
    m.base_color = rtk_rgb_make(rho, rho, rho);
    m.emission = rtk_rgb_make(le, le, le);
    return m;
}

/* A glTF metallic-roughness material. */
static rtk_material gltf(float base, float metallic, float roughness, float specular)
{
    rtk_material m = rtk_material_default();
    m.model = RTK_MODEL_METALLIC_ROUGHNESS;
    m.base_color = rtk_rgb_make(base, base, base);
    m.metallic = metallic;
    m.roughness = roughness;
    m.specular_weight = specular;
    return m;
}

static rtk_vec3 v3(double x, double y, double z)
{
    return rtk_vec3_make((float)x, (float)y, (float)z);
}

static rtk_ray make_ray(rtk_vec3 org, rtk_vec3 dir)
{
    rtk_ray r = {org, 0.0f, dir, INFINITY};
    return r;
}

/* A whitted instance with the defaults and up to two name=value pairs
 * (NULL ends them), and the scene fill makes for it, built; 0 on failure
 * (reported as what). */
typedef struct bench {
    void *state;
    rtk_scene *scene;
} bench;

static int bench_open(bench *b, const char *what, void (*fill)(rtk_scene *), const char *const *set)
{
    const rtk_integrator_fns *f = whitted->functions;
    rtk_params *params = rtk_params_defaults(whitted), *ap = rtk_params_defaults(median);
    b->state = NULL;
    b->scene = NULL;
    rtk_status st = params && ap ? RTK_OK : rtk_error(RTK_ERR_NOMEM, "out of memory");
    for (int k = 0; set && set[k] && st == RTK_OK; k += 2)
        st = rtk_params_set_text(params, set[k], set[k + 1]);
    if (st == RTK_OK)
        st = f->create(params, &b->state);
    if (st == RTK_OK && !(b->scene = rtk_scene_new(what, f->needs(b->state))))
        st = rtk_error(RTK_ERR_NOMEM, "out of memory");
    if (st == RTK_OK) {
        fill(b->scene);
        st = rtk_scene_finish(b->scene);
    }
    if (st == RTK_OK)
        st = rtk_bvh_build(b->scene, median, ap, 1);
    if (st == RTK_OK && f->prepare)
        st = f->prepare(b->state, b->scene);
    rtk_params_destroy(params);
    rtk_params_destroy(ap);
    if (st != RTK_OK)
        check(0, "%s: set up: %s", what, rtk_error_message());
    return st == RTK_OK;
}

static void bench_close(bench *b)
{
    const rtk_integrator_fns *f = whitted->functions;
    if (b->state)
        f->destroy(b->state);
    rtk_scene_free(b->scene);
}

/* The radiance along ray (no camera: no differentials). */
static rtk_rgb li(const bench *b, rtk_ray ray)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = b->scene;
    rtk_ctx_start_sample(&ctx, 0, 0);
    rtk_li_result r = {.depth = INFINITY};
    const rtk_integrator_fns *f = whitted->functions;
    f->li(b->state, &ctx, &ray, &r);
    return r.radiance;
}

static void expect(const char *what, double got, double truth, double rel)
{
    check(fabs(got - truth) <= rel * fabs(truth) + 1e-9, "%s: %.9g, truth %.9g", what, got, truth);
}

/* ---- every punctual light ---- */

static const double rho = 0.5;
/* The floor point the camera ray hits, and the lights. */
static const double px = 0.1, pz = -0.2;
static const double p1[3] = {0.3, 2.0, -0.4}, i1 = 3.0;
static const double p2[3] = {-1.5, 1.0, 0.5}, i2 = 2.0;
static const double sp[3] = {1.0, 1.5, 0.0}, is = 4.0, cos_in = 0.95, cos_out = 0.8;
static const double dird[3] = {0.3, -1.0, 0.2}, ed = 1.5;
/* The spot's axis: from sp towards a point beside the probe, so that the
 * probe lies in the smoothstep band. */
static const double aim[3] = {0.8, 0.0, 0.0};

static void unit(const double a[3], double out[3])
{
    double l = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    for (int k = 0; k < 3; k++)
        out[k] = a[k] / l;
}

static void lit_floor(rtk_scene *s, int blocked)
{
    add_quad(s, v3(-5, 0, -5), v3(0, 0, 10), v3(10, 0, 0), add_material(s, lambert((float)rho, 0)));
    double axis[3], d[3] = {aim[0] - sp[0], aim[1] - sp[1], aim[2] - sp[2]}, dn[3];
    unit(d, axis);
    unit(dird, dn);
    rtk_punctual_light l[4] = {
        {.type = RTK_LIGHT_POINT, .position = v3(p1[0], p1[1], p1[2]),
         .intensity = rtk_rgb_make((float)i1, (float)i1, (float)i1)},
        {.type = RTK_LIGHT_POINT, .position = v3(p2[0], p2[1], p2[2]),
         .intensity = rtk_rgb_make((float)i2, (float)i2, (float)i2)},
        {.type = RTK_LIGHT_SPOT, .position = v3(sp[0], sp[1], sp[2]), .direction = v3(axis[0], axis[1], axis[2]),
         .intensity = rtk_rgb_make((float)is, (float)is, (float)is), .cos_inner = (float)cos_in,
         .cos_outer = (float)cos_out},
        {.type = RTK_LIGHT_DIRECTIONAL, .direction = v3(dn[0], dn[1], dn[2]),
         .intensity = rtk_rgb_make((float)ed, (float)ed, (float)ed)},
    };
    for (int k = 0; k < 4; k++)
        rtk_scene_add_punctual(s, &l[k]);
    if (blocked) /* a small card halfway to the second point light, facing it */
        add_quad(s, v3((px + p2[0]) / 2 - 0.05, 0.5, (pz + p2[2]) / 2 - 0.05), v3(0.1, 0, 0), v3(0, 0, 0.1),
                 add_material(s, lambert(0.0f, 0)));
}

static void lit_floor_open(rtk_scene *s) { lit_floor(s, 0); }
static void lit_floor_blocked(rtk_scene *s) { lit_floor(s, 1); }

/* Irradiance at the probe from a point light at p of intensity i. */
static double point_e(const double p[3], double i)
{
    double d[3] = {p[0] - px, p[1], p[2] - pz};
    double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    return i * (d[1] / sqrt(r2)) / r2;
}

static void test_lights(void)
{
    double axis[3], d[3] = {aim[0] - sp[0], aim[1] - sp[1], aim[2] - sp[2]}, dn[3];
    unit(d, axis);
    unit(dird, dn);
    double ls[3] = {px - sp[0], -sp[1], pz - sp[2]}, lu[3];
    unit(ls, lu);
    double c = lu[0] * axis[0] + lu[1] * axis[1] + lu[2] * axis[2];
    double t = (c - cos_out) / (cos_in - cos_out);
    check(t > 0.05 && t < 0.95, "the probe lies in the spot's smoothstep band: t = %.3f", t);
    double falloff = t * t * (3.0 - 2.0 * t);
    double e1 = point_e(p1, i1), e2 = point_e(p2, i2), es = point_e(sp, is) * falloff, edir = ed * -dn[1];
    rtk_ray down = make_ray(v3(px, 1.0, pz), v3(0, -1, 0));
    bench b;
    if (bench_open(&b, "four lights", lit_floor_open, NULL)) {
        expect("two points, a spot and a directional light: Lo = rho / pi sum E_k", li(&b, down).g,
               rho / M_PI * (e1 + e2 + es + edir), 1e-5);
    }
    bench_close(&b);
    if (bench_open(&b, "four lights, one hidden", lit_floor_blocked, NULL)) {
        expect("a card hides the second point light: its term is gone (hard shadow)", li(&b, down).g,
               rho / M_PI * (e1 + es + edir), 1e-5);
    }
    bench_close(&b);
}

/* ---- recursion depth ---- */

static const double mirror_r = 0.5, mirror_le = 1.0;

/* Two smooth metal mirrors of reflectance mirror_r, emitting mirror_le,
 * facing each other at z = 0 (front +z) and z = 1 (front -z). */
static void mirror_pair(rtk_scene *s)
{
    rtk_material m = gltf((float)mirror_r, 1.0f, 0.0f, 1.0f);
    m.emission = rtk_rgb_make((float)mirror_le, (float)mirror_le, (float)mirror_le);
    uint32_t id = add_material(s, m);
    add_quad(s, v3(-5, -5, 0), v3(10, 0, 0), v3(0, 10, 0), id);
    add_quad(s, v3(-5, -5, 1), v3(0, 10, 0), v3(10, 0, 0), id);
}

static void test_depth(void)
{
    rtk_ray ray = make_ray(v3(0.1, 0.2, 0.5), v3(0, 0, -1));
    const char *depths[] = {NULL, "0", "1", "7"};
    const int want[] = {4, 0, 1, 7};
    for (int k = 0; k < 4; k++) {
        const char *const set[] = {"max_depth", depths[k], NULL};
        bench b;
        if (bench_open(&b, "facing mirrors", mirror_pair, depths[k] ? set : NULL)) {
            double truth = 0.0, r = 1.0;
            for (int d = 0; d <= want[k]; d++, r *= mirror_r)
                truth += mirror_le * r;
            char what[160];
            snprintf(what, sizeof what, "facing emissive mirrors, max_depth %d%s: Le (1 + R + ... + R^%d)", want[k],
                     depths[k] ? "" : " (the default)", want[k]);
            expect(what, li(&b, ray).g, truth, 1e-6);
        }
        bench_close(&b);
    }
}

/* ---- smooth coats reflect as mirrors weighted by Fresnel ---- */

static float coat_roughness;

/* A black plastic floor (glTF metallic 0, f0 0.04) under a white emitter
 * at y = 1 facing down. */
static void coat_scene(rtk_scene *s)
{
    add_quad(s, v3(-50, 0, -50), v3(0, 0, 100), v3(100, 0, 0), add_material(s, gltf(0.0f, 0.0f, coat_roughness, 1.0f)));
    add_quad(s, v3(-50, 1, -50), v3(100, 0, 0), v3(0, 0, 100), add_material(s, lambert(0.0f, 1.0f)));
}

static void test_coat(void)
{
    const double angles[3] = {0.0, 60.0, 80.0};
    const char *const none[] = {"mirror_alpha", "0", NULL};
    for (int k = 0; k < 3; k++) {
        double a = angles[k] * M_PI / 180.0, c = cos(a);
        rtk_ray ray = make_ray(v3(-0.5 * sin(a), 0.5 * c, 0.0), v3(sin(a), -c, 0.0));
        double f = 0.04 + 0.96 * pow(1.0 - c, 5.0);
        char what[160];
        bench b;
        coat_roughness = 0.3f; /* alpha 0.09 <= the default mirror_alpha 0.15 */
        if (bench_open(&b, "smooth coat", coat_scene, NULL)) {
            snprintf(what, sizeof what, "coat of roughness 0.3 at %.0f deg reflects Schlick's F = %.6f of the emitter",
                     angles[k], f);
            expect(what, li(&b, ray).g, f, 2e-5);
        }
        bench_close(&b);
        if (bench_open(&b, "smooth coat, mirror_alpha 0", coat_scene, none)) {
            snprintf(what, sizeof what, "... and nothing with mirror_alpha 0 (%.0f deg)", angles[k]);
            expect(what, li(&b, ray).g, 0.0, 0.0);
        }
        bench_close(&b);
        coat_roughness = 0.5f; /* alpha 0.25 */
        if (bench_open(&b, "rough coat", coat_scene, NULL)) {
            snprintf(what, sizeof what, "coat of roughness 0.5 (alpha 0.25 > 0.15) shows nothing at %.0f deg",
                     angles[k]);
            expect(what, li(&b, ray).g, 0.0, 0.0);
        }
        bench_close(&b);
    }
}

/* ---- Oren-Nayar ---- */

static const double on_rough = 0.5, on_rho = 0.6, on_light[3] = {-1.0, 1.6, 0.4}, on_i = 2.0;

/* A plastic floor with specular 0 (f0 = 0: Schlick's F is (1 - cos)^5) of
 * roughness on_rough, one point light on the viewer's side, where
 * Oren-Nayar's back-scattering shows and the coat's F at wo.m ~ 1 is
 * below 1e-12. */
static void on_scene(rtk_scene *s)
{
    add_quad(s, v3(-5, 0, -5), v3(0, 0, 10), v3(10, 0, 0),
             add_material(s, gltf((float)on_rho, 0.0f, (float)on_rough, 0.0f)));
    rtk_punctual_light l = {.type = RTK_LIGHT_POINT, .position = v3(on_light[0], on_light[1], on_light[2]),
                            .intensity = rtk_rgb_make((float)on_i, (float)on_i, (float)on_i)};
    rtk_scene_add_punctual(s, &l);
}

static void test_oren_nayar(void)
{
    /* Camera ray to the origin. */
    double o[3] = {-0.8, 1.0, 0.1}, wo[3], wi[3];
    unit(o, wo);
    unit(on_light, wi);
    double r2 = on_light[0] * on_light[0] + on_light[1] * on_light[1] + on_light[2] * on_light[2];
    double e = on_i * wi[1] / r2;
    /* The plastic's base: albedo x (1 - F(wo.z)) (1 - F(wi.z)). */
    double base = on_rho * (1.0 - pow(1.0 - wo[1], 5.0)) * (1.0 - pow(1.0 - wi[1], 5.0));
    double sigma = on_rough;
    double A = 1.0 / (M_PI + (M_PI / 2.0 - 2.0 / 3.0) * sigma), B = sigma * A;
    double s = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2] - wi[1] * wo[1];
    double tt = s > 0.0 ? fmax(wi[1], wo[1]) : 1.0;
    double on = base * (A + B * s / tt), lam = base / M_PI;
    rtk_ray ray = make_ray(v3(o[0], o[1], o[2]), v3(-o[0], -o[1], -o[2]));
    const char *const lambert_set[] = {"diffuse", "lambert", NULL};
    bench b;
    if (bench_open(&b, "Oren-Nayar floor", on_scene, NULL)) {
        expect("diffuse oren-nayar (the default): Fujii's f with sigma = the glTF roughness 0.5, x E", li(&b, ray).g,
               on * e, 1e-5);
    }
    bench_close(&b);
    if (bench_open(&b, "Lambert floor", on_scene, lambert_set)) {
        expect("diffuse lambert: the plastic's Lambert base x E", li(&b, ray).g, lam * e, 1e-5);
    }
    bench_close(&b);
    check(fabs(on - lam) > 0.05 * on, "... the two differ here: f %.6f against %.6f", on, lam);
}

/* ---- ambient and the environment ---- */

static void ambient_scene(rtk_scene *s)
{
    add_quad(s, v3(-5, 0, -5), v3(0, 0, 10), v3(5, 0, 0), add_material(s, lambert((float)rho, 0)));
    add_quad(s, v3(0, 0, -5), v3(0, 0, 10), v3(5, 0, 0), add_material(s, gltf(0.7f, 1.0f, 0.6f, 1.0f)));
    rtk_environment *env = NULL;
    if (rtk_environment_constant(rtk_rgb_make(0.25f, 0.5f, 0.75f), 2.0f, &env) == RTK_OK)
        rtk_scene_set_environment(s, env);
}

static void test_ambient_environment(void)
{
    const char *const set[] = {"ambient", "0.3", NULL};
    bench b;
    if (bench_open(&b, "ambient", ambient_scene, set)) {
        rtk_ray down = make_ray(v3(-1, 1, 0), v3(0, -1, 0));
        expect("ambient 0.3 on a Lambert floor of rho 0.5 (no lights): 0.15", li(&b, down).g, 0.3 * rho, 1e-6);
        expect("... and none on a rough metal", li(&b, make_ray(v3(1, 1, 0), v3(0, -1, 0))).g, 0.0, 0.0);
        rtk_rgb sky = li(&b, make_ray(v3(-1, 1, 0), v3(0.2, 1, 0)));
        check(sky.r == 0.5f && sky.g == 1.0f && sky.b == 1.5f,
              "a miss sees the environment: (%g, %g, %g), truth (0.5, 1, 1.5)", (double)sky.r, (double)sky.g,
              (double)sky.b);
    }
    bench_close(&b);
}

int main(void)
{
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK || rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "whitted", &whitted) ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median)) {
        printf("FAIL  shipped plugins found: %s\n", rtk_error_message());
        return 1;
    }
    test_lights();
    test_depth();
    test_coat();
    test_oren_nayar();
    test_ambient_environment();
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
