/* Conformance checks for integrator plugins, for every parameter set:
 * known flags, and a render of a small lit room that is finite, not black
 * (black where the parameter set is documented as "emitters only"),
 * the same on 1 and 2 threads and traced through the kernel, li_batch
 * and the device program (conform_programs.c) equal to li; then the
 * known-answer profiles the plugin declares (conform_profiles.c). Also
 * the stand-in accelerator and filter those renders use. */
#include "conform.h"

#include <ctype.h>
#include <stddef.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

rtk_material rtk_conform_diffuse(rtk_rgb albedo, float le)
{
    rtk_material m = rtk_material_default();
    m.base_color = albedo;
    m.emission = rtk_rgb_make(le, le, le);
    return m;
}

uint32_t rtk_conform_add_material(rtk_scene *s, rtk_material m)
{
    uint32_t id = RTK_INVALID_ID;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

void rtk_conform_add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t material, int with_uv)
{
    uint32_t i[4];
    rtk_vec3 p[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    static const float uv[6] = {0, 0, 1, 0, 1, 1};
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, with_uv ? uv : NULL, material);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, with_uv ? uv : NULL, material);
}

/* The standard room's quads carry uvs. */
static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t material)
{
    rtk_conform_add_quad(s, o, e1, e2, material, 1);
}

/* A material of the standard room. */
static uint32_t add_material(rtk_scene *s, float r, float g, float b, float emit)
{
    return rtk_conform_add_material(s, rtk_conform_diffuse(rtk_rgb_make(r, g, b), emit));
}

/* A small room, open at the front, with a ceiling light and a block: every integrator
 * sees geometry, materials and an emitter. */
static rtk_status make_room(uint32_t needs, rtk_scene **out)
{
    rtk_scene *s = rtk_scene_new("conform room", needs);
    if (!s)
        return RTK_ERR_NOMEM;
    uint32_t white = add_material(s, 0.8f, 0.8f, 0.8f, 0.0f), red = add_material(s, 0.8f, 0.1f, 0.1f, 0.0f);
    uint32_t light = add_material(s, 0.0f, 0.0f, 0.0f, 10.0f);
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(0, 0, 2), rtk_vec3_make(2, 0, 0), white);  /* floor */
    add_quad(s, rtk_vec3_make(-1, 2, -1), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 0, 2), white);  /* ceiling */
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 2, 0), white);  /* back */
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(0, 2, 0), rtk_vec3_make(0, 0, 2), red);    /* left */
    add_quad(s, rtk_vec3_make(1, 0, -1), rtk_vec3_make(0, 0, 2), rtk_vec3_make(0, 2, 0), white);   /* right */
    add_quad(s, rtk_vec3_make(-0.25f, 1.99f, -0.25f), rtk_vec3_make(0.5f, 0, 0), rtk_vec3_make(0, 0, 0.5f), light);
    add_quad(s, rtk_vec3_make(-0.5f, 0.6f, -0.5f), rtk_vec3_make(0.4f, 0, 0), rtk_vec3_make(0, 0, 0.4f), white);
    /* A point light under the ceiling for integrators that use punctual lights. */
    rtk_punctual_light point = {.type = RTK_LIGHT_POINT, .position = rtk_vec3_make(0.2f, 1.8f, 0.3f),
                                .intensity = rtk_rgb_make(2.0f, 2.0f, 2.0f)};
    rtk_status st = rtk_scene_add_punctual(s, &point);
    if (st == RTK_OK)
        st = rtk_scene_finish(s);
    if (st != RTK_OK) {
        rtk_scene_free(s);
        return st;
    }
    *out = s;
    return RTK_OK;
}

/* A builder that needs no plugin: one leaf over everything (see
 * conform.h). */
static rtk_status one_leaf_build(void *state, rtk_build_args *a)
{
    (void)state;
    rtk_bvh_node *n = &a->nodes[0];
    for (int k = 0; k < 3; k++)
        n->lower[k] = INFINITY, n->upper[k] = -INFINITY;
    for (uint32_t i = 0; i < a->prim_count; i++) {
        const rtk_bounds *b = &a->prim_bounds[i];
        const float lo[3] = {b->lower.x, b->lower.y, b->lower.z}, hi[3] = {b->upper.x, b->upper.y, b->upper.z};
        for (int k = 0; k < 3; k++)
            n->lower[k] = fminf(n->lower[k], lo[k]), n->upper[k] = fmaxf(n->upper[k], hi[k]);
        a->prim_order[i] = i;
    }
    n->offset = 0;
    n->count = a->prim_count;
    a->node_count = 1;
    return RTK_OK;
}

static rtk_status no_state(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static void no_destroy(void *state)
{
    (void)state;
}

static float pixel_box_radius(const void *state)
{
    (void)state;
    return 0.5f;
}

static float pixel_box_eval(const void *state, float dx, float dy)
{
    (void)state;
    return fabsf(dx) <= 0.5f && fabsf(dy) <= 0.5f ? 1.0f : 0.0f;
}

static double pixel_box_integral(const void *state)
{
    (void)state;
    return 1.0;
}

static const rtk_accelerator_fns one_leaf_fns = {
    .size = sizeof(rtk_accelerator_fns), .create = no_state, .build = one_leaf_build, .destroy = no_destroy};
const rtk_plugin rtk_conform_one_leaf = {RTK_PLUGIN_HEADER,
                                         .kind = RTK_KIND_ACCELERATOR,
                                         .name = "conform-one-leaf",
                                         .version = "1",
                                         .summary = "",
                                         .functions = &one_leaf_fns};
const rtk_filter_fns rtk_conform_pixel_box = {.size = sizeof(rtk_filter_fns),
                                              .create = no_state,
                                              .radius = pixel_box_radius,
                                              .eval = pixel_box_eval,
                                              .integral = pixel_box_integral,
                                              .destroy = no_destroy};

/* 1 when label names a parameter set "name=value" whose parameter's doc
 * line documents that value as showing emitters only ("0 = emitters
 * only"): such an instance renders the standard room black, since its
 * camera sees no emitter. */
static int emitters_only(const rtk_plugin *p, const char *label)
{
    const char *eq = strchr(label, '=');
    if (!eq)
        return 0;
    for (uint32_t i = 0; i < p->param_count; i++) {
        const rtk_param_desc *d = &p->params[i];
        if (strlen(d->name) != (size_t)(eq - label) || strncmp(d->name, label, (size_t)(eq - label)) != 0 || !d->doc)
            continue;
        char phrase[96];
        snprintf(phrase, sizeof phrase, "%s = emitters only", eq + 1);
        const char *at = strstr(d->doc, phrase);
        /* the value must start a word: "10 = ..." is not "0 = ..." */
        return at && (at == d->doc || !isalnum((unsigned char)at[-1]));
    }
    return 0;
}

void rtk_conform_same_films(rtk_conform_runner *r, const char *name, const char *way, const float *a,
                            const rtk_render_stats *sa, const float *through_li, const rtk_render_stats *sb,
                            size_t count)
{
    size_t differ = 0, first = count;
    for (size_t i = 0; i < count; i++)
        if (memcmp(&a[i], &through_li[i], sizeof(float)) != 0 && differ++ == 0)
            first = i;
    rtk_conform_check(r, differ == 0 && sa->rays == sb->rays && sa->invalid_rays == sb->invalid_rays, name,
                      "%zu of %zu values differ (first: pixel %zu channel %zu, %.9g through %s, %.9g through li); "
                      "rays %llu against %llu, invalid %llu against %llu",
                      differ, count, first / RTK_FILM_CHANNELS, first % RTK_FILM_CHANNELS,
                      differ ? (double)a[first] : 0.0, way, differ ? (double)through_li[first] : 0.0,
                      (unsigned long long)sa->rays, (unsigned long long)sb->rays,
                      (unsigned long long)sa->invalid_rays, (unsigned long long)sb->invalid_rays);
}

/* li_batch gives what li gives, bit for bit: job (rendered through
 * li_batch into batched) again one ray at a time into single, for each
 * sampler; the pixels and the rays traced must be equal. */
static void check_batches(rtk_conform_runner *r, rtk_film_render *job, float *batched, float *single, size_t count,
                          const char *label)
{
    static const rtk_sampler_type samplers[] = {RTK_SAMPLER_INDEPENDENT, RTK_SAMPLER_STRATIFIED, RTK_SAMPLER_SOBOL};
    static const char *const names[] = {"independent", "stratified", "sobol"};
    job->threads = 1;
    for (size_t k = 0; k < sizeof samplers / sizeof samplers[0]; k++) {
        rtk_render_stats sa, sb;
        job->sampler = samplers[k];
        job->one_ray_at_a_time = 0;
        rtk_status s1 = rtk_render_film(job, batched, &sa);
        job->one_ray_at_a_time = 1;
        rtk_status s2 = s1 == RTK_OK ? rtk_render_film(job, single, &sb) : s1;
        char name[256];
        snprintf(name, sizeof name, "li_batch equals li bit for bit (%s sampler) [%s]", names[k], label);
        if (s1 != RTK_OK || s2 != RTK_OK) {
            rtk_conform_check(r, 0, name, "%s", rtk_error_message());
            continue;
        }
        rtk_conform_same_films(r, name, "li_batch", batched, &sa, single, &sb, count);
    }
    job->sampler = RTK_SAMPLER_INDEPENDENT;
    job->one_ray_at_a_time = 0;
}

/* The generic checks of one instance of the integrator p, label its
 * parameter set. */
static void check_integrator(rtk_conform_runner *r, const rtk_plugin *p, void *state, const char *label)
{
    const rtk_integrator_fns *f = p->functions;
    char name[256];
    uint32_t needs = f->needs(state);
    snprintf(name, sizeof name, "needs only known flags [%s]", label);
    rtk_conform_check(r, (needs & ~0x1fu) == 0, name, "needs 0x%x has unknown bits", needs);
    rtk_scene *scene = NULL;
    rtk_status st = make_room(needs, &scene);
    if (st == RTK_OK)
        st = rtk_bvh_build(scene, &rtk_conform_one_leaf, NULL, 1);
    if (st != RTK_OK) {
        rtk_conform_check(r, 0, "standard scene", "%s", rtk_error_message());
        rtk_scene_free(scene);
        return;
    }
    if (f->prepare) {
        st = f->prepare(state, scene);
        snprintf(name, sizeof name, "prepare on the standard scene [%s]", label);
        rtk_conform_check(r, st == RTK_OK, name, "%s", rtk_error_message());
    }
    if (st == RTK_OK) {
        rtk_camera_desc d = {rtk_vec3_make(0, 1, 0.95f), rtk_vec3_make(0, 0.8f, 0), rtk_vec3_make(0, 1, 0), 80.0f};
        rtk_camera cam;
        rtk_camera_init(&cam, &d, 24, 20);
        size_t count = (size_t)24 * 20 * RTK_FILM_CHANNELS;
        float *a = rtk_alloc(count * sizeof(float)), *b = rtk_alloc(count * sizeof(float));
        rtk_render_stats sa, sb;
        rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
        job.scene = scene;
        job.camera = &cam;
        job.integrator = f;
        job.integrator_state = state;
        job.filter = &rtk_conform_pixel_box;
        job.spp = 4;
        job.seed = 7;
        rtk_status s1 = a && b ? rtk_render_film(&job, a, &sa) : RTK_ERR_NOMEM;
        job.threads = 2;
        rtk_status s2 = s1 == RTK_OK ? rtk_render_film(&job, b, &sb) : s1;
        snprintf(name, sizeof name, "renders the standard scene [%s]", label);
        rtk_conform_check(r, s1 == RTK_OK && s2 == RTK_OK, name, "%s", rtk_error_message());
        if (s1 == RTK_OK && s2 == RTK_OK) {
            size_t nonfinite = 0, lit = 0;
            for (size_t i = 0; i < count; i += RTK_FILM_CHANNELS)
                for (int c = 0; c < 3; c++) {
                    if (!isfinite(a[i + (size_t)c]))
                        nonfinite++;
                    if (a[i + (size_t)c] > 0.0f)
                        lit++;
                }
            snprintf(name, sizeof name, "output is finite [%s]", label);
            rtk_conform_check(r, nonfinite == 0 && sa.bad_samples == 0, name,
                              "%zu non-finite pixel values, %llu NaN/Inf samples", nonfinite,
                              (unsigned long long)sa.bad_samples);
            if (emitters_only(p, label)) {
                snprintf(name, sizeof name, "output is black where the camera sees no emitter [%s, documented as "
                         "emitters only]", label);
                rtk_conform_check(r, lit == 0, name, "%zu pixel values are not zero", lit);
            } else {
                snprintf(name, sizeof name, "output is not all black on a lit scene [%s]", label);
                rtk_conform_check(r, lit > 0, name, "every pixel is zero");
            }
            snprintf(name, sizeof name, "same seed gives the same image on 1 and 2 threads [%s]", label);
            rtk_conform_check(r, memcmp(a, b, count * sizeof(float)) == 0, name, "images differ");
            snprintf(name, sizeof name, "traces rays through the kernel [%s]", label);
            rtk_conform_check(r, sa.rays > 0, name, "no ray was traced");
            if (f->size >= offsetof(rtk_integrator_fns, li_batch) + sizeof f->li_batch && f->li_batch)
                check_batches(r, &job, a, b, count, label);
            rtk_conform_device_program(r, f, state, scene, &job, a, b, count, label);
        }
        free(a);
        free(b);
    }
    rtk_scene_free(scene);
}

void rtk_conform_integrator(rtk_conform_runner *r, const rtk_plugin *p)
{
    const rtk_integrator_fns *f = p->functions;
    rtk_conform_each_variant(r, p, f->create, f->destroy, check_integrator);
    rtk_conform_profile(p, r->out, &r->passed, &r->failed);
}
