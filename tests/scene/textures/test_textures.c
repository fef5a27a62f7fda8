/* Texture filtering (kernel/scene/texture.c, scene.c, camera.c, render.c):
 * - the MIP pyramid of odd and even images: level sizes, and every texel
 *   the area mean of the image over its rectangle (exact to float
 *   rounding; the 2x2 means of an even image bit for bit);
 * - a quad facing a 90-degree camera at distance D, so that one pixel
 *   spans exactly 2 D texels of a 32x32 texture, read through headlight
 *   with the context's camera differentials: nearest gives the texel,
 *   bilinear the blend of 4, trilinear at D = 1 (level of detail 1) the
 *   level-1 texel at pixel centres, at D = sqrt 2 the even blend of
 *   levels 1 and 2; without differentials level 0;
 * - repeat, clamp and mirrored repeat at uv in [-1.5, 2.5] for all three;
 * - the same quad placed as a rotated, scaled instance;
 * - wrap modes from glTF samplers (one image, two samplers) and MTL -clamp;
 * - through whitted's planar mirror the level of detail is the one the
 *   camera at the mirrored position sees, and reflected and refracted
 *   differentials agree with the exact neighbouring rays;
 * - the textures config slot: errors with file and line, --set, and a
 *   trilinear render through rtk_render that shows the level-1 texels.
 * References here are written from the definitions, in double; the
 * tolerances are float rounding (the level of detail comes out of float
 * geometry within about 1e-6 of the exact integer). */
#include "config/config.h"
#include "image/image.h"
#include "render/render.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"

static char tmpdir[256];
static const rtk_plugin *median, *headlight, *whitted;

static const char *in_tmp(const char *name)
{
    static char path[4][512];
    static int next;
    char *p = path[next++ & 3];
    snprintf(p, 512, "%s/%s", tmpdir, name);
    return p;
}

/* ---- images and the reference filters ---- */

typedef struct image {
    int w, h;
    float *rgba;
} image;

typedef void (*fill_fn)(int x, int y, int w, int h, float out[4]);

static image make_image(int w, int h, fill_fn fill)
{
    image im = {w, h, malloc(sizeof(float) * 4 * (size_t)w * (size_t)h)};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            fill(x, y, w, h, im.rgba + 4 * ((size_t)y * w + x));
    return im;
}

static void write_image(const char *name, const image *im)
{
    const char *names[4] = {"R", "G", "B", "A"};
    rtk_status st = rtk_image_write(in_tmp(name), im->w, im->h, 4, names, im->rgba, 0);
    if (st != RTK_OK)
        check(0, "write %s: %s", name, rtk_error_message());
}

/* Every texel distinct: red a permutation of the texel index (so no two
 * filters agree by linearity), green the column, blue the row; all k/1024. */
static void fill_distinct(int x, int y, int w, int h, float out[4])
{
    (void)h;
    int i = y * w + x;
    out[0] = (float)((i * 389 + 71) % 1024) / 1024.0f;
    out[1] = (float)x / 32.0f;
    out[2] = (float)y / 32.0f;
    out[3] = 1.0f;
}

/* One-texel checker of 0 and 1: level 0 alternates, every level below is 1/2. */
static void fill_checker(int x, int y, int w, int h, float out[4])
{
    (void)w, (void)h;
    float c = (float)((x + y) & 1);
    out[0] = out[1] = out[2] = c;
    out[3] = 1.0f;
}

/* 8x8 blocks, each a one-texel checker of a and a + 0.5 with a set per
 * block: level 1 is (2a + 0.5) / 2 across the whole block. */
static double block_low(int bx, int by)
{
    return 0.0625 * (bx + 4 * by) / 2.0;
}

static void fill_blocks(int x, int y, int w, int h, float out[4])
{
    (void)w, (void)h;
    double a = block_low(x / 8, y / 8);
    out[0] = out[1] = out[2] = (float)(((x + y) & 1) ? a + 0.5 : a);
    out[3] = 1.0f;
}

/* A reference level: sizes halve (rounding down, at least 1) and each texel
 * is the mean of level 0 over its rectangle in (u, v). */
typedef struct level {
    int w, h;
    double *rgba;
} level;

static level ref_level(const image *im, int l)
{
    level lv = {im->w, im->h, NULL};
    for (int k = 0; k < l; k++) {
        lv.w = lv.w > 1 ? lv.w / 2 : 1;
        lv.h = lv.h > 1 ? lv.h / 2 : 1;
    }
    lv.rgba = calloc(4 * (size_t)lv.w * (size_t)lv.h, sizeof(double));
    for (int y = 0; y < lv.h; y++)
        for (int x = 0; x < lv.w; x++) {
            double u0 = (double)x / lv.w, u1 = (double)(x + 1) / lv.w;
            double v0 = (double)y / lv.h, v1 = (double)(y + 1) / lv.h;
            double *d = lv.rgba + 4 * ((size_t)y * lv.w + x);
            for (int j = 0; j < im->h; j++) {
                double oy = fmin(v1, (double)(j + 1) / im->h) - fmax(v0, (double)j / im->h);
                if (oy <= 0.0)
                    continue;
                for (int i = 0; i < im->w; i++) {
                    double ox = fmin(u1, (double)(i + 1) / im->w) - fmax(u0, (double)i / im->w);
                    if (ox <= 0.0)
                        continue;
                    double wgt = ox * oy / ((u1 - u0) * (v1 - v0));
                    for (int c = 0; c < 4; c++)
                        d[c] += wgt * im->rgba[4 * ((size_t)j * im->w + i) + c];
                }
            }
        }
    return lv;
}

/* t folded into [0, 1] (repeat: [0, 1)) the way each wrap mode defines it. */
static double fold_ref(double t, int wrap)
{
    if (wrap == RTK_WRAP_CLAMP)
        return fmin(1.0, fmax(0.0, t));
    if (wrap == RTK_WRAP_MIRROR) {
        double m = t - 2.0 * floor(t / 2.0);
        return m > 1.0 ? 2.0 - m : m;
    }
    return t - floor(t);
}

static int index_ref(int i, int n, int wrap)
{
    if (wrap == RTK_WRAP_REPEAT)
        return ((i % n) + n) % n;
    return i < 0 ? 0 : i >= n ? n - 1 : i;
}

static void nearest_ref(const level *lv, rtk_tex_wrap wrap, double u, double v, double out[4])
{
    int x = (int)floor(fold_ref(u, wrap.s) * lv->w), y = (int)floor(fold_ref(v, wrap.t) * lv->h);
    x = x < 0 ? 0 : x >= lv->w ? lv->w - 1 : x;
    y = y < 0 ? 0 : y >= lv->h ? lv->h - 1 : y;
    memcpy(out, lv->rgba + 4 * ((size_t)y * lv->w + x), 4 * sizeof(double));
}

static void bilinear_ref(const level *lv, rtk_tex_wrap wrap, double u, double v, double out[4])
{
    double x = fold_ref(u, wrap.s) * lv->w - 0.5, y = fold_ref(v, wrap.t) * lv->h - 0.5;
    int x0 = (int)floor(x), y0 = (int)floor(y);
    double fx = x - x0, fy = y - y0;
    int xs[2] = {index_ref(x0, lv->w, wrap.s), index_ref(x0 + 1, lv->w, wrap.s)};
    int ys[2] = {index_ref(y0, lv->h, wrap.t), index_ref(y0 + 1, lv->h, wrap.t)};
    for (int c = 0; c < 4; c++) {
        double a = lv->rgba[4 * ((size_t)ys[0] * lv->w + xs[0]) + c], b = lv->rgba[4 * ((size_t)ys[0] * lv->w + xs[1]) + c];
        double d = lv->rgba[4 * ((size_t)ys[1] * lv->w + xs[0]) + c], e = lv->rgba[4 * ((size_t)ys[1] * lv->w + xs[1]) + c];
        out[c] = (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * d + fx * e);
    }
}

/* Trilinear at level of detail lod over the reference levels. */
static void trilinear_ref(const level *lv, int levels, rtk_tex_wrap wrap, double u, double v, double lod,
                          double out[4])
{
    if (lod <= 0.0) {
        bilinear_ref(&lv[0], wrap, u, v, out);
        return;
    }
    if (lod >= levels - 1) {
        bilinear_ref(&lv[levels - 1], wrap, u, v, out);
        return;
    }
    int l = (int)floor(lod);
    double f = lod - l, a[4], b[4];
    bilinear_ref(&lv[l], wrap, u, v, a);
    bilinear_ref(&lv[l + 1], wrap, u, v, b);
    for (int c = 0; c < 4; c++)
        out[c] = (1 - f) * a[c] + f * b[c];
}

static double rgb_error(rtk_rgb got, const double want[3])
{
    return fmax(fabs(got.r - want[0]), fmax(fabs(got.g - want[1]), fabs(got.b - want[2])));
}

/* ---- the MIP pyramid ---- */

static void test_pyramid(int w, int h)
{
    image im = make_image(w, h, fill_distinct);
    rtk_texture tex;
    memset(&tex, 0, sizeof tex);
    tex.width = w, tex.height = h, tex.decoded = 1;
    tex.rgba = malloc(sizeof(float) * 4 * (size_t)w * (size_t)h);
    memcpy(tex.rgba, im.rgba, sizeof(float) * 4 * (size_t)w * (size_t)h);
    rtk_status st = rtk_texture_set_filter(&tex, RTK_TEX_TRILINEAR);
    int levels = 1;
    for (int a = w, b = h; a > 1 || b > 1; levels++)
        a = a > 1 ? a / 2 : 1, b = b > 1 ? b / 2 : 1;
    check(st == RTK_OK && tex.levels == levels && tex.mip && tex.mip[0].rgba == tex.rgba,
          "%dx%d: %d MIP levels (want %d), level 0 the image itself", w, h, tex.levels, levels);
    int even = w % 2 == 0 && h % 2 == 0;
    char sizes[256] = "";
    int size_ok = 1;
    double worst = 0.0;
    int exact = 1;
    for (int l = 0; l < tex.levels && l < levels; l++) {
        level ref = ref_level(&im, l);
        const rtk_texture_level *got = &tex.mip[l];
        size_t n = strlen(sizes);
        snprintf(sizes + n, sizeof sizes - n, "%s%dx%d", l ? " " : "", got->width, got->height);
        size_ok &= got->width == ref.w && got->height == ref.h;
        for (int i = 0; got->width == ref.w && got->height == ref.h && i < 4 * ref.w * ref.h; i++) {
            worst = fmax(worst, fabs(got->rgba[i] - ref.rgba[i]));
            /* Level 1 of an even image: the 2x2 mean of floats, rounded once. */
            if (even && l == 1)
                exact &= got->rgba[i] == (float)ref.rgba[i];
        }
        free(ref.rgba);
    }
    check(size_ok, "%dx%d: level sizes %s, each half the one above rounded down", w, h, sizes);
    check(worst <= 1e-6, "%dx%d: every level's texels are the area means of the image (max error %.2g)", w, h,
          worst);
    if (even)
        check(exact, "%dx%d: level 1 texels equal the 2x2 box means bit for bit", w, h);
    double mean[4] = {0, 0, 0, 0};
    for (int i = 0; i < w * h; i++)
        for (int c = 0; c < 4; c++)
            mean[c] += im.rgba[4 * i + c] / (double)(w * h);
    const float *top = tex.mip[tex.levels - 1].rgba;
    check(fabs(top[0] - mean[0]) <= 1e-6 && fabs(top[1] - mean[1]) <= 1e-6 && fabs(top[2] - mean[2]) <= 1e-6,
          "%dx%d: the 1x1 level is the image's mean (%.7f %.7f %.7f)", w, h, top[0], top[1], top[2]);
    rtk_texture_set_filter(&tex, RTK_TEX_BILINEAR);
    check(tex.levels == 0 && tex.mip == NULL, "%dx%d: back to bilinear drops the levels", w, h);
    rtk_texture_set_filter(&tex, RTK_TEX_TRILINEAR);
    rtk_texture_free(&tex);
    free(im.rgba);
}

/* ---- scenes ---- */

#define FILM 16

/* The quad [-1, 1]^2 at z = 0, facing +z, textured with file under wrap;
 * (u, v) = uv0 + span ((x + 1) / 2, (1 - y) / 2): v runs down the image
 * as the texture service has it. Instanced: a quad of half the size
 * turned 90 degrees about z, placed by a rotation back and a scale of 2. */
static rtk_scene *quad_scene(const char *file, rtk_texture_filter filter, rtk_tex_wrap wrap, float uv0, float span,
                             int instanced)
{
    rtk_scene *s = rtk_scene_new(instanced ? "instanced quad" : "quad",
                                 RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES);
    rtk_material m = rtk_material_default();
    rtk_scene_add_texture(s, NULL, in_tmp(file), NULL, 0, 0, &m.base_tex);
    m.base_wrap = wrap;
    uint32_t mat = 0;
    rtk_scene_add_material(s, &m, &mat);
    rtk_scene *target = s;
    uint32_t mesh = 0;
    /* world (X, Y) = (-2 y, 2 x) */
    const double xf[12] = {0, -2, 0, 0, 2, 0, 0, 0, 0, 0, 2, 0};
    if (instanced) {
        rtk_scene_add_mesh(s, "quad", &mesh);
        target = s->meshes[mesh];
    }
    const double world[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    uint32_t idx[4];
    float uv[4][2];
    for (int k = 0; k < 4; k++) {
        double X = world[k][0], Y = world[k][1];
        if (instanced)
            rtk_scene_add_vertex(target, Y / 2.0, -X / 2.0, 0.0, &idx[k]);
        else
            rtk_scene_add_vertex(target, X, Y, 0.0, &idx[k]);
        uv[k][0] = uv0 + span * (float)((X + 1.0) / 2.0);
        uv[k][1] = uv0 + span * (float)((1.0 - Y) / 2.0);
    }
    const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int t = 0; t < 2; t++) {
        float tuv[6];
        for (int k = 0; k < 3; k++)
            tuv[2 * k] = uv[tri[t][k]][0], tuv[2 * k + 1] = uv[tri[t][k]][1];
        rtk_scene_add_triangle(target, idx[tri[t][0]], idx[tri[t][1]], idx[tri[t][2]], NULL, tuv, mat);
    }
    if (instanced)
        rtk_scene_add_instance(s, mesh, xf, "test");
    rtk_params *p = rtk_params_defaults(median);
    rtk_bvh_cache_use use;
    rtk_status st = rtk_scene_finish(s);
    if (st == RTK_OK)
        st = rtk_scene_set_texture_filter(s, filter);
    if (st == RTK_OK)
        st = rtk_bvh_build_cached(s, median, p, 1, NULL, &use);
    rtk_params_destroy(p);
    if (st != RTK_OK) {
        check(0, "build the quad scene: %s", rtk_error_message());
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

static rtk_camera facing_camera(double distance)
{
    rtk_camera_desc d = {{0.0f, 0.0f, (float)distance}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 90.0f};
    rtk_camera cam;
    rtk_camera_init(&cam, &d, FILM, FILM);
    return cam;
}

/* li of integrator (state) for the camera ray through film position
 * (fx, fy), with the camera's differentials in the context when diff is
 * set; uv gets the surface's texture coordinates there. */
static rtk_li_result shade(const rtk_plugin *integrator, void *state, const rtk_scene *s, const rtk_camera *cam,
                           float fx, float fy, int diff, rtk_vec2 *uv)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    if (diff) {
        ctx.camera = cam;
        ctx.film_x = fx;
        ctx.film_y = fy;
    }
    rtk_ctx_start_sample(&ctx, 0, 0);
    rtk_ray ray = rtk_camera_ray(cam, fx, fy);
    rtk_li_result r = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, INFINITY};
    ((const rtk_integrator_fns *)integrator->functions)->li(state, &ctx, &ray, &r);
    if (uv) {
        rtk_hit hit;
        rtk_surface sf;
        uv->x = uv->y = NAN;
        if (rtk_trace(&ctx, &ray, &hit)) {
            rtk_surface_at(s, &ray, &hit, &sf);
            *uv = sf.uv;
        }
    }
    return r;
}

static void *create(const rtk_plugin *p, const char *key, const char *value)
{
    rtk_params *params = rtk_params_defaults(p);
    void *state = NULL;
    if (key)
        rtk_params_set_text(params, key, value);
    if (((const rtk_integrator_fns *)p->functions)->create(params, &state) != RTK_OK)
        check(0, "create %s: %s", p->name, rtk_error_message());
    rtk_params_destroy(params);
    return state;
}

static void destroy(const rtk_plugin *p, void *state)
{
    ((const rtk_integrator_fns *)p->functions)->destroy(state);
}

/* ---- filters on the facing quad ---- */

typedef struct pyramid {
    level lv[8];
    int levels;
} pyramid;

static pyramid ref_pyramid(const image *im)
{
    pyramid p;
    p.levels = 0;
    for (int l = 0; l < 8; l++) {
        p.lv[l] = ref_level(im, l);
        p.levels = l + 1;
        if (p.lv[l].w == 1 && p.lv[l].h == 1)
            break;
    }
    return p;
}

static void free_pyramid(pyramid *p)
{
    for (int l = 0; l < p->levels; l++)
        free(p->lv[l].rgba);
}

static float random_in(rtk_pcg32 *rng, float lo, float hi)
{
    return lo + (hi - lo) * rtk_pcg32_float(rng);
}

static void test_filters(const pyramid *ref)
{
    const rtk_tex_wrap repeat = {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT};
    void *hl = create(headlight, NULL, NULL);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 4, 1);

    /* nearest: film positions at texel centres (u 32 = 2 fx). */
    rtk_scene *s = quad_scene("distinct.exr", RTK_TEX_NEAREST, repeat, 0.0f, 1.0f, 0);
    rtk_camera cam = facing_camera(1.0);
    int bad = 0, n = 0;
    double uv_err = 0.0;
    for (int j = 0; j < 32 && s; j += 3)
        for (int i = 0; i < 32; i += 3, n++) {
            float fx = 0.5f * i + 0.25f, fy = 0.5f * j + 0.25f;
            rtk_vec2 uv;
            rtk_li_result r = shade(headlight, hl, s, &cam, fx, fy, 1, &uv);
            uv_err = fmax(uv_err, fmax(fabs(uv.x - fx / 16.0), fabs(uv.y - fy / 16.0)));
            const double *t = ref->lv[0].rgba + 4 * (j * 32 + i);
            bad += r.albedo.r != (float)t[0] || r.albedo.g != (float)t[1] || r.albedo.b != (float)t[2];
        }
    check(s && bad == 0 && uv_err < 1e-6, "nearest: %d of %d film positions show exactly their texel (uv within %.1g)",
          n - bad, n, uv_err);
    rtk_scene_free(s);

    /* bilinear: the blend of the 4 texels around uv; differentials change nothing. */
    s = quad_scene("distinct.exr", RTK_TEX_BILINEAR, repeat, 0.0f, 1.0f, 0);
    double worst = 0.0;
    int same = 1;
    n = 0;
    for (int k = 0; k < 400 && s; k++, n++) {
        float fx = random_in(&rng, 0.0f, 16.0f), fy = random_in(&rng, 0.0f, 16.0f);
        rtk_vec2 uv;
        rtk_li_result r = shade(headlight, hl, s, &cam, fx, fy, 1, &uv), r0 = shade(headlight, hl, s, &cam, fx, fy, 0, NULL);
        double want[4];
        bilinear_ref(&ref->lv[0], repeat, uv.x, uv.y, want);
        worst = fmax(worst, rgb_error(r.albedo, want));
        same &= memcmp(&r.albedo, &r0.albedo, sizeof r.albedo) == 0;
    }
    check(s && worst <= 2e-6, "bilinear: %d positions equal the analytic blend of 4 texels (max error %.2g)", n, worst);
    check(s && same, "bilinear: the footprint changes nothing (bit for bit, as before trilinear existed)");
    rtk_scene_free(s);

    /* trilinear at D = 1: 2 texels per pixel, level of detail 1. */
    s = quad_scene("distinct.exr", RTK_TEX_TRILINEAR, repeat, 0.0f, 1.0f, 0);
    worst = 0.0;
    n = 0;
    for (int j = 0; j < FILM && s; j++)
        for (int i = 0; i < FILM; i++, n++) {
            rtk_li_result r = shade(headlight, hl, s, &cam, i + 0.5f, j + 0.5f, 1, NULL);
            const double *t = ref->lv[1].rgba + 4 * (j * 16 + i);
            /* ... which is the box mean of the 4 level-0 texels under it */
            const double *a = ref->lv[0].rgba + 4 * (2 * j * 32 + 2 * i);
            double box = (a[0] + a[4] + a[4 * 32] + a[4 * 33]) / 4.0;
            worst = fmax(worst, fmax(rgb_error(r.albedo, t), fabs(r.albedo.r - box)));
        }
    check(s && worst <= 2e-6,
          "trilinear, 2 texels per pixel: all %d pixel centres show their level-1 texel, the mean of 4 (max error %.2g)",
          n, worst);
    worst = 0.0;
    double worst0 = 0.0;
    for (int k = 0; k < 300 && s; k++) {
        float fx = random_in(&rng, 0.0f, 16.0f), fy = random_in(&rng, 0.0f, 16.0f);
        rtk_vec2 uv;
        rtk_li_result r = shade(headlight, hl, s, &cam, fx, fy, 1, &uv), r0 = shade(headlight, hl, s, &cam, fx, fy, 0, NULL);
        double want[4], want0[4];
        bilinear_ref(&ref->lv[1], repeat, uv.x, uv.y, want);
        bilinear_ref(&ref->lv[0], repeat, uv.x, uv.y, want0);
        worst = fmax(worst, rgb_error(r.albedo, want));
        worst0 = fmax(worst0, rgb_error(r0.albedo, want0));
    }
    check(s && worst <= 1e-5, "trilinear at level of detail 1: 300 positions equal bilinear level 1 (max error %.2g)",
          worst);
    check(s && worst0 <= 2e-6, "trilinear without differentials reads level 0 (max error %.2g)", worst0);

    /* D = sqrt 2: 2 sqrt 2 texels per pixel, level 1.5; D = 1/2: level 0;
     * D = 1/4 magnifies: level 0. */
    const double dist[3] = {sqrt(2.0), 0.5, 0.25};
    for (int d = 0; d < 3 && s; d++) {
        rtk_camera c = facing_camera(dist[d]);
        double lod = log2(2.0 * dist[d]);
        float lo = d == 0 ? 3.0f : 0.0f, hi = d == 0 ? 13.0f : 16.0f; /* the quad fills [2.4, 13.6] at sqrt 2 */
        worst = 0.0;
        for (int k = 0; k < 300; k++) {
            float fx = random_in(&rng, lo, hi), fy = random_in(&rng, lo, hi);
            rtk_vec2 uv;
            rtk_li_result r = shade(headlight, hl, s, &c, fx, fy, 1, &uv);
            double want[4];
            trilinear_ref(ref->lv, ref->levels, repeat, uv.x, uv.y, lod, want);
            worst = fmax(worst, rgb_error(r.albedo, want));
        }
        check(worst <= 1e-5, "trilinear at distance %.4g (%.4g texels per pixel, level of detail %.2f): 300 positions "
              "match the reference (max error %.2g)", dist[d], 2.0 * dist[d], lod, worst);
    }
    rtk_scene_free(s);

    /* The same quad as a rotated, scaled instance: the same footprint. */
    s = quad_scene("distinct.exr", RTK_TEX_TRILINEAR, repeat, 0.0f, 1.0f, 1);
    worst = 0.0;
    n = 0;
    for (int j = 0; j < FILM && s; j++)
        for (int i = 0; i < FILM; i++, n++) {
            rtk_li_result r = shade(headlight, hl, s, &cam, i + 0.5f, j + 0.5f, 1, NULL);
            worst = fmax(worst, rgb_error(r.albedo, ref->lv[1].rgba + 4 * (j * 16 + i)));
        }
    check(s && s->instance_count == 1 && worst <= 2e-6,
          "trilinear on an instance (turned 90 degrees, scaled 2): all %d pixel centres show their level-1 texel "
          "(max error %.2g)", n, worst);
    rtk_camera c = facing_camera(sqrt(2.0));
    worst = 0.0;
    for (int k = 0; k < 200 && s; k++) {
        float fx = random_in(&rng, 3.0f, 13.0f), fy = random_in(&rng, 3.0f, 13.0f);
        rtk_vec2 uv;
        rtk_li_result r = shade(headlight, hl, s, &c, fx, fy, 1, &uv);
        double want[4];
        trilinear_ref(ref->lv, ref->levels, repeat, uv.x, uv.y, 1.5, want);
        worst = fmax(worst, rgb_error(r.albedo, want));
    }
    check(s && worst <= 1e-5, "trilinear on the instance at level of detail 1.5 (max error %.2g)", worst);
    rtk_scene_free(s);
    destroy(headlight, hl);
}

/* ---- wrap modes ---- */

static const char *wrap_name(rtk_tex_wrap w)
{
    static char buf[4][64];
    static int next;
    static const char *names[3] = {"repeat", "clamp", "mirror"};
    char *b = buf[next++ & 3];
    if (w.s == w.t)
        snprintf(b, 64, "%s", names[w.s]);
    else
        snprintf(b, 64, "%s in u, %s in v", names[w.s], names[w.t]);
    return b;
}

static void test_wrap(const pyramid *ref)
{
    const rtk_tex_wrap modes[4] = {
        {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT}, {RTK_WRAP_CLAMP, RTK_WRAP_CLAMP},
        {RTK_WRAP_MIRROR, RTK_WRAP_MIRROR}, {RTK_WRAP_CLAMP, RTK_WRAP_MIRROR}};
    const rtk_texture_filter filters[3] = {RTK_TEX_NEAREST, RTK_TEX_BILINEAR, RTK_TEX_TRILINEAR};
    const char *fnames[3] = {"nearest", "bilinear", "trilinear"};
    void *hl = create(headlight, NULL, NULL);
    /* uv runs over [-1.5, 2.5]: 8 texels per pixel, level of detail 3. */
    rtk_camera cam = facing_camera(1.0);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 5, 2);
    for (int m = 0; m < 4; m++)
        for (int f = 0; f < 3; f++) {
            rtk_scene *s = quad_scene("distinct.exr", filters[f], modes[m], -1.5f, 4.0f, 0);
            if (!s)
                continue;
            double worst = 0.0;
            int n = 0, outside = 0;
            for (int k = 0; k < 256; k++, n++) {
                float fx, fy;
                if (f == 0) { /* texel centres: u 32 = 8 fx - 48 */
                    fx = ((float)(k % 16) * 8.0f + 3.5f) / 8.0f;
                    fy = ((float)(k / 16) * 8.0f + 4.5f) / 8.0f;
                } else {
                    fx = random_in(&rng, 0.0f, 16.0f);
                    fy = random_in(&rng, 0.0f, 16.0f);
                }
                rtk_vec2 uv;
                rtk_li_result r = shade(headlight, hl, s, &cam, fx, fy, 1, &uv);
                outside += uv.x < 0.0f || uv.x > 1.0f || uv.y < 0.0f || uv.y > 1.0f;
                double want[4];
                if (f == 0)
                    nearest_ref(&ref->lv[0], modes[m], uv.x, uv.y, want);
                else if (f == 1)
                    bilinear_ref(&ref->lv[0], modes[m], uv.x, uv.y, want);
                else
                    trilinear_ref(ref->lv, ref->levels, modes[m], uv.x, uv.y, 3.0, want);
                worst = fmax(worst, rgb_error(r.albedo, want));
            }
            check(worst <= (f == 0 ? 0.0 : f == 1 ? 2e-6 : 1e-5),
                  "%s, %s: %d positions (%d outside [0, 1]) match the reference (max error %.2g)", wrap_name(modes[m]),
                  fnames[f], n, outside, worst);
            rtk_scene_free(s);
        }
    destroy(headlight, hl);
}

/* ---- wrap modes from the loaders ---- */

static void write_file(const char *name, const char *text)
{
    FILE *f = fopen(in_tmp(name), "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static void test_loaders(void)
{
    /* glTF: one image read by two textures with different samplers. */
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const float uv[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    FILE *f = fopen(in_tmp("wrap.bin"), "wb");
    if (f) {
        fwrite(pos, sizeof pos, 1, f);
        fwrite(uv, sizeof uv, 1, f);
        fwrite(idx, sizeof idx, 1, f);
        fclose(f);
    }
    write_file("wrap.gltf",
               "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],\n"
               " \"nodes\": [{\"mesh\": 0}],\n"
               " \"meshes\": [{\"primitives\": [\n"
               "   {\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"indices\": 2, \"material\": 0},\n"
               "   {\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"indices\": 2, \"material\": 1}]}],\n"
               " \"materials\": [{\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 0}}},\n"
               "   {\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 1}}}],\n"
               " \"textures\": [{\"source\": 0, \"sampler\": 0}, {\"source\": 0, \"sampler\": 1}],\n"
               " \"samplers\": [{\"wrapS\": 33071, \"wrapT\": 33648}, {}],\n"
               " \"images\": [{\"uri\": \"distinct.exr\"}],\n"
               " \"buffers\": [{\"uri\": \"wrap.bin\", \"byteLength\": 92}],\n"
               " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},\n"
               "   {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 32},\n"
               "   {\"buffer\": 0, \"byteOffset\": 80, \"byteLength\": 12}],\n"
               " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\",\n"
               "   \"min\": [0, 0, 0], \"max\": [1, 1, 0]},\n"
               "   {\"bufferView\": 1, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC2\"},\n"
               "   {\"bufferView\": 2, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}\n");
    rtk_scene *s = NULL;
    rtk_status st = rtk_scene_load(in_tmp("wrap.gltf"), RTK_NEED_TEXTURES, &s);
    if (st != RTK_OK) {
        check(0, "load wrap.gltf: %s", rtk_error_message());
    } else {
        const rtk_material *m = s->materials;
        check(s->material_count == 2 && s->texture_count == 1 && m[0].base_tex == 0 && m[1].base_tex == 0,
              "glTF: one image under two samplers is one texture (%u), used by both materials", s->texture_count);
        check(s->material_count == 2 && m[0].base_wrap.s == RTK_WRAP_CLAMP && m[0].base_wrap.t == RTK_WRAP_MIRROR &&
                  m[1].base_wrap.s == RTK_WRAP_REPEAT && m[1].base_wrap.t == RTK_WRAP_REPEAT,
              "glTF: wrapS CLAMP_TO_EDGE, wrapT MIRRORED_REPEAT on the first use; the default REPEAT on the second");
        rtk_scene_free(s);
    }
    /* MTL: -clamp on for one map, not the other, of the same file. */
    write_file("clamp.mtl", "newmtl a\nKd 1 1 1\nmap_Kd -clamp on distinct.exr\nmap_Ke distinct.exr\n"
                            "newmtl b\nKd 1 1 1\nmap_Kd -clamp off distinct.exr\n");
    write_file("clamp.obj", "mtllib clamp.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                            "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 2/2\n");
    st = rtk_scene_load(in_tmp("clamp.obj"), RTK_NEED_TEXTURES, &s);
    if (st != RTK_OK) {
        check(0, "load clamp.obj: %s", rtk_error_message());
        return;
    }
    const rtk_material *m = s->materials;
    check(s->material_count == 2 && m[0].base_wrap.s == RTK_WRAP_CLAMP && m[0].base_wrap.t == RTK_WRAP_CLAMP &&
              m[0].emission_wrap.s == RTK_WRAP_REPEAT && m[1].base_wrap.s == RTK_WRAP_REPEAT &&
              m[0].base_tex == m[1].base_tex,
          "MTL: map_Kd -clamp on clamps both axes, map_Ke and -clamp off repeat, one texture for the file");
    rtk_scene_free(s);
}

/* ---- differentials through whitted's mirror ---- */

static void add_quad(rtk_scene *s, rtk_vec3 c, rtk_vec3 eu, rtk_vec3 ev, uint32_t mat, int uvs)
{
    uint32_t i[4];
    const float su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; k++) {
        rtk_vec3 p = rtk_vec3_add(c, rtk_vec3_add(rtk_vec3_scale(eu, su[k]), rtk_vec3_scale(ev, sv[k])));
        rtk_scene_add_vertex(s, p.x, p.y, p.z, &i[k]);
    }
    const float uv[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int t = 0; t < 2; t++) {
        float tuv[6];
        for (int k = 0; k < 3; k++)
            tuv[2 * k] = uv[tri[t][k]][0], tuv[2 * k + 1] = uv[tri[t][k]][1];
        rtk_scene_add_triangle(s, i[tri[t][0]], i[tri[t][1]], i[tri[t][2]], NULL, uvs ? tuv : NULL, mat);
    }
}

/* The checker quad of side 2 facing the origin from (1, 0, 1); with a
 * mirror, the plane z = 0 too. */
static rtk_scene *mirror_scene(int mirror)
{
    rtk_scene *s = rtk_scene_new(mirror ? "mirror" : "unfolded",
                                 RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS);
    rtk_material m = rtk_material_default();
    rtk_scene_add_texture(s, NULL, in_tmp("checker.exr"), NULL, 0, 0, &m.base_tex);
    uint32_t textured = 0, glass = 0;
    rtk_scene_add_material(s, &m, &textured);
    rtk_material mm = rtk_material_default(); /* a smooth white metal: a perfect mirror */
    mm.model = RTK_MODEL_METALLIC_ROUGHNESS;
    mm.metallic = 1.0f;
    mm.roughness = 0.0f;
    rtk_scene_add_material(s, &mm, &glass);
    float r = (float)sqrt(0.5);
    add_quad(s, rtk_vec3_make(1, 0, 1), rtk_vec3_make(r, 0, -r), rtk_vec3_make(0, 1, 0), textured, 1);
    if (mirror)
        add_quad(s, rtk_vec3_make(0, 0, 0), rtk_vec3_make(3, 0, 0), rtk_vec3_make(0, 3, 0), glass, 1);
    rtk_params *p = rtk_params_defaults(median);
    rtk_bvh_cache_use use;
    rtk_status st = rtk_scene_finish(s);
    if (st == RTK_OK)
        st = rtk_scene_set_texture_filter(s, RTK_TEX_TRILINEAR);
    if (st == RTK_OK)
        st = rtk_bvh_build_cached(s, median, p, 1, NULL, &use);
    rtk_params_destroy(p);
    if (st != RTK_OK) {
        check(0, "build the mirror scene: %s", rtk_error_message());
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

#define MFILM 32

/* Where the mirror sends camera ray ray of scene s, as whitted builds the
 * reflected ray (offset origin, mirror direction): the uv it hits. */
static int mirrored_uv(const rtk_scene *s, rtk_ray ray, rtk_vec2 *uv)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    rtk_hit hit;
    rtk_surface sf;
    if (!rtk_trace(&ctx, &ray, &hit))
        return 0;
    rtk_surface_at(s, &ray, &hit, &sf);
    rtk_vec3 wo = rtk_vec3_neg(rtk_vec3_normalize(ray.dir));
    rtk_ray r = {rtk_offset_ray_origin(sf.p, sf.ng), 0.0f,
                 rtk_vec3_sub(rtk_vec3_scale(sf.ns, 2.0f * rtk_vec3_dot(wo, sf.ns)), wo), INFINITY};
    if (!rtk_trace(&ctx, &r, &hit))
        return 0;
    rtk_surface_at(s, &r, &hit, &sf);
    *uv = sf.uv;
    return 1;
}

static void test_mirror(const pyramid *checker)
{
    rtk_scene *a = mirror_scene(1), *b = mirror_scene(0);
    if (!a || !b) {
        rtk_scene_free(a);
        rtk_scene_free(b);
        return;
    }
    /* A looks at the mirror at 45 degrees; B is its mirror image, behind
     * the mirror plane, seeing the quad straight on from 2 sqrt 2. The
     * mirror turns left and right round: A's film x is B's MFILM - x. */
    rtk_camera_desc da = {{-1, 0, 1}, {0, 0, 0}, {0, 1, 0}, 30.0f}, db = {{-1, 0, -1}, {0, 0, 0}, {0, 1, 0}, 30.0f};
    rtk_camera ca, cb;
    rtk_camera_init(&ca, &da, MFILM, MFILM);
    rtk_camera_init(&cb, &db, MFILM, MFILM);
    void *w = create(whitted, "ambient", "1");
    const rtk_tex_wrap repeat = {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT};
    /* Texels per pixel on the quad seen by B: a pixel spans 2 D tan 15 / MFILM
     * at D = 2 sqrt 2, and the quad has 32 texels per unit. On the checker,
     * level 0 alternates 0 and 1 and level 1 is 1/2, so the value at a
     * point moves with the level of detail. */
    double lod = log2(2.0 * 2.0 * sqrt(2.0) * tan(15.0 * RTK_PI / 180.0) / MFILM * 32.0);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 6, 3);
    double worst_a = 0.0, worst_b = 0.0, sum_a = 0.0, sum_b = 0.0;
    int differ = 0, n = 0, lost = 0;
    for (int k = 0; k < 400; k++, n++) {
        float fx = random_in(&rng, 1.0f, MFILM - 1.0f), fy = random_in(&rng, 1.0f, MFILM - 1.0f);
        rtk_vec2 uva, uvb;
        rtk_li_result ra = shade(whitted, w, a, &ca, fx, fy, 1, NULL);
        rtk_li_result rb = shade(whitted, w, b, &cb, MFILM - fx, fy, 1, &uvb);
        rtk_li_result r0 = shade(whitted, w, a, &ca, fx, fy, 0, NULL);
        if (!mirrored_uv(a, rtk_camera_ray(&ca, fx, fy), &uva)) {
            lost++;
            continue;
        }
        double want_a[4], want_b[4];
        trilinear_ref(checker->lv, checker->levels, repeat, uva.x, uva.y, lod, want_a);
        trilinear_ref(checker->lv, checker->levels, repeat, uvb.x, uvb.y, lod, want_b);
        worst_a = fmax(worst_a, fabs(ra.radiance.g - want_a[1]));
        worst_b = fmax(worst_b, fabs(rb.radiance.g - want_b[1]));
        sum_a += ra.radiance.g, sum_b += rb.radiance.g;
        differ += fabs(r0.radiance.g - want_a[1]) > 0.02;
    }
    check(lost == 0 && worst_b <= 1e-5, "the mirrored camera sees the checker at level of detail %.4f (max error %.2g)",
          lod, worst_b);
    check(lost == 0 && worst_a <= 1e-5,
          "through whitted's mirror the reflected differentials give the same level of detail: %d positions match "
          "(max error %.2g; mean %.6f, the mirrored camera's %.6f)", n, worst_a, sum_a / n, sum_b / n);
    check(differ > n / 4, "... which matters: without differentials %d of %d positions differ by > 0.02", differ, n);
    destroy(whitted, w);
    rtk_scene_free(a);
    rtk_scene_free(b);
}

/* ---- reflect and refract against the exact neighbouring rays ---- */

static double dir_error(rtk_vec3 a, rtk_vec3 b)
{
    a = rtk_vec3_normalize(a), b = rtk_vec3_normalize(b);
    return rtk_vec3_length(rtk_vec3_sub(a, b));
}

static rtk_vec3 snell(rtk_vec3 d, rtk_vec3 n, double eta)
{
    d = rtk_vec3_normalize(d);
    double ci = -rtk_vec3_dot(d, n);
    double ct = sqrt(1.0 - eta * eta * (1.0 - ci * ci));
    return rtk_vec3_add(rtk_vec3_scale(d, (float)eta), rtk_vec3_scale(n, (float)(eta * ci - ct)));
}

static void test_propagation(void)
{
    rtk_scene *s = rtk_scene_new("slab", RTK_NEED_NORMALS | RTK_NEED_MATERIALS);
    rtk_material m = rtk_material_default();
    uint32_t id = 0;
    rtk_scene_add_material(s, &m, &id);
    add_quad(s, rtk_vec3_make(0, 0, 0), rtk_vec3_make(10, 0, 0), rtk_vec3_make(0, 10, 0), id, 0);
    add_quad(s, rtk_vec3_make(0, 0, -0.5f), rtk_vec3_make(10, 0, 0), rtk_vec3_make(0, 10, 0), id, 0);
    rtk_params *p = rtk_params_defaults(median);
    rtk_bvh_cache_use use;
    if (rtk_scene_finish(s) != RTK_OK || rtk_bvh_build_cached(s, median, p, 1, NULL, &use) != RTK_OK) {
        check(0, "build the slab: %s", rtk_error_message());
        rtk_params_destroy(p);
        rtk_scene_free(s);
        return;
    }
    rtk_params_destroy(p);
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    rtk_ray ray = {{0, 0, 2}, 0.0f, rtk_vec3_normalize(rtk_vec3_make(0.3f, 0.2f, -1.0f)), INFINITY};
    rtk_ray_differential d = {ray.org, rtk_vec3_normalize(rtk_vec3_add(ray.dir, rtk_vec3_make(1e-3f, 0, 0))), ray.org,
                              rtk_vec3_normalize(rtk_vec3_add(ray.dir, rtk_vec3_make(0, 1e-3f, 0)))};
    rtk_hit hit;
    rtk_surface sf;
    if (!rtk_trace(&ctx, &ray, &hit)) {
        check(0, "the ray meets the slab");
        rtk_scene_free(s);
        return;
    }
    rtk_surface_at_footprint(s, &ray, &d, &hit, &sf);
    rtk_vec3 n = sf.ns;
    /* Where the neighbouring rays meet the top face, exactly, moved as the
     * new ray's origin is moved off the surface (up for the reflection,
     * down for the refraction). */
    rtk_vec3 qx = rtk_vec3_add(d.rx_org, rtk_vec3_scale(d.rx_dir, -d.rx_org.z / d.rx_dir.z));
    rtk_vec3 qy = rtk_vec3_add(d.ry_org, rtk_vec3_scale(d.ry_dir, -d.ry_org.z / d.ry_dir.z));
    rtk_vec3 up = rtk_vec3_sub(rtk_offset_ray_origin(sf.p, sf.ng), sf.p);
    rtk_vec3 down = rtk_vec3_sub(rtk_offset_ray_origin(sf.p, rtk_vec3_neg(sf.ng)), sf.p);

    rtk_vec3 wi = rtk_vec3_sub(ray.dir, rtk_vec3_scale(n, 2.0f * rtk_vec3_dot(ray.dir, n)));
    rtk_ray_differential out;
    int ok = rtk_differential_reflect(s, &ray, &d, &hit, &sf, wi, &out);
    rtk_vec3 mx = rtk_vec3_make(d.rx_dir.x, d.rx_dir.y, -d.rx_dir.z), my = rtk_vec3_make(d.ry_dir.x, d.ry_dir.y, -d.ry_dir.z);
    double eo = fmax(rtk_vec3_length(rtk_vec3_sub(out.rx_org, rtk_vec3_add(qx, up))),
                     rtk_vec3_length(rtk_vec3_sub(out.ry_org, rtk_vec3_add(qy, up))));
    double ed = fmax(dir_error(out.rx_dir, mx), dir_error(out.ry_dir, my));
    check(ok && eo <= 1e-6 && ed <= 1e-6,
          "reflected differentials are the mirrored neighbouring rays (origins %.2g, directions %.2g)", eo, ed);

    /* Into glass (n = 1.5): first order in the 1e-3 step, so within ~1e-6. */
    rtk_vec3 wt = snell(ray.dir, n, 1.0 / 1.5);
    ok = rtk_differential_refract(s, &ray, &d, &hit, &sf, wt, 1.0f / 1.5f, &out);
    eo = fmax(rtk_vec3_length(rtk_vec3_sub(out.rx_org, rtk_vec3_add(qx, down))),
              rtk_vec3_length(rtk_vec3_sub(out.ry_org, rtk_vec3_add(qy, down))));
    ed = fmax(dir_error(out.rx_dir, snell(d.rx_dir, n, 1.0 / 1.5)), dir_error(out.ry_dir, snell(d.ry_dir, n, 1.0 / 1.5)));
    check(ok && eo <= 1e-6 && ed <= 1e-5,
          "refracted differentials follow Snell's law for the neighbouring rays (origins %.2g, directions %.2g)", eo,
          ed);
    /* ... and out of the slab's parallel bottom face: parallel to the rays that came in. */
    rtk_ray inside = {rtk_offset_ray_origin(sf.p, rtk_vec3_neg(sf.ng)), 0.0f, wt, INFINITY};
    rtk_hit hit2;
    rtk_surface sf2;
    rtk_ray_differential out2;
    ok = ok && rtk_trace(&ctx, &inside, &hit2);
    if (ok) {
        rtk_surface_at_footprint(s, &inside, &out, &hit2, &sf2);
        rtk_vec3 wo2 = snell(wt, sf2.ns, 1.5);
        ok = rtk_differential_refract(s, &inside, &out, &hit2, &sf2, wo2, 1.5f, &out2);
        ed = fmax(dir_error(out2.rx_dir, d.rx_dir), dir_error(out2.ry_dir, d.ry_dir));
    }
    check(ok && ed <= 1e-5, "through a parallel slab the differentials leave parallel to the entering ones (%.2g)",
          ed);
    rtk_ray_differential none;
    check(!rtk_differential_reflect(s, &ray, NULL, &hit, &sf, wi, &none), "no differentials in, none out");
    rtk_scene_free(s);
}

/* ---- the config slot and a render ---- */

static rtk_status load_config(rtk_registry *reg, const char *name, const char *text, const char *override,
                              rtk_config **cfg)
{
    write_file(name, text);
    rtk_config_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.overrides = &override;
    o.override_count = override ? 1 : 0;
    return rtk_config_load(in_tmp(name), reg, &o, cfg);
}

static void expect_error(rtk_registry *reg, const char *what, const char *body, const char *line, const char *word)
{
    char text[1024];
    snprintf(text, sizeof text, "scene = \"blocks.obj\";\ncache = \"off\";\n%s\n", body);
    rtk_config *cfg = NULL;
    rtk_status st = load_config(reg, "bad.cfg", text, NULL, &cfg);
    const char *msg = rtk_error_message();
    char where[64];
    snprintf(where, sizeof where, "bad.cfg:%s", line);
    check(st != RTK_OK && strstr(msg, where) && strstr(msg, word), "%s: refused at %s: %s", what, where, msg);
    rtk_config_destroy(cfg);
}

static void test_config(void)
{
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK) {
        check(0, "registry: %s", rtk_error_message());
        return;
    }
    image blocks = make_image(32, 32, fill_blocks);
    write_image("blocks.exr", &blocks);
    free(blocks.rgba);
    write_file("blocks.mtl", "newmtl m\nKd 1 1 1\nmap_Kd blocks.exr\n");
    write_file("blocks.obj", "mtllib blocks.mtl\nusemtl m\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                             "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
    expect_error(reg, "unknown filter", "textures = { filter = \"bicubic\"; };", "3", "bicubic");
    expect_error(reg, "misspelt key", "textures = {\n  filtr = \"nearest\"; };", "4", "filter");
    expect_error(reg, "not a group", "textures = \"trilinear\";", "3", "group");

    const char *base = "scene = \"blocks.obj\";\n"
                       "camera = { position = [0.0, 0.0, 1.0]; look_at = [0.0, 0.0, 0.0]; fov = 90.0; };\n"
                       "film = { width = 16; height = 16; spp = 4; output = \"%s\"; };\n"
                       "cache = \"off\";\nthreads = 1;\n"
                       "integrator = { plugin = \"ao\"; rays = 1; albedo = true; };\n"
                       "filter = { plugin = \"box\"; radius = 0.5; };\n%s";
    char text[2048];
    rtk_config *cfg = NULL;
    snprintf(text, sizeof text, base, "plain.exr", "");
    rtk_status st = load_config(reg, "plain.cfg", text, NULL, &cfg);
    check(st == RTK_OK && cfg->texture_filter == RTK_TEX_BILINEAR, "no textures group: bilinear");
    rtk_config_destroy(cfg);
    cfg = NULL;
    st = load_config(reg, "plain.cfg", text, "textures.filter=nearest", &cfg);
    check(st == RTK_OK && cfg->texture_filter == RTK_TEX_NEAREST, "--set textures.filter=nearest");
    rtk_config_destroy(cfg);
    cfg = NULL;

    snprintf(text, sizeof text, base, "tri.exr", "textures = { filter = \"trilinear\"; };\n");
    st = load_config(reg, "tri.cfg", text, NULL, &cfg);
    rtk_render_options opts;
    memset(&opts, 0, sizeof opts);
    opts.size = sizeof opts;
    opts.quiet = 1;
    rtk_render_report rep;
    memset(&rep, 0, sizeof rep);
    rep.size = sizeof rep;
    if (st == RTK_OK)
        st = rtk_render(cfg, &opts, &rep);
    rtk_config_destroy(cfg);
    rtk_image img = {0, 0, NULL, 0, 0};
    if (st == RTK_OK)
        st = rtk_image_read(in_tmp("tri.exr"), NULL, 0, 0, &img);
    if (st != RTK_OK) {
        check(0, "trilinear render: %s", rtk_error_message());
    } else {
        /* Pixels 1 and 2 of each 4: every sample's level-1 stencil stays in its block. */
        double worst = 0.0;
        int n = 0;
        for (int y = 0; y < 16; y++)
            for (int x = 0; x < 16; x++) {
                if (x % 4 == 0 || x % 4 == 3 || y % 4 == 0 || y % 4 == 3)
                    continue;
                double want = block_low(x / 4, y / 4) + 0.25;
                const float *px = img.rgba + 4 * (y * 16 + x);
                worst = fmax(worst, fmax(fabs(px[0] - want), fabs(px[2] - want)));
                n++;
            }
        check(worst <= 1e-5, "rtk_render with textures.filter = trilinear (ao with albedo, 4 jittered spp): %d "
              "block pixels show level 1, the mean of a and a + 1/2 (max error %.2g)", n, worst);
    }
    free(img.rgba);
    rtk_registry_destroy(reg);
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/rtk-textures-XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary directory\n");
        return 1;
    }
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK || rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "headlight", &headlight) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "whitted", &whitted) != RTK_OK) {
        printf("FAIL  plugins: %s\n", rtk_error_message());
        return 1;
    }
    rtk_log_set_level(RTK_LOG_WARN);
    test_pyramid(5, 3);
    test_pyramid(7, 1);
    test_pyramid(6, 5);
    test_pyramid(1, 1);
    test_pyramid(8, 4);

    image distinct = make_image(32, 32, fill_distinct), checker = make_image(64, 64, fill_checker);
    write_image("distinct.exr", &distinct);
    write_image("checker.exr", &checker);
    pyramid pd = ref_pyramid(&distinct), pc = ref_pyramid(&checker);
    test_filters(&pd);
    test_wrap(&pd);
    test_loaders();
    test_mirror(&pc);
    test_propagation();
    test_config();
    free_pyramid(&pd);
    free_pyramid(&pc);
    free(distinct.rgba);
    free(checker.rgba);
    rtk_registry_destroy(reg);

    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (!getenv("KEEP") && system(cmd) != 0)
        printf("note  could not remove %s\n", tmpdir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
