/* The light service (include/rtk/lights.h, kernel/scene/lights.c,
 * environment.c) against answers computed here from the header's
 * formulas, never from the kernel's tables:
 * - environment map sampling: chi-square goodness of fit over bins in
 *   (phi, cos theta) of the sampled world directions, expected counts from
 *   the pixels' luminance x sin(theta) integrated exactly per bin; a
 *   constant environment against the uniform sphere the same way;
 * - the environment pdf integrates to 1 over the sphere, equals the
 *   header's closed form, and rtk_incident_light_pdf returns the pdf of
 *   every sample (environment and area) for the direction it took;
 * - the choice between area, point, spot, directional and environment
 *   lights follows the header's power table (chi-square), an emission
 *   texture counting with its mean;
 * - a constant environment L over a white Lambertian plane gives L through
 *   the shipped arealight (light sampling alone and with MIS), within 5
 *   standard errors of the samples' mean;
 * - importance and uniform sampling of a non-constant map give the same
 *   irradiance within noise, and both the quadrature of the map;
 * - the mapping and rotation put pixels where the header says.
 * Chi-square p-values use the Wilson-Hilferty normal approximation (good
 * to a few percent of p at these degrees of freedom); the threshold is
 * Sidak-corrected for a family-wise significance of 0.01 over the file's
 * NCHI2 tests. Random numbers come from one fixed PCG32 stream. */
#include "scene/scene.h"
#include "accel/accel.h"
#include "render/render.h"
#include "image/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../../check.h"

#define PI 3.14159265358979323846
#define NCHI2 4
/* Chi-square bins over the sphere: NPHI in phi, NCOS in cos theta. */
#define NPHI 32
#define NCOS 16
#define ALPHA_FAMILY 0.01

static char tmpdir[256];
static const rtk_plugin *median;
static const rtk_plugin *arealight;

static rtk_pcg32 rng;

static float uniform(void)
{
    return rtk_pcg32_float(&rng);
}

static rtk_vec2 uniform2(void)
{
    rtk_vec2 u;
    u.x = uniform();
    u.y = uniform();
    return u;
}

static double lum(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

/* p-value of chi2 with dof degrees of freedom (Wilson-Hilferty). */
static double chi2_p(double chi2, int dof)
{
    double k = dof, z = (cbrt(chi2 / k) - (1.0 - 2.0 / (9.0 * k))) / sqrt(2.0 / (9.0 * k));
    return 0.5 * erfc(z / sqrt(2.0));
}

/* Chi-square of observed counts against probabilities prob over n cells
 * (cells expecting fewer than 5 pooled into one); checks the p-value
 * against the Sidak threshold and that no sample fell where prob is 0. */
static void chi2_check(const char *label, const long *observed, const double *prob, int n, long total)
{
    double threshold = 1.0 - pow(1.0 - ALPHA_FAMILY, 1.0 / NCHI2);
    double chi2 = 0.0, pool_e = 0.0, pool_o = 0.0;
    int cells = 0, pooled = 0;
    long impossible = 0;
    for (int i = 0; i < n; i++) {
        double e = prob[i] * (double)total;
        if (prob[i] <= 0.0) {
            impossible += observed[i];
            continue;
        }
        if (e < 5.0) {
            pool_e += e, pool_o += (double)observed[i];
            pooled++;
            continue;
        }
        chi2 += ((double)observed[i] - e) * ((double)observed[i] - e) / e;
        cells++;
    }
    if (pool_e > 0.0) {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        cells++;
    }
    int dof = cells - 1;
    double p = dof > 0 ? chi2_p(chi2, dof) : 0.0;
    check(p >= threshold && impossible == 0,
          "%s: chi-square over %ld samples, %d cells (%d pooled), chi2 %.1f, dof %d, p %.3g >= %.3g (Sidak); %ld "
          "samples where the pdf is 0",
          label, total, cells, pooled, chi2, dof, p, threshold, impossible);
}

/* A material of albedo and emission le x texture emission_tex (-1: none). */
static uint32_t add_material(rtk_scene *s, rtk_rgb albedo, rtk_rgb le, int emission_tex)
{
    rtk_material m = rtk_material_default();
    m.base_color = albedo, m.emission = le, m.emission_tex = emission_tex;
    uint32_t id = RTK_INVALID_ID;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

/* The parallelogram o, o + e1, o + e1 + e2, o + e2 of material mat, uv
 * (0, 0) to (1, 1); its front side is e1 x e2. */
static void add_rect(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t mat)
{
    uint32_t v[4];
    const rtk_vec3 corner[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, corner[k].x, corner[k].y, corner[k].z, &v[k]);
    const float uv0[6] = {0, 0, 1, 0, 1, 1}, uv1[6] = {0, 0, 1, 1, 0, 1};
    rtk_scene_add_triangle(s, v[0], v[1], v[2], NULL, uv0, mat);
    rtk_scene_add_triangle(s, v[0], v[2], v[3], NULL, uv1, mat);
}

/* The square y = 0, |x|, |z| <= half, facing +y, white. */
static void add_floor(rtk_scene *s, float half)
{
    add_rect(s, rtk_vec3_make(-half, 0.0f, -half), rtk_vec3_make(0.0f, 0.0f, 2.0f * half),
             rtk_vec3_make(2.0f * half, 0.0f, 0.0f), add_material(s, rtk_rgb_make(1, 1, 1), rtk_rgb_make(0, 0, 0), -1));
}

/* A finished, built scene holding a floor of half-size half. */
static rtk_scene *floor_scene(float half)
{
    rtk_scene *s = rtk_scene_new("lights-test", RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS);
    add_floor(s, half);
    rtk_params *ap = rtk_params_defaults(median);
    rtk_status st = rtk_scene_finish(s);
    if (st == RTK_OK)
        st = rtk_bvh_build(s, median, ap, 1);
    rtk_params_destroy(ap);
    check(st == RTK_OK, "floor scene built%s%s", st ? ": " : "", st ? rtk_error_message() : "");
    return s;
}

/* A render context on scene for direct calls of li. */
static void ctx_init(rtk_ctx *ctx, const rtk_scene *scene, uint64_t seed)
{
    memset(ctx, 0, sizeof *ctx);
    ctx->scene = scene;
    ctx->gen.seed = seed;
}

/* The test's environment image: W x H RGB. */
#define W 32
#define H 16
static float image[W * H * 3];

/* A gradient with a bright pixel and a black bottom row. */
static void fill_image(void)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float *p = image + 3 * (y * W + x);
            p[0] = 0.2f + 0.8f * (float)x / W;
            p[1] = 0.1f + 0.5f * (float)y / H;
            p[2] = 0.3f;
            if (x == 20 && y == 5)
                p[0] = 60.0f, p[1] = 40.0f, p[2] = 20.0f;
            if (y == H - 1)
                p[0] = p[1] = p[2] = 0.0f;
        }
}

/* Writes image to name in the temporary folder; returns the path. */
static const char *write_exr(const char *name, int w, int h, const float *rgb)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    static const char *const names[] = {"R", "G", "B"};
    rtk_status st = rtk_image_write(path, w, h, 3, names, rgb, 0);
    check(st == RTK_OK, "%s written%s%s", name, st ? ": " : "", st ? rtk_error_message() : "");
    return path;
}

/* The world direction's phi (atan2(x, -z), as the header's u) and cos theta. */
static void angles(rtk_vec3 d, double *phi, double *cos_theta)
{
    double len = sqrt((double)d.x * d.x + (double)d.y * d.y + (double)d.z * d.z);
    *phi = atan2(d.x, -d.z);
    *cos_theta = d.y / len;
}

/* A light sample for the origin on a floor facing +y, from fresh numbers. */
static int sample_at_origin(const rtk_scene *s, rtk_light_incident *li)
{
    return rtk_sample_incident_light(s, rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 1, 0), uniform(), uniform2(), li);
}

/* The (phi, cos theta) bin of direction d: NPHI x NCOS over the sphere. */
static int bin_of(rtk_vec3 d)
{
    double phi, ct;
    angles(d, &phi, &ct);
    int pb = (int)((phi + PI) / (2.0 * PI) * NPHI), cb = (int)((ct + 1.0) * 0.5 * NCOS);
    pb = pb < 0 ? 0 : pb >= NPHI ? NPHI - 1 : pb;
    cb = cb < 0 ? 0 : cb >= NCOS ? NCOS - 1 : cb;
    return cb * NPHI + pb;
}

/* Discrete probability of each pixel under the header's sampling rule:
 * luminance x sin(theta at the row's centre), normalised. */
static void pixel_probabilities(double *prob)
{
    double sum = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const float *p = image + 3 * (y * W + x);
            prob[y * W + x] = lum(p[0], p[1], p[2]) * sin(PI * (y + 0.5) / H);
            sum += prob[y * W + x];
        }
    for (int i = 0; i < W * H; i++)
        prob[i] /= sum;
}

/* The header's pdf of world direction d for the image turned by rot degrees. */
static double reference_pdf(const double *prob, double rot, rtk_vec3 d)
{
    double phi, ct;
    angles(d, &phi, &ct);
    double pm = phi + rot * PI / 180.0; /* world phi = map phi - rotation */
    double u = 0.5 + pm / (2.0 * PI);
    u -= floor(u);
    double theta = acos(fmax(-1.0, fmin(1.0, ct)));
    int x = (int)(u * W), y = (int)(theta / PI * H);
    x = x < W ? x : W - 1, y = y < H ? y : H - 1;
    /* pdf_uv = prob x W H; solid angle: / (2 pi^2 sin theta). */
    return prob[y * W + x] * W * H / (2.0 * PI * PI * sin(theta));
}

#define NSAMPLES 1000000L

/* Sampling of the map (turned 45 degrees, four pixel columns, so that the
 * phi bins stay aligned with pixel columns) against its pdf. */
static void test_map_sampling(void)
{
    fill_image();
    const char *path = write_exr("map.exr", W, H, image);
    const double rot = 45.0;
    rtk_environment *env = NULL;
    rtk_status st = rtk_environment_load(path, 2.0f, (float)rot, &env);
    check(st == RTK_OK, "environment map loads%s%s", st ? ": " : "", st ? rtk_error_message() : "");
    if (st != RTK_OK)
        return;
    rtk_scene *s = floor_scene(1.0f);
    rtk_scene_set_environment(s, env);
    double prob[W * H];
    pixel_probabilities(prob);

    /* Expected probability per (phi, cos theta) bin: a pixel is sampled
     * uniformly in (phi, theta), so its share of a bin is its theta
     * overlap with the bin over its own theta extent. */
    static double expected[NPHI * NCOS];
    memset(expected, 0, sizeof expected);
    int shift = (int)(rot / 360.0 * W + 0.5);
    for (int y = 0; y < H; y++) {
        double t0 = PI * y / H, t1 = PI * (y + 1) / H;
        for (int b = 0; b < NCOS; b++) {
            double c0 = -1.0 + 2.0 * b / NCOS, c1 = -1.0 + 2.0 * (b + 1) / NCOS;
            double lo = fmax(t0, acos(c1)), hi = fmin(t1, acos(c0));
            if (hi <= lo)
                continue;
            for (int x = 0; x < W; x++) {
                int phi_bin = ((x - shift) % W + W) % W * NPHI / W;
                expected[b * NPHI + phi_bin] += prob[y * W + x] * (hi - lo) / (t1 - t0);
            }
        }
    }
    static long observed[NPHI * NCOS];
    memset(observed, 0, sizeof observed);
    long failed = 0, pdf_mismatch = 0, lookup_mismatch = 0;
    double worst = 0.0;
    rtk_vec3 p = rtk_vec3_make(0, 0, 0);
    for (long i = 0; i < NSAMPLES; i++) {
        rtk_light_incident li;
        if (!sample_at_origin(s, &li)) {
            failed++;
            continue;
        }
        observed[bin_of(li.wi)]++;
        if (i < 20000) {
            rtk_ray r = {p, 0.0f, li.wi, INFINITY};
            double back = rtk_incident_light_pdf(s, p, &r, NULL), ref = reference_pdf(prob, rot, li.wi);
            double e = fabs(ref / li.pdf - 1.0);
            rtk_rgb L = rtk_scene_environment(s, li.wi);
            worst = fmax(worst, e);
            if (back != li.pdf || L.r != li.li.r || L.g != li.li.g || L.b != li.li.b || li.delta || !isinf(li.dist))
                lookup_mismatch++;
            if (e > 1e-3)
                pdf_mismatch++;
        }
    }
    check(failed <= NSAMPLES / 10000, "map: samples fail only where float rounding carries them over a pixel edge "
                                      "into the black row (%ld of %ld, at most 1e-4)", failed, NSAMPLES);
    chi2_check("map turned 45 degrees, 32 x 16 bins in (phi, cos theta)", observed, expected, NPHI * NCOS,
               NSAMPLES - failed);
    check(lookup_mismatch == 0, "map: rtk_incident_light_pdf of a miss along the sample and rtk_scene_environment "
                                "there equal the sample's pdf and radiance exactly (%ld of 20000 differ)",
          lookup_mismatch);
    check(pdf_mismatch <= 20, "map: the header's closed form (computed here in double) equals the sample's pdf "
                              "within 1e-3 (%ld of 20000 off, at pixel edges; worst %.2g)",
          pdf_mismatch, worst);

    /* The pdf integrates to 1: pdf sin theta is constant within pixels,
     * so the midpoints of a grid 8 times finer than the image are exact. */
    double integral = 0.0;
    const int nu = 8 * W, nt = 8 * H;
    for (int j = 0; j < nt; j++) {
        double theta = PI * (j + 0.5) / nt;
        for (int i = 0; i < nu; i++) {
            double phi = 2.0 * PI * (i + 0.5) / nu - PI;
            rtk_vec3 d = rtk_vec3_make((float)(sin(theta) * sin(phi)), (float)cos(theta),
                                       (float)(-sin(theta) * cos(phi)));
            rtk_ray r = {p, 0.0f, d, INFINITY};
            integral += rtk_incident_light_pdf(s, p, &r, NULL) * sin(theta) * (PI / nt) * (2.0 * PI / nu);
        }
    }
    check(fabs(integral - 1.0) < 1e-4, "map: the pdf integrates to %.6f over the sphere (1 within 1e-4)", integral);

    /* Irradiance on the floor's normal and on a tilted one: importance
     * sampling, uniform sphere sampling and quadrature agree. */
    const rtk_vec3 normals[2] = {{0.0f, 1.0f, 0.0f}, {0.6f, 0.0f, 0.8f}};
    for (int k = 0; k < 2; k++) {
        rtk_vec3 n = normals[k];
        const long m = 400000;
        double si = 0.0, si2 = 0.0, su = 0.0, su2 = 0.0;
        for (long i = 0; i < m; i++) {
            rtk_light_incident li;
            double x = 0.0;
            if (rtk_sample_incident_light(s, p, n, uniform(), uniform2(), &li))
                x = lum(li.li.r, li.li.g, li.li.b) * fmax(0.0, rtk_vec3_dot(n, li.wi)) / li.pdf;
            si += x, si2 += x * x;
            float z = 1.0f - 2.0f * uniform(), r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), ph = 2.0f * (float)PI * uniform();
            rtk_vec3 d = rtk_vec3_make(r * cosf(ph), z, r * sinf(ph));
            rtk_rgb L = rtk_scene_environment(s, d);
            double y = lum(L.r, L.g, L.b) * fmax(0.0, rtk_vec3_dot(n, d)) * 4.0 * PI;
            su += y, su2 += y * y;
        }
        double mi = si / m, mu = su / m;
        double sei = sqrt(fmax(0.0, si2 / m - mi * mi) / m), seu = sqrt(fmax(0.0, su2 / m - mu * mu) / m);
        double quad = 0.0;
        for (int j = 0; j < nt; j++) {
            double theta = PI * (j + 0.5) / nt;
            for (int i = 0; i < nu; i++) {
                double phi = 2.0 * PI * (i + 0.5) / nu - PI;
                rtk_vec3 d = rtk_vec3_make((float)(sin(theta) * sin(phi)), (float)cos(theta),
                                           (float)(-sin(theta) * cos(phi)));
                rtk_rgb L = rtk_scene_environment(s, d);
                quad += lum(L.r, L.g, L.b) * fmax(0.0, rtk_vec3_dot(n, d)) * sin(theta) * (PI / nt) * (2.0 * PI / nu);
            }
        }
        double tol = 5.0 * sqrt(sei * sei + seu * seu);
        check(fabs(mi - mu) <= tol && fabs(mi - quad) <= 5.0 * sei + 2e-3 * quad &&
                  fabs(mu - quad) <= 5.0 * seu + 2e-3 * quad,
              "map: irradiance on normal [%g, %g, %g]: importance %.5g (SE %.2g), uniform %.5g (SE %.2g), quadrature "
              "%.5g; |importance - uniform| %.3g <= %.3g; importance's SE is %.1fx smaller",
              n.x, n.y, n.z, mi, sei, mu, seu, quad, fabs(mi - mu), tol, seu / sei);
    }
    rtk_scene_free(s);
}

/* A constant environment is sampled uniformly over the sphere. */
static void test_constant_sampling(void)
{
    rtk_scene *s = floor_scene(1.0f);
    rtk_environment *env = NULL;
    rtk_environment_constant(rtk_rgb_make(0.5f, 1.0f, 2.0f), 3.0f, &env);
    rtk_scene_set_environment(s, env);
    static long observed[NPHI * NCOS];
    static double expected[NPHI * NCOS];
    memset(observed, 0, sizeof observed);
    for (int i = 0; i < NPHI * NCOS; i++)
        expected[i] = 1.0 / (NPHI * NCOS);
    long bad = 0;
    const long n = 500000;
    rtk_vec3 p = rtk_vec3_make(0, 0, 0);
    for (long i = 0; i < n; i++) {
        rtk_light_incident li;
        if (!sample_at_origin(s, &li)) {
            bad++;
            continue;
        }
        rtk_ray r = {p, 0.0f, li.wi, INFINITY};
        if (fabs(li.pdf * 4.0 * PI - 1.0) > 1e-6 || fabs(rtk_incident_light_pdf(s, p, &r, NULL) * 4.0 * PI - 1.0) > 1e-6 ||
            li.li.r != 1.5f || li.li.g != 3.0f || li.li.b != 6.0f)
            bad++;
        observed[bin_of(li.wi)]++;
    }
    check(bad == 0, "constant environment: pdf 1 / (4 pi) from the sample and from rtk_incident_light_pdf, radiance "
                    "colour x strength (%ld samples off)", bad);
    chi2_check("constant environment, uniform over the sphere", observed, expected, NPHI * NCOS, n);
    rtk_scene_free(s);
}

/* Every kind of light at once: choice by power, each sample's values, and
 * rtk_incident_light_pdf of the area and environment samples. */
static void test_choice(void)
{
    rtk_scene *s = rtk_scene_new("lights-choice", RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS);
    add_floor(s, 1.0f);
    const float le = 4.0f; /* a 0.5 x 0.5 light at y = 1 facing down */
    add_rect(s, rtk_vec3_make(-0.25f, 1.0f, -0.25f), rtk_vec3_make(0.5f, 0.0f, 0.0f), rtk_vec3_make(0.0f, 0.0f, 0.5f),
             add_material(s, rtk_rgb_make(0, 0, 0), rtk_rgb_make(le, le, le), -1));
    rtk_punctual_light point = {.type = RTK_LIGHT_POINT, .position = {0.5f, 0.8f, 0.0f}, .intensity = {1, 1, 1}};
    rtk_punctual_light spot = {.type = RTK_LIGHT_SPOT, .position = {-0.5f, 0.9f, 0.0f}, .direction = {0, -1, 0},
                               .intensity = {2, 2, 2}, .cos_inner = (float)cos(30.0 * PI / 180.0),
                               .cos_outer = (float)cos(45.0 * PI / 180.0)};
    rtk_punctual_light sun = {.type = RTK_LIGHT_DIRECTIONAL, .direction = {0, -1, 0}, .intensity = {0.5f, 0.5f, 0.5f}};
    rtk_scene_add_punctual(s, &point);
    rtk_scene_add_punctual(s, &spot);
    rtk_scene_add_punctual(s, &sun);
    rtk_params *ap = rtk_params_defaults(median);
    rtk_status st = rtk_scene_finish(s);
    if (st == RTK_OK)
        st = rtk_bvh_build(s, median, ap, 1);
    rtk_params_destroy(ap);
    rtk_environment *env = NULL;
    if (st == RTK_OK)
        st = rtk_environment_constant(rtk_rgb_make(0.3f, 0.3f, 0.3f), 1.0f, &env);
    if (st == RTK_OK)
        st = rtk_scene_set_environment(s, env);
    check(st == RTK_OK, "scene with every kind of light%s%s", st ? ": " : "", st ? rtk_error_message() : "");
    if (st != RTK_OK) {
        rtk_scene_free(s);
        return;
    }
    /* Powers by the header's table; R = half the bounds' diagonal
     * (x, z in [-1, 1], y in [0, 1]). */
    double r = 0.5 * sqrt(4.0 + 1.0 + 4.0);
    double power[5] = {PI * 0.25 * le, 4.0 * PI * 1.0,
                       2.0 * PI * 2.0 * (1.0 - 0.5 * ((double)spot.cos_inner + spot.cos_outer)), PI * r * r * 0.5,
                       PI * r * r * 4.0 * PI * 0.3};
    double total = power[0] + power[1] + power[2] + power[3] + power[4], prob[5];
    for (int i = 0; i < 5; i++)
        prob[i] = power[i] / total;
    long observed[5] = {0};
    long failed = 0, wrong = 0, pdf_off = 0, area_seen = 0;
    const long n = 200000;
    rtk_vec3 p = rtk_vec3_make(0, 0, 0), ng = rtk_vec3_make(0, 1, 0);
    rtk_ctx ctx;
    ctx_init(&ctx, s, 5);
    for (long i = 0; i < n; i++) {
        rtk_light_incident li;
        if (!sample_at_origin(s, &li)) {
            failed++;
            continue;
        }
        int kind = !li.delta ? (isinf(li.dist) ? 4 : 0)
                   : isinf(li.dist) ? 3
                   : fabsf(li.dist - rtk_vec3_length(point.position)) < 1e-5f ? 1
                                                                             : 2;
        observed[kind]++;
        float d2 = kind == 1 ? rtk_vec3_dot(point.position, point.position) : rtk_vec3_dot(spot.position, spot.position);
        float c = kind == 2 ? -rtk_vec3_dot(li.wi, spot.direction) : 1.0f;
        float t = (c - spot.cos_outer) / (spot.cos_inner - spot.cos_outer);
        float fall = c >= spot.cos_inner ? 1.0f : t * t * (3.0f - 2.0f * t);
        double want_li = kind == 0 ? le : kind == 1 ? 1.0 / d2 : kind == 2 ? 2.0 * fall / d2 : kind == 3 ? 0.5 : 0.3;
        double want_pdf = li.delta ? prob[kind] : li.pdf; /* continuous pdfs checked below */
        if (fabs(li.li.g / want_li - 1.0) > 1e-5 || fabs(li.pdf / want_pdf - 1.0) > 1e-5 ||
            fabsf(rtk_vec3_length(li.wi) - 1.0f) > 1e-5f)
            wrong++;
        if (li.delta)
            continue;
        /* The density of the direction: the emitter an area sample's ray
         * finds, a miss for the environment's. */
        rtk_ray ray = {rtk_offset_ray_origin(p, ng), 0.0f, li.wi, INFINITY};
        rtk_hit hit;
        int h = kind == 0 && rtk_trace(&ctx, &ray, &hit);
        area_seen += h;
        if (kind == 0 && !h) {
            pdf_off++;
            continue;
        }
        float back = rtk_incident_light_pdf(s, p, &ray, h ? &hit : NULL);
        float want = kind == 0 ? (float)(prob[0] / 0.25 * li.dist * li.dist / fabs(li.wi.y)) : (float)(prob[4] / (4.0 * PI));
        if (fabs(back / li.pdf - 1.0) > 1e-3 || fabs(want / li.pdf - 1.0) > 1e-3)
            pdf_off++;
    }
    check(failed == 0 && wrong == 0,
          "every light kind: all samples succeed (%ld failed) with the header's radiance or irradiance (I / d^2 x "
          "falloff, E, Le) and pick probability (%ld off)", failed, wrong);
    check(pdf_off == 0 && area_seen == observed[0],
          "area and environment samples: rtk_incident_light_pdf of the traced direction = the sample's pdf = pick x "
          "dist^2 / (A |cos|) or pick / (4 pi) within 1e-3 (%ld off)", pdf_off);
    chi2_check("choice of area, point, spot, directional, environment by power", observed, prob, 5, n - failed);
    printf("      chosen %ld %ld %ld %ld %ld of %ld, expected %.0f %.0f %.0f %.0f %.0f\n", observed[0], observed[1],
           observed[2], observed[3], observed[4], n, prob[0] * n, prob[1] * n, prob[2] * n, prob[3] * n, prob[4] * n);

    /* A hit on the floor (no emitter) has density 0; so does the back of the light. */
    rtk_ray down = {rtk_vec3_make(0.1f, 0.5f, 0.1f), 0.0f, rtk_vec3_make(0, -1, 0), INFINITY};
    rtk_ray up = {rtk_vec3_make(0.1f, 1.5f, 0.1f), 0.0f, rtk_vec3_make(0, -1, 0), INFINITY};
    rtk_hit hf, hb;
    int got_floor = rtk_trace(&ctx, &down, &hf), got_back = rtk_trace(&ctx, &up, &hb);
    check(got_floor && got_back && rtk_incident_light_pdf(s, down.org, &down, &hf) == 0.0f &&
              rtk_incident_light_pdf(s, up.org, &up, &hb) == 0.0f,
          "rtk_incident_light_pdf is 0 on a surface that does not emit and on the back of an emitter");
    rtk_scene_free(s);
}

/* Two equal emitters, one through an emission texture of mean 1/4: the
 * choice counts the texture's mean (power 1 : 1/4), and a sampled point's
 * radiance is the factor x the texel there. */
static void test_emission_texture(void)
{
    float px[4 * 4 * 3];
    for (int i = 0; i < 48; i++)
        px[i] = 0.25f;
    const char *path = write_exr("quarter.exr", 4, 4, px);
    rtk_scene *s = rtk_scene_new("lights-texture", RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS |
                                                       RTK_NEED_TEXTURES | RTK_NEED_LIGHTS);
    int tex = -1;
    rtk_scene_add_texture(s, "quarter.exr", path, NULL, 0, 0, &tex);
    const rtk_vec3 e1 = {0.5f, 0.0f, 0.0f}, e2 = {0.0f, 0.0f, 0.5f};
    add_rect(s, rtk_vec3_make(-1.0f, 1.0f, 0.0f), e1, e2, add_material(s, rtk_rgb_make(0, 0, 0), rtk_rgb_make(2, 2, 2), -1));
    add_rect(s, rtk_vec3_make(0.5f, 1.0f, 0.0f), e1, e2, add_material(s, rtk_rgb_make(0, 0, 0), rtk_rgb_make(2, 2, 2), tex));
    rtk_status st = rtk_scene_finish(s);
    check(st == RTK_OK && rtk_scene_light_count(s) == 4, "two emitting quads with an emission texture on one%s%s",
          st ? ": " : "", st ? rtk_error_message() : "");
    long observed[2] = {0, 0}, wrong = 0, drawn = 0;
    const long n = 100000;
    for (long i = 0; st == RTK_OK && i < n; i++) {
        rtk_light_sample ls;
        if (!rtk_scene_sample_light(s, uniform(), uniform2(), &ls)) {
            wrong++;
            continue;
        }
        int textured = ls.prim >= 2;
        observed[textured]++, drawn++;
        if (fabsf(ls.le.g / (textured ? 0.5f : 2.0f) - 1.0f) > 1e-6f) /* bilinear weights sum to 1 within rounding */
            wrong++;
    }
    const double prob[2] = {0.8, 0.2};
    check(wrong == 0, "emission texture: Le = factor x texel at every sampled point (%ld off)", wrong);
    chi2_check("emitters chosen by area x factor x their emission texture's mean (4 : 1)", observed, prob, 2, drawn);
    rtk_scene_free(s);
}

/* Mean and standard error of the green radiance arealight returns along ray. */
static double arealight_mean(const rtk_scene *s, const char *mis, const rtk_ray *ray, long n, double *se)
{
    const rtk_integrator_fns *f = arealight->functions;
    rtk_params *params = rtk_params_defaults(arealight);
    rtk_params_set_text(params, "mis", mis);
    void *state = NULL;
    rtk_status st = f->create(params, &state);
    if (st == RTK_OK && f->prepare)
        st = f->prepare(state, s);
    rtk_params_destroy(params);
    if (st != RTK_OK) {
        check(0, "arealight set up: %s", rtk_error_message());
        *se = 0.0;
        return NAN;
    }
    rtk_ctx ctx;
    ctx_init(&ctx, s, 9);
    double sum = 0.0, sum2 = 0.0;
    for (long i = 0; i < n; i++) {
        rtk_ctx_start_sample(&ctx, (uint64_t)i, 0);
        rtk_li_result r = {.depth = INFINITY};
        f->li(state, &ctx, ray, &r);
        sum += r.radiance.g, sum2 += (double)r.radiance.g * r.radiance.g;
    }
    f->destroy(state);
    double mean = sum / n;
    *se = sqrt(fmax(0.0, sum2 / n - mean * mean) / n);
    return mean;
}

/* A white Lambertian floor under a constant environment L reflects L. */
static void test_furnace(void)
{
    const float l = 0.7f;
    rtk_scene *s = floor_scene(1000.0f);
    rtk_environment *env = NULL;
    rtk_environment_constant(rtk_rgb_make(0.2f, l, 1.0f), 1.0f, &env);
    rtk_scene_set_environment(s, env);
    const long n = 100000;
    rtk_ray ray = {rtk_vec3_make(0.3f, 1.0f, -0.2f), 0.0f, rtk_vec3_normalize(rtk_vec3_make(0.2f, -1.0f, 0.1f)), INFINITY};
    const char *modes[2] = {"false", "true"};
    for (int k = 0; k < 2; k++) {
        double se, mean = arealight_mean(s, modes[k], &ray, n, &se);
        /* Light sampling alone: 4 L cos theta on the upper half of the
         * sphere, 0 below: variance 5 L^2 / 3 per sample. */
        double se_exact = sqrt(5.0 / 3.0) * l / sqrt((double)n);
        check(fabs(mean - l) <= 5.0 * se && (k == 1 || fabs(se / se_exact - 1.0) < 0.05),
              "constant environment L = %g over a white Lambertian floor, arealight mis = %s: Lo %.6g within 5 SE "
              "(%.2g) of L%s",
              l, modes[k], mean, 5.0 * se, k == 1 ? "" : "; SE matches sqrt(5/3) L / sqrt(N)");
    }
    rtk_ray sky = {rtk_vec3_make(0.0f, 1.0f, 0.0f), 0.0f, rtk_vec3_make(0.0f, 1.0f, 0.0f), INFINITY};
    double se, seen = arealight_mean(s, "true", &sky, 16, &se);
    check(seen == l && se == 0.0, "arealight: a camera ray that misses sees the environment (%g)", seen);
    rtk_scene_free(s);
}

/* Pixels land where the header's mapping says, turned by rotation. */
static void test_mapping(void)
{
    enum { MW = 8, MH = 4 };
    float px[MW * MH * 3];
    for (int y = 0; y < MH; y++)
        for (int x = 0; x < MW; x++) {
            px[3 * (y * MW + x)] = (float)x;
            px[3 * (y * MW + x) + 1] = (float)y;
            px[3 * (y * MW + x) + 2] = 1.0f;
        }
    const char *path = write_exr("index.exr", MW, MH, px);
    typedef struct probe {
        float rotation;
        rtk_vec3 dir;
        int x, y;
        const char *what;
    } probe;
    const probe probes[] = {
        {0.0f, {0.05f, -0.05f, -1.0f}, 4, 2, "-z is the image's centre"},
        {0.0f, {1.0f, -0.05f, 0.05f}, 6, 2, "+x is u = 3/4, right of the centre"},
        {0.0f, {-1.0f, 0.05f, 0.05f}, 1, 1, "-x is u = 1/4"},
        {0.0f, {0.01f, 1.0f, 0.0f}, 6, 0, "+y is the top row"},
        {0.0f, {0.01f, -1.0f, 0.0f}, 6, 3, "-y is the bottom row"},
        {90.0f, {-1.0f, -0.05f, -0.05f}, 4, 2, "rotation 90 moves the centre to -x"},
        {90.0f, {0.05f, -0.05f, -1.0f}, 6, 2, "rotation 90 moves +x's pixel (u = 3/4) to -z"},
        {-90.0f, {1.0f, -0.05f, 0.05f}, 4, 2, "rotation -90 moves the centre to +x"},
        {180.0f, {-0.05f, -0.05f, 1.0f}, 4, 2, "rotation 180 moves the centre to +z"},
    };
    for (size_t i = 0; i < sizeof probes / sizeof probes[0]; i++) {
        rtk_environment *env = NULL;
        rtk_status st = rtk_environment_load(path, 1.0f, probes[i].rotation, &env);
        rtk_scene *s = rtk_scene_new("mapping", RTK_NEED_LIGHTS);
        rtk_scene_set_environment(s, st == RTK_OK ? env : NULL);
        rtk_rgb c = rtk_scene_environment(s, probes[i].dir);
        check(st == RTK_OK && c.r == (float)probes[i].x && c.g == (float)probes[i].y,
              "mapping, rotation %g: %s (pixel %d, %d; found %g, %g)", probes[i].rotation, probes[i].what, probes[i].x,
              probes[i].y, c.r, c.g);
        rtk_scene_free(s);
    }
    /* The brightest pixel of a turned map is sampled most, where the mapping puts it. */
    float one[MW * MH * 3];
    for (int i = 0; i < MW * MH * 3; i++)
        one[i] = 0.01f;
    one[3 * (1 * MW + 6)] = one[3 * (1 * MW + 6) + 1] = one[3 * (1 * MW + 6) + 2] = 1000.0f;
    path = write_exr("bright.exr", MW, MH, one);
    rtk_environment *env = NULL;
    rtk_status st = rtk_environment_load(path, 1.0f, 90.0f, &env);
    rtk_scene *s = floor_scene(1.0f);
    rtk_scene_set_environment(s, st == RTK_OK ? env : NULL);
    /* Pixel (6, 1): u in [3/4, 7/8], theta in [45, 90] degrees; map phi
     * 2 pi (u - 1/2) in [90, 135] degrees; turned 90: world phi in [0, 45]. */
    long inside = 0;
    const long n = 10000;
    for (long i = 0; i < n; i++) {
        rtk_light_incident li;
        if (!sample_at_origin(s, &li))
            continue;
        double phi, ct;
        angles(li.wi, &phi, &ct);
        inside += phi >= 0.0 && phi <= PI / 4 && ct >= 0.0 && ct <= sqrt(0.5);
    }
    check(inside > n * 99 / 100, "rotation 90: %ld of %ld samples fall in world phi [0, 45] degrees, theta [45, 90], "
                                 "where the bright pixel goes", inside, n);
    rtk_scene_free(s);
}

/* Bad maps are refused with the reason and the fix. */
static void test_bad_maps(void)
{
    float px[4 * 2 * 3];
    for (int i = 0; i < 24; i++)
        px[i] = 1.0f;
    typedef struct bad {
        float value;
        const char *want;
    } bad;
    const bad bads[] = {{NAN, "is nan"}, {INFINITY, "is inf"}, {-1.0f, "is -1"}};
    for (size_t i = 0; i < sizeof bads / sizeof bads[0]; i++) {
        px[3 * 5 + 1] = bads[i].value; /* pixel (1, 1), green */
        rtk_environment *env = NULL;
        rtk_status st = rtk_environment_from_pixels("sky.exr", 4, 2, 3, px, 1.0f, 0.0f, &env);
        const char *msg = rtk_error_message();
        check(st != RTK_OK && !env && strstr(msg, "sky.exr") && strstr(msg, "pixel (1, 1) channel 1") &&
                  strstr(msg, bads[i].want) && strstr(msg, "finite and not negative"),
              "pixel %g refused: %s", bads[i].value, msg);
    }
    static const char *const grey[] = {"Y"};
    char path[512];
    snprintf(path, sizeof path, "%s/grey.exr", tmpdir);
    rtk_status st = rtk_image_write(path, 4, 2, 1, grey, px, 0);
    rtk_environment *env = NULL;
    if (st == RTK_OK)
        st = rtk_environment_load(path, 1.0f, 0.0f, &env);
    check(st != RTK_OK && !env && strstr(rtk_error_message(), "has 1 channel") &&
              strstr(rtk_error_message(), "RGB (3) or RGBA (4)"),
          "a one-channel map is refused: %s", rtk_error_message());
    snprintf(path, sizeof path, "%s/missing.exr", tmpdir);
    st = rtk_environment_load(path, 1.0f, 0.0f, &env);
    check(st != RTK_OK && !env && strstr(rtk_error_message(), "missing.exr"), "a missing map is refused: %s",
          rtk_error_message());
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/rtk-test-lights-XXXXXX", base && base[0] ? base : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    rtk_pcg32_seed(&rng, 0x1234567u, 54u);
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK || rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) ||
        rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "arealight", &arealight)) {
        printf("FAIL  shipped plugins found: %s\n", rtk_error_message());
        return 1;
    }
    test_map_sampling();
    test_constant_sampling();
    test_choice();
    test_emission_texture();
    test_furnace();
    test_mapping();
    test_bad_maps();
    rtk_registry_destroy(reg);
    const char *names[] = {"map.exr", "index.exr", "bright.exr", "grey.exr", "quarter.exr"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char path[600];
        snprintf(path, sizeof path, "%s/%s", tmpdir, names[i]);
        unlink(path);
    }
    rmdir(tmpdir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
