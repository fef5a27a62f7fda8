/* The known-answer profiles an integrator declares (rtk_plugin.conform,
 * a comma-separated list; docs/conform.md), run by `rtk conform` after
 * the generic checks: scenes whose answer is known in closed form, traced
 * with a one-leaf builder so that no accelerator plugin takes part. A
 * profile names a computation, not a plugin. It creates the integrator
 * with its defaults and sets only the parameters it names; a plugin that
 * declares a profile must have them, with these types and ranges that
 * admit the values set:
 *
 *   profile            sets                      checks
 *   ambient-occlusion  rays int: 16, 64          AO of a plane 1, at the foot of a wall 1/2, in an
 *                      distance float: inf, 1,   inner corner 1/4, under a ceiling at h with distance
 *                        0.625, 0.4              R min(1, (h/R)^2), inside a closed box 0
 *   direct-area-light  light_samples int: 1, 4   square and disk lights over a Lambertian receiver
 *                      mis bool: false, true     (rho L F), a furnace (rho Le)
 *   whitted-recursion  max_depth int: 1, 3, 5    point light rho I cos / (pi r^2) from the scene and
 *                                                from glTF KHR_lights_punctual, a mirror against the
 *                                                mirrored camera, glass Fresnel at normal incidence,
 *                                                total internal reflection, a parallel slab
 *   headlight-shading  ambient float: 0          Kd x |cos| on a quad, front and back; depth and
 *                                                normal AOVs
 *   environment-light  (defaults)                constant sky L: a miss sees L, a white floor L, at
 *                                                a black wall's foot L/2, in a black corner L/4, a
 *                                                white sphere L
 *   path-tracing       max_depth int: 0, 1, 2,   closed furnace Le (1 - rho^(k+1)) / (1 - rho), the
 *                        3, 1024                 square light rho L F at depth 1, a white sphere
 *                                                under a constant sky L
 *
 * Tolerances: a Monte Carlo estimate passes within 5 standard errors of
 * its sample count (ambient-occlusion: each cosine-weighted ray is a
 * Bernoulli trial, sqrt(A (1 - A) / N); direct-area-light: the samples'
 * own variance) plus a stated bound on the scene's bias; an answer of
 * exactly 0 or 1 must come out exactly. whitted-recursion and
 * headlight-shading are deterministic per ray: the tolerances cover float
 * rounding. Every check line carries the estimate and the truth. */
#include "conform.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Where check lines go and what they count. */
typedef struct tally {
    FILE *out;
    int *passed, *failed;
} tally;

static void check(tally *t, int ok, const char *fmt, ...) RTK_PRINTF(3, 4);

/* One line, "ok" or "FAIL" and the text. */
static void check(tally *t, int ok, const char *fmt, ...)
{
    fputs(ok ? "ok    " : "FAIL  ", t->out);
    va_list ap;
    va_start(ap, fmt);
    vfprintf(t->out, fmt, ap);
    va_end(ap);
    fputc('\n', t->out);
    if (ok)
        (*t->passed)++;
    else
        (*t->failed)++;
}

/* Deterministic answers pass within rel x |truth| (a truth of 0 exactly). */
static void expect_close(tally *t, const char *what, double got, double truth, double rel)
{
    int ok = fabs(got - truth) <= rel * fabs(truth) + (truth == 0.0 ? 0.0 : 1e-12);
    check(t, ok, "%s: %.9g, truth %.9g", what, got, truth);
}

static uint32_t add_material(rtk_scene *s, rtk_material m)
{
    return rtk_conform_add_material(s, m);
}

/* The profiles' quads carry no uvs. */
static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t material)
{
    rtk_conform_add_quad(s, o, e1, e2, material, 0);
}

static rtk_material diffuse(float albedo, float le)
{
    return rtk_conform_diffuse(rtk_rgb_make(albedo, albedo, albedo), le);
}

/* Smooth glass of index 1.5 (glTF: transmission 1, roughness 0, white):
 * rtk_surface_bsdf's smooth dielectric. */
static rtk_material glass(void)
{
    rtk_material m = rtk_material_default();
    m.model = RTK_MODEL_METALLIC_ROUGHNESS;
    m.metallic = 0.0f;
    m.roughness = 0.0f;
    m.transmission = 1.0f;
    m.ior = 1.5f;
    return m;
}

static rtk_vec3 v3(double x, double y, double z)
{
    return rtk_vec3_make((float)x, (float)y, (float)z);
}

static rtk_ray make_ray(rtk_vec3 org, rtk_vec3 dir)
{
    rtk_ray r = {.org = org, .tmin = 0.0f, .dir = dir, .tmax = INFINITY};
    return r;
}

/* The integrator under test and the scene of one exact test. */
typedef struct bench {
    const rtk_integrator_fns *f;
    void *state;
    uint32_t needs;   /* the instance's RTK_NEED_* flags: the scene keeps only these */
    rtk_scene *scene; /* made by the caller from needs, then bench_ready */
} bench;

/* Creates p's instance from its defaults with set = {name, value, ...,
 * NULL} applied. Returns 0 after reporting the check `what` failed. */
static int bench_open(tally *t, const rtk_plugin *p, const char *const *set, const char *what, bench *b)
{
    memset(b, 0, sizeof *b);
    b->f = p->functions;
    rtk_params *params = rtk_params_defaults(p);
    rtk_status st = params ? RTK_OK : rtk_error(RTK_ERR_NOMEM, "out of memory");
    for (int i = 0; st == RTK_OK && set[i]; i += 2)
        st = rtk_params_set_text(params, set[i], set[i + 1]);
    if (st == RTK_OK)
        st = b->f->create(params, &b->state);
    rtk_params_destroy(params);
    if (st != RTK_OK) {
        b->f = NULL;
        check(t, 0, "%s: set-up failed: %s", what, rtk_error_message());
        return 0;
    }
    b->needs = b->f->needs(b->state);
    return 1;
}

/* Finishes b's scene (a loaded one is finished already), builds it and
 * prepares the instance for it. Returns 0 after reporting a failure. */
static int bench_ready(tally *t, bench *b, const char *what)
{
    rtk_status st = RTK_OK;
    if (!b->scene)
        st = rtk_error(RTK_ERR_NOMEM, "out of memory for the scene");
    else if (!b->scene->finished)
        st = rtk_scene_finish(b->scene);
    if (st == RTK_OK)
        st = rtk_bvh_build(b->scene, &rtk_conform_one_leaf, NULL, 1);
    if (st == RTK_OK && b->f->prepare)
        st = b->f->prepare(b->state, b->scene);
    if (st != RTK_OK)
        check(t, 0, "%s: set-up failed: %s", what, rtk_error_message());
    return st == RTK_OK;
}

static void bench_close(bench *b)
{
    if (b->f)
        b->f->destroy(b->state);
    rtk_scene_free(b->scene);
    memset(b, 0, sizeof *b);
}

/* Mean of channel c (0 red, 1 green) of the radiance along ray over n
 * samples (pixel i, sample 0 for i < n, from seed); *se, when not NULL,
 * gets the standard error from the samples' own variance. */
static double bench_mean(const bench *b, const rtk_ray *ray, uint64_t seed, int n, int c, double *se)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = b->scene;
    ctx.gen.seed = seed;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < n; i++) {
        rtk_ctx_start_sample(&ctx, (uint64_t)i, 0);
        rtk_li_result r = {.depth = INFINITY};
        b->f->li(b->state, &ctx, ray, &r);
        double v = c == 0 ? r.radiance.r : r.radiance.g;
        sum += v;
        sum2 += v * v;
    }
    double mean = sum / n;
    if (se)
        *se = sqrt(fmax(0.0, sum2 / n - mean * mean) / n);
    return mean;
}

/* ---- ambient-occlusion ---- */

/* Far enough that the quads below act as infinite planes. */
static const float big = 1e4f;

static void ao_plane(rtk_scene *s)
{
    add_quad(s, v3(-big, 0, -big), v3(0, 0, 2 * big), v3(2 * big, 0, 0), RTK_INVALID_ID);
}

/* Floor y = 0 for x < 0, wall x = 0 facing -x: at its foot the wall hides
 * exactly the half of the hemisphere with dx > 0. */
static void ao_wall(rtk_scene *s)
{
    add_quad(s, v3(-big, 0, -big), v3(0, 0, 2 * big), v3(big, 0, 0), RTK_INVALID_ID);
    add_quad(s, v3(0, 0, -big), v3(0, big, 0), v3(0, 0, 2 * big), RTK_INVALID_ID);
}

/* Inner corner of the floor and two walls: a quarter stays open. */
static void ao_corner(rtk_scene *s)
{
    add_quad(s, v3(-big, 0, -big), v3(0, 0, big), v3(big, 0, 0), RTK_INVALID_ID);
    add_quad(s, v3(0, 0, -big), v3(0, big, 0), v3(0, 0, big), RTK_INVALID_ID);
    add_quad(s, v3(-big, 0, 0), v3(big, 0, 0), v3(0, big, 0), RTK_INVALID_ID);
}

/* A ceiling at h = 0.5 over the floor. */
static void ao_ceiling(rtk_scene *s)
{
    add_quad(s, v3(-big, 0, -big), v3(0, 0, 2 * big), v3(2 * big, 0, 0), RTK_INVALID_ID);
    add_quad(s, v3(-big, 0.5, -big), v3(2 * big, 0, 0), v3(0, 0, 2 * big), RTK_INVALID_ID);
}

/* A closed box, 2 on a side, floor at y = 0. */
static void ao_box(rtk_scene *s)
{
    add_quad(s, v3(-1, 0, -1), v3(0, 0, 2), v3(2, 0, 0), RTK_INVALID_ID);
    add_quad(s, v3(-1, 2, -1), v3(2, 0, 0), v3(0, 0, 2), RTK_INVALID_ID);
    add_quad(s, v3(-1, 0, -1), v3(2, 0, 0), v3(0, 2, 0), RTK_INVALID_ID);
    add_quad(s, v3(-1, 0, 1), v3(0, 2, 0), v3(2, 0, 0), RTK_INVALID_ID);
    add_quad(s, v3(-1, 0, -1), v3(0, 2, 0), v3(0, 0, 2), RTK_INVALID_ID);
    add_quad(s, v3(1, 0, -1), v3(0, 0, 2), v3(0, 2, 0), RTK_INVALID_ID);
}

/* AO at the floor point target (normal +y) seen from straight above, with
 * rays and distance set, against truth: 2000 camera rays of `rays`
 * occlusion rays each. */
static void ao_expect(tally *t, const rtk_plugin *p, const char *what, void (*fill)(rtk_scene *), rtk_vec3 target,
                      const char *rays, const char *distance, double truth)
{
    const char *const set[] = {"rays", rays, "distance", distance, NULL};
    bench b;
    if (bench_open(t, p, set, what, &b)) {
        if ((b.scene = rtk_scene_new(what, b.needs)))
            fill(b.scene);
        if (bench_ready(t, &b, what)) {
            const int samples = 2000;
            rtk_ray ray = make_ray(rtk_vec3_add(target, v3(0, 0.01, 0)), v3(0, -1, 0));
            double a = bench_mean(&b, &ray, 11, samples, 0, NULL);
            long n = (long)samples * atol(rays);
            double se = sqrt(truth * (1.0 - truth) / (double)n);
            int ok = (truth == 0.0 || truth == 1.0) ? a == truth : fabs(a - truth) <= 5.0 * se;
            check(t, ok, "%s: %.6f, truth %.6f (5 SE = %.6f, %ld rays)", what, a, truth, 5.0 * se, n);
        }
    }
    bench_close(&b);
}

static void ambient_occlusion_profile(tally *t, const rtk_plugin *p)
{
    ao_expect(t, p, "unoccluded plane", ao_plane, v3(0.3, 0, -0.2), "16", "inf", 1.0);
    ao_expect(t, p, "foot of an infinite wall", ao_wall, v3(-1e-3, 0, 0), "64", "inf", 0.5);
    ao_expect(t, p, "inner corner of floor and two walls", ao_corner, v3(-1e-3, 0, -1e-3), "64", "inf", 0.25);
    /* Under the ceiling a ray escapes when h / cos(theta) >= R, which for
     * cosine weighting has probability (h/R)^2. */
    const char *radii[] = {"1", "0.625", "0.4"};
    for (int k = 0; k < 3; k++) {
        double r = atof(radii[k]), truth = fmin(1.0, (0.5 / r) * (0.5 / r));
        char what[128];
        snprintf(what, sizeof what, "under a ceiling at h = 0.5 with distance R = %s", radii[k]);
        ao_expect(t, p, what, ao_ceiling, v3(0, 0, 0), "64", radii[k], truth);
    }
    ao_expect(t, p, "inside a closed box", ao_box, v3(0.2, 0, 0.1), "64", "inf", 0.0);
}

/* ---- direct-area-light ---- */

/* Receivers are Lambertian with albedo rho, so Lo = rho / pi * E = rho L F
 * for a uniform emitter of radiance L with view factor F. */
static const float rho = 0.5f, light_h = 1.0f, light_l = 2.0f;
/* The square light's half-side, the disk's radius and its fan of triangles. */
static const float square_a = 0.5f, disk_r = 0.75f;
static const int disk_fan = 512;

static void receiver(rtk_scene *s)
{
    add_quad(s, v3(-5, 0, -5), v3(0, 0, 10), v3(10, 0, 0), add_material(s, diffuse(rho, 0.0f)));
}

static void square_light(rtk_scene *s)
{
    receiver(s);
    const float a = square_a;
    add_quad(s, v3(-a, light_h, -a), v3(2 * a, 0, 0), v3(0, 0, 2 * a), add_material(s, diffuse(0.0f, light_l)));
}

/* A disk facing down, as a fan of disk_fan triangles. */
static void disk_light(rtk_scene *s)
{
    receiver(s);
    uint32_t m = add_material(s, diffuse(0.0f, light_l)), c, first = 0, prev = 0;
    rtk_scene_add_vertex(s, 0, light_h, 0, &c);
    for (int k = 0; k <= disk_fan; k++) {
        double a = 2.0 * M_PI * (k % disk_fan) / disk_fan;
        uint32_t v = first;
        if (k < disk_fan)
            rtk_scene_add_vertex(s, disk_r * cos(a), light_h, disk_r * sin(a), &v);
        if (k == 0)
            first = v;
        else
            rtk_scene_add_triangle(s, c, prev, v, NULL, NULL, m); /* (prev - c) x (v - c) points down */
        prev = v;
    }
}

/* A convex diffuse block (rho = 0.5) inside a closed box whose inner faces
 * emit Le = 1: irradiance pi Le everywhere, so Lo = rho Le. */
static void furnace(rtk_scene *s)
{
    uint32_t wall = add_material(s, diffuse(0.3f, 1.0f)), obj = add_material(s, diffuse(rho, 0.0f));
    add_quad(s, v3(-2, -2, -2), v3(0, 0, 4), v3(4, 0, 0), wall); /* floor, up */
    add_quad(s, v3(-2, 2, -2), v3(4, 0, 0), v3(0, 0, 4), wall);  /* ceiling, down */
    add_quad(s, v3(-2, -2, -2), v3(4, 0, 0), v3(0, 4, 0), wall); /* back, +z */
    add_quad(s, v3(-2, -2, 2), v3(0, 4, 0), v3(4, 0, 0), wall);  /* front, -z */
    add_quad(s, v3(-2, -2, -2), v3(0, 4, 0), v3(0, 0, 4), wall); /* left, +x */
    add_quad(s, v3(2, -2, -2), v3(0, 0, 4), v3(0, 4, 0), wall);  /* right, -x */
    add_quad(s, v3(-0.5, 0.5, -0.5), v3(0, 0, 1), v3(1, 0, 0), obj);   /* block top */
    add_quad(s, v3(-0.5, -0.5, -0.5), v3(1, 0, 0), v3(0, 0, 1), obj);  /* bottom */
    add_quad(s, v3(-0.5, -0.5, 0.5), v3(1, 0, 0), v3(0, 1, 0), obj);   /* +z */
    add_quad(s, v3(-0.5, -0.5, -0.5), v3(0, 1, 0), v3(1, 0, 0), obj);  /* -z */
    add_quad(s, v3(0.5, -0.5, -0.5), v3(0, 1, 0), v3(0, 0, 1), obj);   /* +x */
    add_quad(s, v3(-0.5, -0.5, -0.5), v3(0, 0, 1), v3(0, 1, 0), obj);  /* -x */
}

/* A receiver point, the unit direction it is seen from, and its truth. */
typedef struct probe {
    rtk_vec3 at, from;
    double truth, bias; /* bias: bound on the scene's own deviation from the closed form */
    const char *what;
} probe;

/* The probes of the scene fill makes, with one light sample and no MIS,
 * then four samples with MIS: 20,000 camera rays each. */
static void area_light_expect(tally *t, const rtk_plugin *p, void (*fill)(rtk_scene *), const probe *probes, int count)
{
    static const char *const modes[2][5] = {{"light_samples", "1", "mis", "false", NULL},
                                            {"light_samples", "4", "mis", "true", NULL}};
    for (int m = 0; m < 2; m++) {
        bench b;
        if (bench_open(t, p, modes[m], probes[0].what, &b)) {
            if ((b.scene = rtk_scene_new(probes[0].what, b.needs)))
                fill(b.scene);
            if (bench_ready(t, &b, probes[0].what)) {
                for (int k = 0; k < count; k++) {
                    const probe *q = &probes[k];
                    rtk_ray ray = make_ray(rtk_vec3_add(q->at, rtk_vec3_scale(q->from, 0.01f)), rtk_vec3_neg(q->from));
                    double se = 0.0, mean = bench_mean(&b, &ray, 5, 20000, 1, &se);
                    check(t, fabs(mean - q->truth) <= 5.0 * se + q->bias,
                          "%s [light_samples=%s mis=%s]: %.6f, truth %.6f (5 SE = %.6f + bias bound %.1e)", q->what,
                          modes[m][1], modes[m][3], mean, q->truth, 5.0 * se, q->bias);
                }
            }
        }
        bench_close(&b);
    }
}

static void direct_area_light_profile(tally *t, const rtk_plugin *p)
{
    const rtk_vec3 up = v3(0, 1, 0);
    double A = (double)square_a / light_h, q = A / sqrt(1.0 + A * A);
    double F = 4.0 / M_PI * q * atan(q);
    const probe square = {v3(0, 0, 0), up, rho * light_l * F, 0.0, "square light: Lo = rho L F"};
    area_light_expect(t, p, square_light, &square, 1);

    /* F = r^2 / (h^2 + r^2). The fan has the inscribed polygon's area,
     * smaller by the factor sin(2 pi / n) / (2 pi / n); that bounds the
     * bias of the check. */
    double Fd = (double)disk_r * disk_r / ((double)light_h * light_h + (double)disk_r * disk_r);
    double x = 2.0 * M_PI / disk_fan;
    const probe disk = {v3(0, 0, 0), up, rho * light_l * Fd, rho * light_l * Fd * (1.0 - sin(x) / x),
                        "disk light: Lo = rho L r^2 / (h^2 + r^2)"};
    area_light_expect(t, p, disk_light, &disk, 1);

    const probe block[2] = {{v3(0.1, 0.5, -0.2), up, rho, 0.0, "furnace: block top shows rho Le"},
                            {v3(0.5, 0.1, 0.3), v3(1, 0, 0), rho, 0.0, "furnace: block side shows rho Le"}};
    area_light_expect(t, p, furnace, block, 2);
}

/* ---- whitted-recursion ---- */

/* Unpolarised Fresnel reflectance from index n1 into n2; 1 beyond the
 * critical angle. */
static double fresnel(double cos_i, double n1, double n2)
{
    double sin_t = n1 / n2 * sqrt(1.0 - cos_i * cos_i);
    if (sin_t >= 1.0)
        return 1.0;
    double cos_t = sqrt(1.0 - sin_t * sin_t);
    double a = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    double b = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    return 0.5 * (a * a + b * b);
}

/* Green radiance along each of n rays, one sample each, with max_depth
 * set, in the scene fill makes (arg passed on); out[i] is -1 when the
 * set-up fails (reported as `what`). */
static void whitted_trace(tally *t, const rtk_plugin *p, const char *max_depth, void (*fill)(rtk_scene *, const void *),
                          const void *arg, const rtk_ray *rays, int n, double *out, const char *what)
{
    const char *const set[] = {"max_depth", max_depth, NULL};
    for (int i = 0; i < n; i++)
        out[i] = -1.0;
    bench b;
    if (bench_open(t, p, set, what, &b)) {
        if ((b.scene = rtk_scene_new(what, b.needs)))
            fill(b.scene, arg);
        if (bench_ready(t, &b, what))
            for (int i = 0; i < n; i++)
                out[i] = bench_mean(&b, &rays[i], 0, 1, 1, NULL);
    }
    bench_close(&b);
}

/* The point light above a rho = 0.5 floor at (0.3, 2, -0.4), I = 3. */
static const double point_x = 0.3, point_y = 2.0, point_z = -0.4, point_i = 3.0;

static void point_scene(rtk_scene *s, const void *arg)
{
    (void)arg;
    add_quad(s, v3(-5, 0, -5), v3(0, 0, 10), v3(10, 0, 0), add_material(s, diffuse(rho, 0)));
    rtk_punctual_light l = {.type = RTK_LIGHT_POINT, .position = v3(point_x, point_y, point_z),
                            .intensity = rtk_rgb_make((float)point_i, (float)point_i, (float)point_i)};
    rtk_scene_add_punctual(s, &l);
}

/* Lo = rho I cos(theta) / (pi r^2) at the origin, seen from (0, 1, 0). */
static double point_truth(void)
{
    double r2 = point_x * point_x + point_y * point_y + point_z * point_z, cos_t = point_y / sqrt(r2);
    return rho * point_i * cos_t / (M_PI * r2);
}

/* Mirror of reflectance 0.8 at z = 0 facing +z (when *arg), a lit diffuse
 * card at z = 2 in front of it. */
static void mirror_scene(rtk_scene *s, const void *arg)
{
    if (*(const int *)arg) {
        /* A smooth metal of reflectance 0.8 (glTF metallic 1, roughness 0). */
        rtk_material mirror = rtk_material_default();
        mirror.model = RTK_MODEL_METALLIC_ROUGHNESS;
        mirror.metallic = 1.0f;
        mirror.roughness = 0.0f;
        mirror.base_color = rtk_rgb_make(0.8f, 0.8f, 0.8f);
        add_quad(s, v3(-5, -5, 0), v3(10, 0, 0), v3(0, 10, 0), add_material(s, mirror));
    }
    uint32_t card = add_material(s, diffuse(0.6f, 0));
    /* Both windings: lit from either side. */
    add_quad(s, v3(-1, -1, 2), v3(2, 0, 0), v3(0, 2, 0), card);
    add_quad(s, v3(-1, -1, 2), v3(0, 2, 0), v3(2, 0, 0), card);
    rtk_punctual_light l = {.type = RTK_LIGHT_POINT, .position = v3(0.5, 3.0, 1.0), .intensity = rtk_rgb_make(5, 5, 5)};
    rtk_scene_add_punctual(s, &l);
}

/* A glass slab (n = 1.5) between z = -0.1 and 0, a white emitter facing
 * it at z = 2 (when *arg). */
static void slab_scene(rtk_scene *s, const void *arg)
{
    uint32_t g = add_material(s, glass());
    add_quad(s, v3(-50, -50, 0), v3(100, 0, 0), v3(0, 100, 0), g);    /* top, +z */
    add_quad(s, v3(-50, -50, -0.1), v3(0, 100, 0), v3(100, 0, 0), g); /* bottom, -z */
    if (arg && *(const int *)arg)
        add_quad(s, v3(-50, -50, 2), v3(0, 100, 0), v3(100, 0, 0), add_material(s, diffuse(0, 1.0f))); /* -z */
}

/* A glass block between y = -1 and 0 under a white emitter at y = 1. */
static void tir_scene(rtk_scene *s, const void *arg)
{
    (void)arg;
    uint32_t g = add_material(s, glass()), white = add_material(s, diffuse(0, 1.0f));
    add_quad(s, v3(-50, 0, -50), v3(0, 0, 100), v3(100, 0, 0), g);             /* top, +y */
    add_quad(s, v3(-50, -1, -50), v3(100, 0, 0), v3(0, 0, 100), g);            /* bottom, -y */
    add_quad(s, v3(-500, 1, -500), v3(1000, 0, 0), v3(0, 0, 1000), white);     /* -y */
}

/* The ray of the parallel-slab test enters at 30 degrees from (0, 0, 1);
 * a 2 mm emitter sits on its shifted exit line at z = -10. */
static const double slab_theta = 30.0 * M_PI / 180.0;

static void parallel_scene(rtk_scene *s, const void *arg)
{
    (void)arg;
    slab_scene(s, NULL);
    double tt = asin(sin(slab_theta) / 1.5);
    double x = 1.0 * tan(slab_theta) + 0.1 * tan(tt) + 9.9 * tan(slab_theta);
    const double h = 1e-3;
    add_quad(s, v3(x - h, -h, -10.0), v3(2 * h, 0, 0), v3(0, 2 * h, 0), add_material(s, diffuse(0, 1.0f)));
}

/* A glTF file with a Lambertian rho = 0.5 floor quad (metallic 0,
 * roughness 0, KHR_materials_specular specularFactor 0: a plastic of
 * f0 = 0, whose coat reflects (1 - cos)^5, under 1e-7 on this ray and
 * light, and whose base has Oren-Nayar sigma 0) and a KHR_lights_punctual point
 * light on a translated node at the same place as point_scene's light:
 * the loader places it, and the integrator lights the floor by the same
 * law. Written to a temporary directory and removed. */
static void whitted_gltf(tally *t, const rtk_plugin *p)
{
    const char *tmp = getenv("TMPDIR");
    char dir[1024], bin[1100], gltf[1100];
    snprintf(dir, sizeof dir, "%s/rtk-conform-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        check(t, 0, "glTF KHR_lights_punctual: temporary directory %s: %s", dir, strerror(errno));
        return;
    }
    snprintf(bin, sizeof bin, "%s/quad.bin", dir);
    snprintf(gltf, sizeof gltf, "%s/quad.gltf", dir);
    const float pos[12] = {-5, 0, -5, -5, 0, 5, 5, 0, 5, 5, 0, -5};
    const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    int written = 0;
    FILE *f = fopen(bin, "wb");
    if (f) {
        written = fwrite(pos, sizeof pos, 1, f) == 1 && fwrite(idx, sizeof idx, 1, f) == 1;
        written = fclose(f) == 0 && written;
    }
    f = written ? fopen(gltf, "w") : NULL;
    if (f) {
        fputs("{\"asset\": {\"version\": \"2.0\"},\n"
              " \"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_specular\"],\n"
              " \"extensions\": {\"KHR_lights_punctual\": {\"lights\": [\n"
              "   {\"type\": \"point\", \"color\": [1.0, 1.0, 1.0], \"intensity\": 3.0}]}},\n"
              " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1]}],\n"
              " \"nodes\": [{\"mesh\": 0},\n"
              "   {\"translation\": [0.3, 2.0, -0.4], \"extensions\": {\"KHR_lights_punctual\": {\"light\": 0}}}],\n"
              " \"materials\": [{\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.5, 0.5, 0.5, 1.0],\n"
              "   \"metallicFactor\": 0.0, \"roughnessFactor\": 0.0},\n"
              "   \"extensions\": {\"KHR_materials_specular\": {\"specularFactor\": 0.0}}}],\n"
              " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 0}]}],\n"
              " \"buffers\": [{\"uri\": \"quad.bin\", \"byteLength\": 60}],\n"
              " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},\n"
              "   {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 12}],\n"
              " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\",\n"
              "   \"min\": [-5, 0, -5], \"max\": [5, 0, 5]},\n"
              "   {\"bufferView\": 1, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}\n",
              f);
        written = fclose(f) == 0;
    } else {
        written = 0;
    }
    if (!written) {
        check(t, 0, "glTF KHR_lights_punctual: cannot write %s: %s", dir, strerror(errno));
    } else {
        const char *const set[] = {"max_depth", "5", NULL};
        const char *what = "glTF KHR_lights_punctual";
        bench b;
        if (bench_open(t, p, set, what, &b) && rtk_scene_load(gltf, b.needs, &b.scene) != RTK_OK) {
            check(t, 0, "glTF with KHR_lights_punctual loads: %s", rtk_error_message());
        } else if (b.scene) {
            const rtk_punctual_light *l = rtk_scene_punctual(b.scene, 0);
            expect_close(t, "glTF KHR_lights_punctual: one light", rtk_scene_punctual_count(b.scene), 1.0, 0.0);
            if (l)
                expect_close(t, "glTF light: placed by its node", l->position.y, 2.0, 0.0);
            if (l && bench_ready(t, &b, what)) {
                rtk_ray ray = make_ray(v3(0, 1, 0), v3(0, -1, 0));
                expect_close(t, "glTF point light: Lo = rho I cos / (pi r^2)", bench_mean(&b, &ray, 0, 1, 1, NULL),
                             point_truth(), 1e-5);
            }
        }
        bench_close(&b);
    }
    remove(bin);
    remove(gltf);
    rmdir(dir);
}

static void whitted_recursion_profile(tally *t, const rtk_plugin *p)
{
    double got;
    rtk_ray ray = make_ray(v3(0, 1, 0), v3(0, -1, 0));
    whitted_trace(t, p, "5", point_scene, NULL, &ray, 1, &got, "point light");
    expect_close(t, "point light: Lo = rho I cos / (pi r^2)", got, point_truth(), 1e-5);

    /* The mirror shows R x what a camera mirrored through its plane sees
     * in the same scene without the mirror: rays from (x, y, 1) aimed at
     * the mirror and beyond at the card's back. */
    rtk_ray rays[8], mirrored[8];
    for (int k = 0; k < 8; k++) {
        rtk_vec3 org = rtk_vec3_make(0.1f * k - 0.3f, 0.05f * k - 0.2f, 1.0f);
        rtk_vec3 dir = rtk_vec3_normalize(rtk_vec3_make(-0.02f * k, 0.03f, -1.0f));
        rays[k] = make_ray(org, dir);
        mirrored[k] = make_ray(rtk_vec3_make(org.x, org.y, -org.z), rtk_vec3_make(dir.x, dir.y, -dir.z));
    }
    double seen[8], direct[8];
    const int with = 1, without = 0;
    whitted_trace(t, p, "5", mirror_scene, &with, rays, 8, seen, "mirror");
    whitted_trace(t, p, "5", mirror_scene, &without, mirrored, 8, direct, "mirrored view");
    check(t, direct[0] > 0.0, "mirror: the mirrored view is lit: %.9g", direct[0]);
    for (int k = 0; k < 8; k++) {
        char what[128];
        snprintf(what, sizeof what, "mirror shows R x the mirrored camera's view (ray %d)", k);
        expect_close(t, what, seen[k], 0.8 * direct[k], 1e-4);
    }

    /* Normal incidence reflects ((n - 1)/(n + 1))^2 = 0.04 of the emitter
     * behind the camera; one bounce only. */
    const int lit = 1;
    ray = make_ray(v3(0.2, 0.1, 1.0), v3(0, 0, -1));
    whitted_trace(t, p, "1", slab_scene, &lit, &ray, 1, &got, "glass slab");
    expect_close(t, "glass reflects 0.04 at normal incidence", got, 0.04, 1e-5);

    /* From inside the block towards its top face at angle a to the normal:
     * below the critical angle asin(1/1.5) = 41.81 deg the face transmits
     * (1 - F) Le to the emitter, beyond it nothing. */
    const double angles[4] = {30.0, 41.0, 41.9, 60.0};
    rtk_ray up[4];
    double through[4];
    for (int k = 0; k < 4; k++) {
        double a = angles[k] * M_PI / 180.0;
        up[k] = make_ray(v3(0, -0.5, 0), v3(sin(a), cos(a), 0.0));
    }
    whitted_trace(t, p, "1", tir_scene, NULL, up, 4, through, "glass block");
    for (int k = 0; k < 4; k++) {
        double truth = 1.0 - fresnel(cos(angles[k] * M_PI / 180.0), 1.5, 1.0);
        char what[128];
        snprintf(what, sizeof what, "glass at %.1f deg from inside: %s", angles[k],
                 truth == 0.0 ? "total internal reflection" : "transmits 1 - F");
        expect_close(t, what, through[k], truth, 2e-5);
    }

    /* Through a parallel slab the ray leaves parallel to the entering one,
     * shifted sideways: it hits the 2 mm emitter on that exact line and
     * shows (1 - F_in)(1 - F_out) Le. */
    double tt = asin(sin(slab_theta) / 1.5);
    ray = make_ray(v3(0, 0, 1), v3(sin(slab_theta), 0.0, -cos(slab_theta)));
    whitted_trace(t, p, "3", parallel_scene, NULL, &ray, 1, &got, "parallel slab");
    expect_close(t, "slab: the transmitted ray leaves parallel to the entering one", got,
                 (1.0 - fresnel(cos(slab_theta), 1.0, 1.5)) * (1.0 - fresnel(cos(tt), 1.5, 1.0)), 2e-5);

    whitted_gltf(t, p);
}

/* ---- headlight-shading ---- */

/* Renders b's scene from desc, w x h pixels at spp, each sample counted in
 * its own pixel. NULL after reporting a failure. [caller frees] */
static float *bench_render(tally *t, const bench *b, const rtk_camera_desc *desc, uint32_t w, uint32_t h, uint32_t spp,
                           uint32_t threads, const char *what)
{
    rtk_camera cam;
    float *px = NULL;
    rtk_status st = rtk_camera_init(&cam, desc, w, h);
    if (st == RTK_OK) {
        px = rtk_alloc(sizeof(float) * RTK_FILM_CHANNELS * w * h);
        rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
        job.scene = b->scene;
        job.camera = &cam;
        job.integrator = b->f;
        job.integrator_state = b->state;
        job.filter = &rtk_conform_pixel_box;
        job.spp = spp;
        job.seed = 3;
        job.threads = threads;
        st = px ? rtk_render_film(&job, px, NULL) : rtk_error(RTK_ERR_NOMEM, "out of memory for the image");
    }
    if (st != RTK_OK) {
        check(t, 0, "%s: render failed: %s", what, rtk_error_message());
        free(px);
        return NULL;
    }
    return px;
}

/* A 2x2 quad at z = 0 facing +z with Kd = (0.25, 0.5, 0.75), seen from
 * (0, 0, 5) with a 10 degree field: a pixel shows Kd x cos(angle to the
 * axis), averaged over the pixel. */
static void headlight_shading_profile(tally *t, const rtk_plugin *p)
{
    const char *const set[] = {"ambient", "0", NULL};
    const char *what = "headlight quad";
    const double kd[3] = {0.25, 0.5, 0.75};
    bench b;
    if (bench_open(t, p, set, what, &b)) {
        if ((b.scene = rtk_scene_new(what, b.needs))) {
            rtk_material m = rtk_material_default();
            m.base_color = rtk_rgb_make((float)kd[0], (float)kd[1], (float)kd[2]);
            add_quad(b.scene, v3(-1, -1, 0), v3(2, 0, 0), v3(0, 2, 0), add_material(b.scene, m));
        }
        if (bench_ready(t, &b, what)) {
            rtk_camera_desc front = {v3(0, 0, 5), v3(0, 0, 0), v3(0, 1, 0), 10.0f};
            float *px = bench_render(t, &b, &front, 33, 33, 4, 2, what);
            if (px) {
                /* At the centre pixel cos >= cos(atan(tan(5 deg) / 33 x sqrt2)) > 1 - 1e-5. */
                const float *c = px + (size_t)(16 * 33 + 16) * RTK_FILM_CHANNELS;
                int ok = 1;
                for (int k = 0; k < 3; k++)
                    ok = ok && fabs(c[k] - kd[k]) < kd[k] * 1e-5;
                check(t, ok, "headlight: centre pixel equals Kd x cos = Kd: (%.7g, %.7g, %.7g), truth (%g, %g, %g)",
                      c[0], c[1], c[2], kd[0], kd[1], kd[2]);
                /* The corner pixel (0, 0) looks atan(tan(5 deg) sqrt2 32/33) off
                 * the axis; at distance 5 the quad covers it. */
                double ang = atan(tan(5.0 * M_PI / 180.0) * sqrt(2.0) * 32.0 / 33.0);
                check(t, fabs(px[1] - kd[1] * cos(ang)) < kd[1] * 2e-4,
                      "headlight: corner pixel equals Kd x cos(angle): %.7g, truth %.7g", px[1], kd[1] * cos(ang));
                check(t, c[9] > 4.99f && c[9] < 5.01f, "depth AOV of the centre pixel is the distance 5: %.7g", c[9]);
                check(t, fabsf(c[8] - 1.0f) < 1e-6f, "normal AOV of the centre pixel is +z: z = %.9g", c[8]);
            }
            free(px);
            /* From behind the quad still shows (|cos|), not black. The
             * centre pixel of 9 sees within atan(sqrt2 tan(5 deg) / 9) of the axis. */
            rtk_camera_desc back = {v3(0, 0, -5), v3(0, 0, 0), v3(0, 1, 0), 10.0f};
            px = bench_render(t, &b, &back, 9, 9, 1, 1, what);
            if (px) {
                double tol = 1.0 - cos(atan(sqrt(2.0) * tan(5.0 * M_PI / 180.0) / 9.0)) + 1e-6;
                float g = px[(4 * 9 + 4) * RTK_FILM_CHANNELS + 1];
                check(t, fabs(g - kd[1]) <= kd[1] * tol, "headlight: back face gets |cos|: %.7g, truth %g (to %.2g)", g,
                      kd[1], kd[1] * tol);
            }
            free(px);
        }
    }
    bench_close(&b);
}

/* ---- environment-light ---- */

/* The constant environment's radiance (per channel, so a swapped channel shows). */
static const float env_l[3] = {0.6f, 0.9f, 0.3f};

/* Gives s the constant environment env_l. */
static rtk_status constant_sky(rtk_scene *s)
{
    rtk_environment *env = NULL;
    rtk_status st = rtk_environment_constant(rtk_rgb_make(env_l[0], env_l[1], env_l[2]), 1.0f, &env);
    return st == RTK_OK ? rtk_scene_set_environment(s, env) : st;
}

/* A white Lambertian sphere of radius 1 at the origin, 24 x 48 facets,
 * each facing out; convex, so every facet sees its whole hemisphere. */
static void white_sphere(rtk_scene *s)
{
    enum { rows = 24, cols = 48 };
    uint32_t m = add_material(s, diffuse(1.0f, 0.0f));
    uint32_t ids[rows + 1][cols];
    for (int i = 0; i <= rows; i++)
        for (int j = 0; j < cols; j++) {
            double th = M_PI * i / rows, ph = 2.0 * M_PI * j / cols;
            rtk_scene_add_vertex(s, (float)(sin(th) * cos(ph)), (float)cos(th), (float)(sin(th) * sin(ph)), &ids[i][j]);
        }
    for (int i = 0; i < rows; i++)
        for (int j = 0; j < cols; j++) {
            uint32_t a = ids[i][j], b = ids[i][(j + 1) % cols], c = ids[i + 1][j], d = ids[i + 1][(j + 1) % cols];
            /* (b - a) x (c - a) points out for rows going down from +y and columns turning to +z */
            if (i > 0)
                rtk_scene_add_triangle(s, a, b, c, NULL, NULL, m);
            if (i < rows - 1)
                rtk_scene_add_triangle(s, b, d, c, NULL, NULL, m);
        }
}

/* Floor of albedo 1 (y = 0, up) with black occluders; fill one of the
 * ao_* scenes' shapes with the white floor first. */
static void env_plane(rtk_scene *s)
{
    add_quad(s, v3(-big, 0, -big), v3(0, 0, 2 * big), v3(2 * big, 0, 0), add_material(s, diffuse(1.0f, 0.0f)));
}

static void env_wall(rtk_scene *s)
{
    uint32_t black = add_material(s, diffuse(0.0f, 0.0f));
    add_quad(s, v3(-big, 0, -big), v3(0, 0, 2 * big), v3(big, 0, 0), add_material(s, diffuse(1.0f, 0.0f)));
    add_quad(s, v3(0, 0, -big), v3(0, big, 0), v3(0, 0, 2 * big), black);
}

static void env_corner(rtk_scene *s)
{
    uint32_t black = add_material(s, diffuse(0.0f, 0.0f));
    add_quad(s, v3(-big, 0, -big), v3(0, 0, big), v3(big, 0, 0), add_material(s, diffuse(1.0f, 0.0f)));
    add_quad(s, v3(0, 0, -big), v3(0, big, 0), v3(0, 0, big), black);
    add_quad(s, v3(-big, 0, 0), v3(big, 0, 0), v3(0, big, 0), black);
}

static void env_sphere(rtk_scene *s)
{
    white_sphere(s);
}

/* Each channel c of the radiance along ray, over n samples, against
 * truth x env_l[c]: within 5 standard errors of the samples' own
 * variance, or exactly when exact is set. */
static void env_expect(tally *t, const rtk_plugin *p, const char *const *set, const char *label, const char *what,
                       void (*fill)(rtk_scene *), const rtk_ray *ray, double truth, int exact)
{
    bench b;
    if (bench_open(t, p, set, what, &b)) {
        if ((b.scene = rtk_scene_new(what, b.needs))) {
            fill(b.scene);
            if (constant_sky(b.scene) != RTK_OK) {
                rtk_scene_free(b.scene);
                b.scene = NULL;
            }
        }
        if (bench_ready(t, &b, what)) {
            int n = exact ? 16 : 20000;
            for (int c = 0; c < 2; c++) {
                double se = 0.0, mean = bench_mean(&b, ray, 9, n, c, &se), want = truth * env_l[c];
                int ok = exact ? fabs(mean - want) <= 1e-6 * want : fabs(mean - want) <= 5.0 * se + 1e-6 * want;
                check(t, ok, "%s%s [%s channel]: %.6f, truth %.6f (%s %.2g)", what, label, c ? "green" : "red", mean,
                      want, exact ? "to" : "5 SE =", exact ? 1e-6 * want : 5.0 * se);
            }
        }
    }
    bench_close(&b);
}

/* A constant environment L: a ray that leaves the scene sees L; a white
 * Lambertian floor shows L x the fraction of its cosine-weighted
 * hemisphere that sees the sky past black occluders (the AO answers); a
 * white sphere shows L. Run with the plugin's defaults. */
static void environment_light_profile(tally *t, const rtk_plugin *p)
{
    const char *const none[] = {NULL};
    rtk_ray miss = make_ray(v3(0, 1, 0), rtk_vec3_normalize(v3(0.3, 0.5, -0.8)));
    env_expect(t, p, none, "", "a ray that leaves the scene sees L", env_plane, &miss, 1.0, 1);
    rtk_ray down = make_ray(v3(0.3, 0.01, -0.2), v3(0, -1, 0));
    env_expect(t, p, none, "", "white floor under the sky shows L", env_plane, &down, 1.0, 0);
    rtk_ray wall = make_ray(v3(-1e-3, 0.01, 0), v3(0, -1, 0));
    env_expect(t, p, none, "", "white floor at the foot of a black wall shows L / 2", env_wall, &wall, 0.5, 0);
    rtk_ray corner = make_ray(v3(-1e-3, 0.01, -1e-3), v3(0, -1, 0));
    env_expect(t, p, none, "", "white floor in a corner of black walls shows L / 4", env_corner, &corner, 0.25, 0);
    rtk_ray top = make_ray(v3(0.05, 3, 0.02), v3(0, -1, 0));
    env_expect(t, p, none, "", "white sphere seen from above shows L", env_sphere, &top, 1.0, 0);
    rtk_ray side = make_ray(v3(3, 0.1, 0.2), v3(-1, 0, 0));
    env_expect(t, p, none, "", "white sphere seen from the side shows L", env_sphere, &side, 1.0, 0);
}

/* ---- path-tracing ---- */

/* A closed box, 4 on a side, every inner face Lambertian with albedo
 * furnace_rho and emitting furnace_le: the radiance after at most k
 * bounces is Le (1 + rho + ... + rho^k), Le / (1 - rho) in the limit. */
static const float furnace_rho = 0.5f, furnace_le = 1.0f;

static void closed_furnace(rtk_scene *s)
{
    uint32_t wall = add_material(s, diffuse(furnace_rho, furnace_le));
    add_quad(s, v3(-2, -2, -2), v3(0, 0, 4), v3(4, 0, 0), wall);
    add_quad(s, v3(-2, 2, -2), v3(4, 0, 0), v3(0, 0, 4), wall);
    add_quad(s, v3(-2, -2, -2), v3(4, 0, 0), v3(0, 4, 0), wall);
    add_quad(s, v3(-2, -2, 2), v3(0, 4, 0), v3(4, 0, 0), wall);
    add_quad(s, v3(-2, -2, -2), v3(0, 4, 0), v3(0, 0, 4), wall);
    add_quad(s, v3(2, -2, -2), v3(0, 0, 4), v3(0, 4, 0), wall);
}

/* Global illumination with max_depth bounces: the closed furnace at 0
 * (exactly Le), 1, 2, 3 and 1024 bounces; the square light's direct light
 * at max_depth = 1; a white sphere under a constant sky shows L at 1, 3
 * and 1024 bounces. */
static void path_tracing_profile(tally *t, const rtk_plugin *p)
{
    static const char *const depths[] = {"0", "1", "2", "3", "1024"};
    rtk_ray into_wall = make_ray(v3(0.1, -0.3, 0.2), rtk_vec3_normalize(v3(0.4, -1, 0.25)));
    for (size_t k = 0; k < RTK_COUNTOF(depths); k++) {
        const char *const set[] = {"max_depth", depths[k], NULL};
        char what[128];
        int d = atoi(depths[k]);
        double truth = furnace_le * (1.0 - pow(furnace_rho, d + 1)) / (1.0 - furnace_rho);
        snprintf(what, sizeof what, "closed furnace (rho %.2g, Le %.2g) [max_depth=%s]", (double)furnace_rho,
                 (double)furnace_le, depths[k]);
        bench b;
        if (bench_open(t, p, set, what, &b)) {
            if ((b.scene = rtk_scene_new(what, b.needs)))
                closed_furnace(b.scene);
            if (bench_ready(t, &b, what)) {
                int n = d == 0 ? 16 : 20000;
                double se = 0.0, mean = bench_mean(&b, &into_wall, 3, n, 1, &se);
                int ok = d == 0 ? mean == truth : fabs(mean - truth) <= 5.0 * se;
                check(t, ok, "%s: Le (1 - rho^(k+1)) / (1 - rho): %.6f, truth %.6f (%s %.2g)", what, mean, truth,
                      d == 0 ? "exactly, to" : "5 SE =", d == 0 ? 0.0 : 5.0 * se);
            }
        }
        bench_close(&b);
    }
    {
        const char *const set[] = {"max_depth", "1", NULL};
        const rtk_vec3 up = v3(0, 1, 0);
        double A = (double)square_a / light_h, q = A / sqrt(1.0 + A * A);
        double F = 4.0 / M_PI * q * atan(q);
        bench b;
        const char *what = "square light, direct only [max_depth=1]: Lo = rho L F";
        if (bench_open(t, p, set, what, &b)) {
            if ((b.scene = rtk_scene_new(what, b.needs)))
                square_light(b.scene);
            if (bench_ready(t, &b, what)) {
                rtk_ray ray = make_ray(rtk_vec3_scale(up, 0.01f), rtk_vec3_neg(up));
                double se = 0.0, mean = bench_mean(&b, &ray, 5, 20000, 1, &se), truth = rho * light_l * F;
                check(t, fabs(mean - truth) <= 5.0 * se, "%s: %.6f, truth %.6f (5 SE = %.2g)", what, mean, truth,
                      5.0 * se);
            }
        }
        bench_close(&b);
    }
    static const char *const sky_depths[] = {"1", "3", "1024"};
    rtk_ray side = make_ray(v3(3, 0.1, 0.2), v3(-1, 0, 0));
    for (size_t k = 0; k < RTK_COUNTOF(sky_depths); k++) {
        const char *const set[] = {"max_depth", sky_depths[k], NULL};
        char label[64];
        snprintf(label, sizeof label, " [max_depth=%s]", sky_depths[k]);
        env_expect(t, p, set, label, "white sphere under a constant sky shows L", env_sphere, &side, 1.0, 0);
    }
}

/* ---- profiles ---- */

/* A parameter a profile sets. */
typedef struct profile_param {
    const char *name;
    rtk_param_type type;
} profile_param;

typedef struct profile {
    const char *name;        /* first member: rtk_suggest reads the names through it */
    const char *abi31_name;  /* what a descriptor of ABI 3.1 calls it ("": newer than 3.1) */
    profile_param params[2]; /* name NULL past the last */
    void (*run)(tally *t, const rtk_plugin *p);
} profile;

static const profile profiles[] = {
    {"ambient-occlusion", "ao", {{"rays", RTK_PARAM_INT}, {"distance", RTK_PARAM_FLOAT}}, ambient_occlusion_profile},
    {"direct-area-light", "arealight", {{"light_samples", RTK_PARAM_INT}, {"mis", RTK_PARAM_BOOL}},
     direct_area_light_profile},
    {"whitted-recursion", "whitted", {{"max_depth", RTK_PARAM_INT}, {NULL, 0}}, whitted_recursion_profile},
    {"headlight-shading", "headlight", {{"ambient", RTK_PARAM_FLOAT}, {NULL, 0}}, headlight_shading_profile},
    {"environment-light", "", {{NULL, 0}, {NULL, 0}}, environment_light_profile},
    {"path-tracing", "", {{"max_depth", RTK_PARAM_INT}, {NULL, 0}}, path_tracing_profile},
};

/* The longest profile name an item is compared with; longer items are unknown. */
#define PROFILE_NAME_MAX 63

/* "ambient-occlusion, direct-area-light, ..." for messages. */
static void known_profiles(char *buf, size_t cap)
{
    size_t used = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < RTK_COUNTOF(profiles) && used < cap; i++)
        used += (size_t)snprintf(buf + used, cap - used, "%s%s", i ? ", " : "", profiles[i].name);
}

/* The profile named word: by its name, or by its 3.1 name when p's
 * descriptor is of ABI 3.1. NULL when none. */
static const profile *profile_find(const rtk_plugin *p, const char *word)
{
    for (size_t i = 0; i < RTK_COUNTOF(profiles); i++)
        if (strcmp(profiles[i].name, word) == 0 || (p->abi_minor <= 1 && strcmp(profiles[i].abi31_name, word) == 0))
            return &profiles[i];
    return NULL;
}

/* Parses p's declared list (docs/conform.md) into run[] (room for every
 * profile), one FAIL line per item that is empty, unknown or repeated.
 * Returns the number of profiles, or 0 after a FAIL. */
static size_t profiles_parse(tally *t, const rtk_plugin *p, const char *list, const profile **run)
{
    char known[256];
    known_profiles(known, sizeof known);
    size_t n = 0;
    int bad = 0;
    for (const char *item = list;; item++) {
        size_t len = strcspn(item, ",");
        const char *begin = item, *end = item + len;
        while (begin < end && *begin == ' ')
            begin++;
        while (end > begin && end[-1] == ' ')
            end--;
        char word[PROFILE_NAME_MAX + 1];
        int wlen = (int)(end - begin);
        snprintf(word, sizeof word, "%.*s", wlen, begin);
        const profile *pr = wlen <= PROFILE_NAME_MAX ? profile_find(p, word) : NULL;
        if (wlen == 0) {
            bad = 1;
            check(t, 0, "conform profiles of integrator '%s' are well-formed: conform = \"%.200s\" has an empty item "
                  "(separate profile names by one comma; known: %s)", p->name, list, known);
        } else if (!pr) {
            bad = 1;
            const char *near = rtk_suggest(word, &profiles[0].name, RTK_COUNTOF(profiles), sizeof profiles[0]);
            const profile *renamed = NULL;
            for (size_t i = 0; i < RTK_COUNTOF(profiles); i++)
                if (strcmp(profiles[i].abi31_name, word) == 0)
                    renamed = &profiles[i];
            if (renamed)
                check(t, 0, "conform profile \"%s\" is known: integrator '%s' declares a profile this rtk does not "
                      "have; \"%s\" is the ABI 3.1 name of \"%s\", which a 3.%u descriptor must use (known: %s; "
                      "docs/conform.md)", word, p->name, word, renamed->name, (unsigned)p->abi_minor, known);
            else if (near)
                check(t, 0, "conform profile \"%.64s\" is known: integrator '%s' declares a profile this rtk does not "
                      "have; did you mean \"%s\"? (known: %s; docs/conform.md)", word, p->name, near, known);
            else
                check(t, 0, "conform profile \"%.64s\" is known: integrator '%s' declares a profile this rtk does not "
                      "have (known: %s; docs/conform.md)", word, p->name, known);
        } else {
            int repeated = 0;
            for (size_t i = 0; i < n; i++)
                repeated |= run[i] == pr;
            if (repeated) {
                bad = 1;
                check(t, 0, "conform profile \"%s\" is declared once: integrator '%s' declares conform = \"%.200s\", "
                      "which lists \"%s\" twice", pr->name, p->name, list, pr->name);
            } else {
                run[n++] = pr;
            }
        }
        item += len;
        if (!*item)
            break;
    }
    return bad ? 0 : n;
}

/* 1 when p declares each parameter pr sets, with its type; else a FAIL
 * line per parameter that is missing or of another type. */
static int profile_params_match(tally *t, const rtk_plugin *p, const profile *pr)
{
    int found = 1;
    for (int k = 0; k < 2 && pr->params[k].name; k++) {
        const profile_param *want = &pr->params[k];
        const rtk_param_desc *d = NULL;
        for (uint32_t i = 0; i < p->param_count; i++)
            if (strcmp(p->params[i].name, want->name) == 0)
                d = &p->params[i];
        if (!d || d->type != want->type) {
            found = 0;
            if (d)
                check(t, 0, "profile \"%s\": integrator '%s' declares the profile, which sets the %s parameter '%s', "
                      "but the plugin's '%s' is of type %s", pr->name, p->name, rtk_param_type_name(want->type),
                      want->name, want->name, rtk_param_type_name(d->type));
            else
                check(t, 0, "profile \"%s\": integrator '%s' declares the profile, which sets the %s parameter '%s', "
                      "but the plugin has no parameter '%s'", pr->name, p->name, rtk_param_type_name(want->type),
                      want->name, want->name);
        }
    }
    return found;
}

void rtk_conform_profile(const rtk_plugin *p, FILE *out, int *passed, int *failed)
{
    tally t = {out, passed, failed};
    /* A descriptor built before 3.1 ends before conform. */
    const char *list = p->size >= offsetof(rtk_plugin, conform) + sizeof p->conform ? p->conform : NULL;
    if (!list) {
        fprintf(out, "# no conformance profile declared: generic checks only\n");
        return;
    }
    const profile *run[RTK_COUNTOF(profiles)];
    size_t n = profiles_parse(&t, p, list, run);
    for (size_t i = 0; i < n; i++) {
        if (!profile_params_match(&t, p, run[i]))
            continue;
        check(&t, 1, "profile \"%s\": the plugin has the parameters the profile sets", run[i]->name);
        fprintf(out, "# profile %s: exact tests\n", run[i]->name);
        run[i]->run(&t, p);
    }
}
