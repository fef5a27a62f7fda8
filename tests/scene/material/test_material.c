/* Materials (kernel/scene/material.c and the material inputs the loaders
 * keep, kernel/scene/io/obj.cpp and gltf.cpp):
 * - the hand-written files of data/ (one material per mapping rule, and
 *   out-of-range values) load with every input the BSDF mapping reads,
 *   and bad values come out clamped with a warning naming file, material
 *   and key;
 * - factor textures (map_Ks, map_Ns, map_Pr, map_Pm; glTF
 *   metallicRoughnessTexture, transmissionTexture, specularTexture,
 *   specularColorTexture) get their slot, channel, wrap and uv set, and are
 *   decoded only for integrators that read textures;
 * - rtk_surface_bsdf: every rule of include/rtk/bsdf.h on those materials
 *   gives the expected lobes, weights and parameters (expected values
 *   computed here from the files' numbers by the rules); textured factors
 *   read the left or right texel of 2 x 1 textures at the hit's uv, on a
 *   scene's own triangle and on an instance; the white furnace of a few
 *   results (mean f |cos| / pdf of rtk_bsdf_sample, 2 x 10^5 samples at
 *   3 angles) is <= 1 within 4 standard errors;
 * - every material of data/, ../shared/data/gltf-samples and the Assimp
 *   test models (each skipped with a line when absent) maps to weights in
 *   [0, 1] summing to at most 1, parameters in range, finite f and pdf. */
#include "scene/scene.h"
#include "image/image.h"

#include <rtk/bsdf.h>

#include <fcntl.h>
#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "scratch.h"
#include "capture.h"

#ifndef RTK_SOURCE_ROOT
#define RTK_SOURCE_ROOT "."
#endif

#define DATA RTK_SOURCE_ROOT "/tests/scene/material/data/"
#define ALL_NEEDS (RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS)

/* A w x 1 EXR whose texel x is rgba[4 x .. 4 x + 3]. */
static void write_strip(const char *name, int w, const float *rgba)
{
    static const char *const names[4] = {"R", "G", "B", "A"};
    if (rtk_image_write(in_tmp(name), w, 1, 4, names, rgba, 0) != RTK_OK) {
        printf("FAIL  cannot write %s: %s\n", name, rtk_error_message());
        exit(1);
    }
}

/* Whether one line of captured holds all of a, b and c. */
static int warned(const char *a, const char *b, const char *c)
{
    for (const char *line = captured; *line;) {
        const char *end = strchr(line, '\n');
        size_t n = end ? (size_t)(end - line) : strlen(line);
        char text[2048];
        snprintf(text, sizeof text, "%.*s", (int)n, line);
        if (strstr(text, a) && strstr(text, b) && strstr(text, c))
            return 1;
        line += n + (end ? 1 : 0);
    }
    return 0;
}

/* Loads path; its warnings go to captured (the input tests read them). */
static rtk_scene *load(const char *path, uint32_t needs)
{
    rtk_scene *s = NULL;
    int saved;
    capture_begin(&saved);
    rtk_status st = rtk_scene_load(path, needs, &s);
    capture_end(saved);
    if (st != RTK_OK) {
        printf("FAIL  load %s: %s\n", path, rtk_error_message());
        failed++;
        return NULL;
    }
    return s;
}

static const rtk_material *find(const rtk_scene *s, const char *name)
{
    for (uint32_t i = 0; s && i < s->material_count; i++)
        if (s->materials[i].name && strcmp(s->materials[i].name, name) == 0)
            return &s->materials[i];
    printf("FAIL  no material '%s'\n", name);
    failed++;
    return NULL;
}

static int near(float a, float b) { return fabsf(a - b) <= 1e-6f * fmaxf(1.0f, fabsf(b)); }
static int near_rgb(rtk_rgb c, float r, float g, float b) { return near(c.r, r) && near(c.g, g) && near(c.b, b); }

/* ---- the loaders keep the mapping's inputs ---- */

static void test_obj_inputs(void)
{
    rtk_scene *s = load(DATA "materials.obj", ALL_NEEDS);
    if (!s)
        return;
    check(s->material_count == 14 && s->tri_material[0] == RTK_INVALID_ID,
          "materials.obj: 14 materials, the first triangle without one");
    const rtk_material *m = find(s, "lambert0");
    check(m && m->model == RTK_MODEL_MTL && m->illum == 0 && m->has_illum && near_rgb(m->base_color, 0.8f, 0.2f, 0.1f),
          "lambert0: MTL model, illum 0 given, Kd");
    m = find(s, "noillum_ks");
    check(m && m->model == RTK_MODEL_MTL && !m->has_illum && near_rgb(m->specular, 0.2f, 0.2f, 0.2f) &&
              near(m->shininess, 18.0f),
          "noillum_ks: no illum line is told apart from illum 0; Ks, Ns kept");
    m = find(s, "glass4");
    check(m && m->illum == 4 && near(m->alpha, 0.25f) && near(m->ior, 1.33f) && m->has_filter &&
              near_rgb(m->filter, 0.9f, 0.95f, 1.0f),
          "glass4: d, Ni and Tf kept");
    m = find(s, "glass9_tr");
    check(m && m->illum == 9 && near(m->alpha, 0.4f) && !m->has_filter && near(m->ior, 1.6f),
          "glass9_tr: Tr 0.6 is d 0.4, no Tf");
    m = find(s, "pbr_metal");
    check(m && m->model == RTK_MODEL_METALLIC_ROUGHNESS && near(m->roughness, 0.5f) && near(m->metallic, 1.0f),
          "pbr_metal: Pr and Pm make it metallic-roughness");
    m = find(s, "pbr_dielectric");
    check(m && m->model == RTK_MODEL_METALLIC_ROUGHNESS && near(m->metallic, 0.0f) && near(m->ior, 1.45f),
          "pbr_dielectric: Pm 0, Ni kept");
    m = find(s, "out_of_range");
    check(m && near_rgb(m->base_color, 1.0f, 0.0f, 0.5f) && near_rgb(m->specular, 1.0f, 1.0f, 1.0f) &&
              near(m->shininess, 0.0f) && near(m->ior, 1.5f) && near(m->alpha, 1.0f),
          "out_of_range: Kd, Ks clamped to [0, 1], Ns to 0, Ni 0 gives 1.5, d to 1");
    const char *keys[] = {"Kd", "Ks", "Ns", "Ni", "d (or 1 - Tr)"};
    for (int k = 0; k < 5; k++)
        check(warned("materials.mtl", "material 'out_of_range'", keys[k]),
              "out_of_range: a warning names materials.mtl, the material and %s", keys[k]);
    check(!warned("lambert0", "", "") && !warned("glass4", "", ""), "valid materials give no warning");
    rtk_scene_free(s);
}

static void test_gltf_inputs(void)
{
    rtk_scene *s = load(DATA "materials.gltf", ALL_NEEDS);
    if (!s)
        return;
    check(s->material_count == 7, "materials.gltf: 7 materials (KHR_materials_specular required and supported)");
    const rtk_material *m = find(s, "metal");
    check(m && m->model == RTK_MODEL_METALLIC_ROUGHNESS && near(m->metallic, 1.0f) && near(m->roughness, 0.4f) &&
              near_rgb(m->base_color, 0.9f, 0.6f, 0.3f),
          "metal: metallic-roughness model, factors kept");
    m = find(s, "glass");
    check(m && near(m->transmission, 1.0f) && near(m->ior, 1.5f) && near(m->roughness, 0.0f),
          "glass: transmissionFactor and ior kept");
    m = find(s, "specular");
    check(m && near(m->specular_weight, 0.5f) && near_rgb(m->specular_color, 2.0f, 1.0f, 0.5f),
          "specular: specularFactor and specularColorFactor (above 1 allowed) kept");
    m = find(s, "half metal");
    check(m && near(m->specular_weight, 1.0f) && near_rgb(m->specular_color, 1.0f, 1.0f, 1.0f),
          "without KHR_materials_specular: specular 1, specular colour white");
    m = find(s, "out of range");
    check(m && near_rgb(m->base_color, 1.0f, 0.0f, 0.5f) && near(m->metallic, 1.0f) && near(m->roughness, 0.0f) &&
              near(m->transmission, 1.0f) && near(m->ior, 1.5f) && near(m->specular_weight, 0.0f) &&
              near_rgb(m->specular_color, 0.0f, 0.5f, 4.0f),
          "out of range: factors clamped to their ranges, ior below 1 gives 1.5");
    const char *keys[] = {"baseColorFactor", "metallicFactor", "roughnessFactor", "transmissionFactor", "ior",
                          "specularFactor", "specularColorFactor"};
    for (int k = 0; k < 7; k++)
        check(warned("materials.gltf", "material 6 'out of range'", keys[k]),
              "out of range: a warning names materials.gltf, the material and %s", keys[k]);
    check(!warned("'metal'", "", ""), "valid materials give no warning");
    rtk_scene_free(s);
}

/* ---- factor textures ---- */

/* Texels (left, right) of the factor textures the textured files use. */
static const float strip_a[8] = {0.2f, 0.25f, 1.0f, 0.5f, 1.0f, 1.0f, 0.0f, 1.0f};
static const float strip_b[8] = {0.5f, 0.1f, 0.9f, 0.3f, 0.8f, 0.6f, 0.4f, 0.7f};

static void write_textured_files(void)
{
    write_strip("a.exr", 2, strip_a);
    write_strip("b.exr", 2, strip_b);
    write_text("textured.mtl", "# map_Ks, map_Ns, map_Pr, map_Pm\n"
                               "newmtl mtl_maps\nillum 2\nKd 0.5 0.5 0.5\nKs 0.5 0.5 0.5\nNs 100\n"
                               "map_Ks b.exr\nmap_Ns -clamp on a.exr\n"
                               "newmtl pbr_maps\nKd 1 1 1\nPr 0.8\nmap_Pr -imfchan g a.exr\nmap_Pm b.exr\n");
    write_text("textured.obj", "mtllib textured.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                               "usemtl mtl_maps\nf 1/1 2/2 3/3\nusemtl pbr_maps\nf 1/1 2/2 3/3\n");
    /* One triangle, uvs (0, 0), (1, 0), (0, 1) in both sets. */
    static const char *const gltf =
        "{\"asset\": {\"version\": \"2.0\"},\n"
        " \"extensionsUsed\": [\"KHR_materials_transmission\", \"KHR_materials_specular\",\n"
        "   \"KHR_texture_transform\"],\n"
        " \"scene\": 0, %s,\n"
        " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1, \"TEXCOORD_1\": 1},"
        " \"material\": 0}]}],\n"
        " \"materials\": [{\"name\": \"gltf_maps\",\n"
        "   \"pbrMetallicRoughness\": {\"metallicFactor\": 0.5, \"roughnessFactor\": 1,\n"
        "     \"metallicRoughnessTexture\": {\"index\": 0}},\n"
        "   \"extensions\": {\n"
        "     \"KHR_materials_transmission\": {\"transmissionFactor\": 1, \"transmissionTexture\": {\"index\": 1, "
        "\"texCoord\": 1}},\n"
        "     \"KHR_materials_specular\": {\"specularTexture\": {\"index\": 1},\n"
        "       \"specularColorTexture\": {\"index\": 2, \"extensions\": {\"KHR_texture_transform\": "
        "{\"offset\": [0.5, 0]}}}}}}],\n"
        " \"textures\": [{\"source\": 0, \"sampler\": 0}, {\"source\": 1}, {\"source\": 1}],\n"
        " \"samplers\": [{\"wrapS\": 33071, \"wrapT\": 33648}],\n"
        " \"images\": [{\"uri\": \"a.exr\"}, {\"uri\": \"b.exr\"}],\n"
        " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", "
        "\"min\": [0, 0, 0], \"max\": [1, 1, 0]},\n"
        "   {\"bufferView\": 1, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"}],\n"
        " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}, {\"buffer\": 0, \"byteOffset\": 36, \"byteLength\": "
        "24}],\n"
        " \"buffers\": [{\"byteLength\": 60, \"uri\": \"data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/\"}]}\n";
    char text[4096];
    snprintf(text, sizeof text, gltf, "\"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": 0}]");
    write_text("textured.gltf", text);
    /* The same mesh placed twice: instanced, with the textures shared. */
    snprintf(text, sizeof text, gltf,
             "\"scenes\": [{\"nodes\": [0, 1]}],\n"
             " \"nodes\": [{\"mesh\": 0}, {\"mesh\": 0, \"translation\": [3, 0, 0]}]");
    write_text("instanced.gltf", text);
}

static void test_texture_slots(void)
{
    rtk_scene *s = load(in_tmp("textured.obj"), ALL_NEEDS);
    if (s) {
        const rtk_material *m = find(s, "mtl_maps"), *p = find(s, "pbr_maps");
        const rtk_tex_slot *ks = m ? &m->maps[RTK_MAP_SPECULAR_COLOR] : NULL;
        const rtk_tex_slot *ns = m ? &m->maps[RTK_MAP_SHININESS] : NULL;
        check(ks && ks->tex >= 0 && s->textures[ks->tex].srgb && ns->tex >= 0 && !s->textures[ns->tex].srgb &&
                  ns->channel == 0 && ns->wrap.s == RTK_WRAP_CLAMP && ns->wrap.t == RTK_WRAP_CLAMP &&
                  ks->wrap.s == RTK_WRAP_REPEAT,
              "map_Ks (colour, sRGB) and map_Ns (data, first channel, -clamp on) get their slots");
        check(m && m->model == RTK_MODEL_MTL && m->maps[RTK_MAP_ROUGHNESS].tex == -1, "mtl_maps stays MTL");
        const rtk_tex_slot *pr = p ? &p->maps[RTK_MAP_ROUGHNESS] : NULL, *pm = p ? &p->maps[RTK_MAP_METALLIC] : NULL;
        check(p && p->model == RTK_MODEL_METALLIC_ROUGHNESS && pr->tex >= 0 && pr->channel == 1 && pm->tex >= 0 &&
                  pm->channel == 0 && near(p->metallic, 1.0f) && near(p->roughness, 0.8f),
              "map_Pr (-imfchan g) and map_Pm alone: metallic-roughness, map_Pm's factor 1");
        check(ks && s->textures[ks->tex].decoded && s->textures[pr->tex].decoded,
              "factor textures are decoded for an integrator that reads textures");
        rtk_scene_free(s);
    }
    s = load(in_tmp("textured.obj"), RTK_NEED_MATERIALS);
    if (s) {
        int any = 0;
        for (uint32_t i = 0; i < s->texture_count; i++)
            any |= s->textures[i].decoded;
        check(!any, "and not decoded for one that does not");
        rtk_scene_free(s);
    }
    s = load(in_tmp("textured.gltf"), ALL_NEEDS);
    if (s) {
        const rtk_material *m = find(s, "gltf_maps");
        if (m) {
            const rtk_tex_slot *r = &m->maps[RTK_MAP_ROUGHNESS], *mt = &m->maps[RTK_MAP_METALLIC];
            const rtk_tex_slot *t = &m->maps[RTK_MAP_TRANSMISSION], *sp = &m->maps[RTK_MAP_SPECULAR];
            const rtk_tex_slot *sc = &m->maps[RTK_MAP_SPECULAR_COLOR];
            check(r->tex >= 0 && r->tex == mt->tex && r->channel == 1 && mt->channel == 2 &&
                      r->wrap.s == RTK_WRAP_CLAMP && mt->wrap.t == RTK_WRAP_MIRROR && !s->textures[r->tex].srgb,
                  "metallicRoughnessTexture: one texture, G roughness and B metallic, its sampler's wraps, linear");
            check(t->tex >= 0 && t->channel == 0 && t->uv.set == 1 && sp->tex == t->tex && sp->channel == 3 &&
                      sp->uv.set == 0,
                  "transmissionTexture (R, TEXCOORD_1) and specularTexture (A) get their slots");
            check(sc->tex >= 0 && sc->tex != t->tex && s->textures[sc->tex].srgb && sc->uv.transformed &&
                      near(sc->uv.m[2], 0.5f),
                  "specularColorTexture: sRGB, with its KHR_texture_transform");
        }
        rtk_scene_free(s);
    }
}

/* ---- the mapping ---- */

static rtk_rgb grey(double v) { return rtk_rgb_make((float)v, (float)v, (float)v); }
static rtk_rgb rgb(double r, double g, double b) { return rtk_rgb_make((float)r, (float)g, (float)b); }

/* The MTL rule's GGX alpha for Phong exponent ns. */
static float phong_alpha(double ns) { return (float)sqrt(2.0 / (ns + 2.0)); }
/* Schlick's f0 of a dielectric of index ior. */
static double dielectric_f0(double ior) { return ((ior - 1.0) / (ior + 1.0)) * ((ior - 1.0) / (ior + 1.0)); }

/* A mixture of up to 3 lobes with grey weights (weight <= 0 ends it). */
static rtk_bsdf mix(double w0, rtk_lobe l0, double w1, rtk_lobe l1, double w2, rtk_lobe l2)
{
    rtk_bsdf b;
    memset(&b, 0, sizeof b);
    const double w[3] = {w0, w1, w2};
    const rtk_lobe l[3] = {l0, l1, l2};
    for (int i = 0; i < 3 && w[i] > 0.0; i++)
        rtk_bsdf_add(&b, grey(w[i]), l[i]);
    return b;
}
static rtk_bsdf one(rtk_lobe l) { return rtk_bsdf_of(l); }
static const rtk_lobe none = {0};

static int close_to(float a, float b) { return fabsf(a - b) <= 2e-6f * fmaxf(1.0f, fabsf(b)); }
static int close_rgb(rtk_rgb a, rtk_rgb b) { return close_to(a.r, b.r) && close_to(a.g, b.g) && close_to(a.b, b.b); }

static const char *const lobe_names[] = {"lambert", "oren-nayar", "ggx", "dielectric", "rough dielectric", "plastic"};

static const char *lobe_name(rtk_lobe_type t)
{
    return (unsigned)t < sizeof lobe_names / sizeof lobe_names[0] ? lobe_names[t] : "?";
}

/* Writes b's lobes, weights and parameters into text. */
static void describe(const rtk_bsdf *b, char *text, size_t n)
{
    size_t at = (size_t)snprintf(text, n, "%u lobes:", b->count);
    for (uint32_t i = 0; i < b->count && i < RTK_BSDF_MAX_LOBES && at < n; i++) {
        const rtk_lobe *l = &b->lobe[i];
        at += (size_t)snprintf(text + at, n - at,
                               " [%.4g %s albedo (%.4g %.4g %.4g) f0 (%.4g %.4g %.4g) alpha %.4g ior %.4g tint (%.4g "
                               "%.4g %.4g)]",
                               (double)b->weight[i].r, lobe_name(l->type), (double)l->albedo.r, (double)l->albedo.g,
                               (double)l->albedo.b, (double)l->f0.r, (double)l->f0.g, (double)l->f0.b,
                               (double)l->alpha, (double)l->ior, (double)l->tint.r, (double)l->tint.g,
                               (double)l->tint.b);
    }
}

/* Whether got has want's lobes in order, with its weights and every
 * parameter. */
static int same_bsdf(const rtk_bsdf *got, const rtk_bsdf *want)
{
    if (got->count != want->count)
        return 0;
    for (uint32_t i = 0; i < got->count; i++) {
        const rtk_lobe *a = &got->lobe[i], *b = &want->lobe[i];
        if (!close_rgb(got->weight[i], want->weight[i]) || a->type != b->type || !close_rgb(a->albedo, b->albedo) ||
            !close_to(a->sigma, b->sigma) || !close_to(a->alpha, b->alpha) || a->fresnel != b->fresnel ||
            !close_rgb(a->f0, b->f0) || !close_rgb(a->eta, b->eta) || !close_rgb(a->k, b->k) ||
            !close_to(a->ior, b->ior) || !close_rgb(a->tint, b->tint))
            return 0;
    }
    return 1;
}

static int in01(float v) { return v >= 0.0f && v <= 1.0f; }
static int rgb01(rtk_rgb c) { return in01(c.r) && in01(c.g) && in01(c.b); }

/* Whether b keeps the mapping's promises: 1 to 4 lobes, weights in [0, 1]
 * summing to at most 1 per channel, parameters in their ranges, and
 * finite f and pdf at a few directions; why says what broke. */
static int in_ranges(const rtk_bsdf *b, const char **why)
{
    *why = "lobe count";
    if (b->count < 1 || b->count > RTK_BSDF_MAX_LOBES)
        return 0;
    double sum[3] = {0, 0, 0};
    for (uint32_t i = 0; i < b->count; i++) {
        const rtk_lobe *l = &b->lobe[i];
        *why = "weight outside [0, 1]";
        if (!rgb01(b->weight[i]))
            return 0;
        sum[0] += b->weight[i].r, sum[1] += b->weight[i].g, sum[2] += b->weight[i].b;
        int ok = 1;
        switch (l->type) {
        case RTK_LOBE_LAMBERT: ok = rgb01(l->albedo); break;
        case RTK_LOBE_GGX: ok = l->fresnel == RTK_FRESNEL_SCHLICK && rgb01(l->f0); break;
        case RTK_LOBE_PLASTIC: ok = rgb01(l->albedo) && rgb01(l->f0); break;
        case RTK_LOBE_DIELECTRIC:
        case RTK_LOBE_ROUGH_DIELECTRIC: ok = isfinite(l->ior) && l->ior > 0.0f && rgb01(l->tint); break;
        default: ok = 0;
        }
        *why = "albedo, f0, tint or ior outside its range";
        if (!ok)
            return 0;
        *why = "alpha outside [RTK_GGX_ALPHA_MIN, 1]";
        if ((l->type == RTK_LOBE_GGX || l->type == RTK_LOBE_PLASTIC || l->type == RTK_LOBE_ROUGH_DIELECTRIC) &&
            !(l->alpha >= RTK_GGX_ALPHA_MIN && l->alpha <= 1.0f))
            return 0;
    }
    *why = "weights sum above 1";
    if (sum[0] > 1.0 + 1e-6 || sum[1] > 1.0 + 1e-6 || sum[2] > 1.0 + 1e-6)
        return 0;
    const rtk_vec3 dirs[3] = {{0.0f, 0.0f, 1.0f}, {0.6f, 0.0f, 0.8f}, {0.0f, -0.6f, -0.8f}};
    *why = "non-finite f or pdf";
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            rtk_rgb f = rtk_bsdf_eval(b, dirs[i], dirs[j]);
            float pdf = rtk_bsdf_pdf(b, dirs[i], dirs[j]);
            if (!isfinite(f.r) || !isfinite(f.g) || !isfinite(f.b) || !isfinite(pdf))
                return 0;
        }
    return 1;
}

/* The surface and BSDF of triangle prim (of instance inst, or
 * RTK_INVALID_ID) at barycentrics (u, v), seen along -z. */
static rtk_bsdf bsdf_at(const rtk_scene *s, uint32_t inst, uint32_t prim, float u, float v, rtk_surface *sf)
{
    rtk_hit hit = {1.0f, u, v, prim, inst};
    rtk_ray ray = {{0.0f, 0.0f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
    rtk_surface local;
    if (!sf)
        sf = &local;
    rtk_surface_at(s, &ray, &hit, sf);
    rtk_bsdf b;
    rtk_surface_bsdf(s, &hit, sf, &b);
    return b;
}

/* The first of s's own triangles with material name (NULL: none). */
static uint32_t triangle_of(const rtk_scene *s, const char *name)
{
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        uint32_t m = s->tri_material[t];
        if (name ? m < s->material_count && strcmp(s->materials[m].name, name) == 0 : m == RTK_INVALID_ID)
            return t;
    }
    printf("FAIL  no triangle with material %s\n", name ? name : "(none)");
    failed++;
    return 0;
}

/* Checks that material name of s (NULL: none) at barycentrics (u, v)
 * maps to want, within the ranges; rule says which rule. */
static void expect(const rtk_scene *s, const char *name, float u, float v, rtk_bsdf want, const char *rule)
{
    rtk_bsdf got = bsdf_at(s, RTK_INVALID_ID, triangle_of(s, name), u, v, NULL);
    const char *why;
    int ok = same_bsdf(&got, &want) && in_ranges(&got, &why);
    char text[2048];
    describe(&got, text, sizeof text);
    check(ok, "%s: %s: %s", name ? name : "no material", rule, ok ? text : "");
    if (!ok) {
        printf("      got  %s\n", text);
        describe(&want, text, sizeof text);
        printf("      want %s\n", text);
    }
}

static void test_mtl_rules(void)
{
    rtk_scene *s = load(DATA "materials.obj", ALL_NEEDS);
    if (!s)
        return;
    const rtk_rgb white = grey(1);
    expect(s, NULL, 0.2f, 0.2f, one(rtk_lobe_lambert(white)), "no material is Lambert(white)");
    expect(s, "lambert0", 0.2f, 0.2f, one(rtk_lobe_lambert(rgb(0.8, 0.2, 0.1))), "illum 0 is Lambert(Kd), Ks unused");
    expect(s, "lambert1", 0.2f, 0.2f, one(rtk_lobe_lambert(grey(0.5))), "illum 1 is Lambert(Kd)");
    expect(s, "plastic2", 0.2f, 0.2f, one(rtk_lobe_plastic(rgb(0.6, 0.3, 0.2), grey(0.04), phong_alpha(98))),
           "illum 2 is plastic(Kd, Ks, sqrt(2 / (Ns + 2)))");
    expect(s, "noillum_ks", 0.2f, 0.2f, one(rtk_lobe_plastic(grey(0.4), grey(0.2), phong_alpha(18))),
           "no illum with Ks > 0 is illum 2");
    expect(s, "noillum_noks", 0.2f, 0.2f, one(rtk_lobe_lambert(grey(0.3))), "no illum with Ks = 0 is Lambert(Kd)");
    expect(s, "mirror3", 0.2f, 0.2f, one(rtk_lobe_plastic(grey(0.1), grey(0.8), phong_alpha(1000))),
           "illum 3 is illum 2");
    expect(s, "metal5", 0.2f, 0.2f, one(rtk_lobe_ggx_schlick(rgb(0.9, 0.6, 0.3), phong_alpha(200))),
           "illum 5 is ggx_schlick(Ks, alpha)");
    expect(s, "glass4", 0.2f, 0.2f,
           mix(0.25, rtk_lobe_plastic(grey(0.9), grey(0.1), phong_alpha(50)), 0.75,
               rtk_lobe_rough_dielectric(1.33f, phong_alpha(50), rgb(0.9, 0.95, 1.0)), 0, none),
           "illum 4 is d x plastic + (1 - d) x rough dielectric(Ni, alpha, Tf)");
    expect(s, "glass7", 0.2f, 0.2f,
           mix(0.5, rtk_lobe_lambert(rgb(0.5, 0.6, 0.7)), 0.5, rtk_lobe_dielectric(1.5f, rgb(0.5, 0.6, 0.7)), 0, none),
           "illum 7 with Ks 0 and alpha at its minimum: Lambert + smooth dielectric tinted Kd");
    expect(s, "ks0_2", 0.2f, 0.2f, one(rtk_lobe_lambert(rgb(0.2, 0.5, 0.2))), "illum 2 with Ks = 0 is Lambert(Kd)");
    expect(s, "pbr_metal", 0.2f, 0.2f, one(rtk_lobe_ggx_schlick(rgb(0.9, 0.8, 0.7), 0.25f)),
           "Pm 1: ggx_schlick(Kd, Pr^2)");
    expect(s, "pbr_dielectric", 0.2f, 0.2f,
           one(rtk_lobe_plastic(rgb(0.3, 0.6, 0.3), grey(dielectric_f0(1.45)), 0.09f)),
           "Pm 0: plastic(Kd, ((Ni - 1) / (Ni + 1))^2, Pr^2)");
    expect(s, "out_of_range", 0.2f, 0.2f, one(rtk_lobe_plastic(rgb(1, 0, 0.5), white, 1.0f)),
           "clamped inputs: plastic(Kd in [0, 1], Ks 1, Ns 0 -> alpha 1)");
    expect(s, "glass9_tr", 0.2f, 0.2f,
           mix(0.4, rtk_lobe_plastic(grey(0.8), grey(0.05), phong_alpha(400)), 0.6,
               rtk_lobe_rough_dielectric(1.6f, phong_alpha(400), grey(0.8)), 0, none),
           "illum 9 with Tr 0.6: tinted Kd without Tf");
    rtk_scene_free(s);
    /* Without RTK_NEED_MATERIALS the surface is neutral, and so is its BSDF. */
    s = load(DATA "materials.obj", RTK_NEED_NORMALS);
    if (s) {
        rtk_bsdf b = bsdf_at(s, RTK_INVALID_ID, 3, 0.2f, 0.2f, NULL);
        rtk_bsdf want = one(rtk_lobe_lambert(white));
        check(same_bsdf(&b, &want), "a scene loaded without materials maps to Lambert(white)");
        rtk_scene_free(s);
    }
}

static void test_gltf_rules(void)
{
    rtk_scene *s = load(DATA "materials.gltf", ALL_NEEDS);
    if (!s)
        return;
    const rtk_rgb white = grey(1);
    expect(s, "metal", 0.2f, 0.2f, one(rtk_lobe_ggx_schlick(rgb(0.9, 0.6, 0.3), 0.16f)),
           "metallic 1: ggx_schlick(base, roughness^2)");
    expect(s, "dielectric", 0.2f, 0.2f, one(rtk_lobe_plastic(rgb(0.2, 0.4, 0.8), grey(0.04), 0.25f)),
           "metallic 0: plastic(base, 0.04, roughness^2)");
    expect(s, "half metal", 0.2f, 0.2f,
           mix(0.3, rtk_lobe_ggx_schlick(grey(0.5), 0.49f), 0.7, rtk_lobe_plastic(grey(0.5), grey(0.04), 0.49f), 0,
               none),
           "metallic 0.3: 0.3 ggx + 0.7 plastic");
    expect(s, "glass", 0.2f, 0.2f, one(rtk_lobe_dielectric(1.5f, rgb(0.9, 1.0, 0.8))),
           "transmission 1, roughness 0: smooth dielectric tinted by the base colour");
    expect(s, "rough glass", 0.2f, 0.2f,
           mix(0.2, rtk_lobe_ggx_schlick(white, 0.09f), 0.8 * 0.4,
               rtk_lobe_plastic(white, grey(dielectric_f0(1.33)), 0.09f), 0.8 * 0.6,
               rtk_lobe_rough_dielectric(1.33f, 0.09f, white)),
           "m ggx + (1-m)(1-t) plastic + (1-m) t rough dielectric");
    expect(s, "specular", 0.2f, 0.2f,
           one(rtk_lobe_plastic(grey(0.7), rgb(0.04 * 2.0 * 0.5, 0.04 * 1.0 * 0.5, 0.04 * 0.5 * 0.5), 0.36f)),
           "KHR_materials_specular: f0 = min(0.04 x specularColor, 1) x specular");
    expect(s, "out of range", 0.2f, 0.2f, one(rtk_lobe_ggx_schlick(rgb(1, 0, 0.5), RTK_GGX_ALPHA_MIN)),
           "clamped inputs: metallic 1, roughness 0 gives the smallest alpha");
    expect(s, NULL, 0.2f, 0.2f, one(rtk_lobe_lambert(white)), "a primitive without material is Lambert(white)");
    rtk_scene_free(s);
}

/* Barycentrics (u, 0.1) of the textured triangles read texel column u:
 * 0.25 the left texel of the 2 x 1 strips, 0.75 the right one. */
static void test_textured_rules(void)
{
    rtk_scene *s = load(in_tmp("textured.obj"), ALL_NEEDS);
    if (s) {
        expect(s, "mtl_maps", 0.25f, 0.1f,
               one(rtk_lobe_plastic(grey(0.5), rgb(0.5 * strip_b[0], 0.5 * strip_b[1], 0.5 * strip_b[2]),
                                    phong_alpha(100 * strip_a[0]))),
               "left texel: Ks x map_Ks, Ns x map_Ns");
        expect(s, "mtl_maps", 0.75f, 0.1f,
               one(rtk_lobe_plastic(grey(0.5), rgb(0.5 * strip_b[4], 0.5 * strip_b[5], 0.5 * strip_b[6]),
                                    phong_alpha(100 * strip_a[4]))),
               "right texel: Ks x map_Ks, Ns x map_Ns");
        double r = 0.8 * strip_a[1], m = strip_b[0];
        expect(s, "pbr_maps", 0.25f, 0.1f,
               mix(m, rtk_lobe_ggx_schlick(grey(1), (float)(r * r)), 1 - m,
                   rtk_lobe_plastic(grey(1), grey(0.04), (float)(r * r)), 0, none),
               "left texel: Pr x map_Pr's G (-imfchan g), map_Pm");
        r = 0.8 * strip_a[5], m = strip_b[4];
        expect(s, "pbr_maps", 0.75f, 0.1f,
               mix(m, rtk_lobe_ggx_schlick(grey(1), (float)(r * r)), 1 - m,
                   rtk_lobe_plastic(grey(1), grey(0.04), (float)(r * r)), 0, none),
               "right texel: Pr x map_Pr's G, map_Pm");
        rtk_scene_free(s);
    }
    s = load(in_tmp("textured.obj"), RTK_NEED_MATERIALS | RTK_NEED_UVS);
    if (s) {
        expect(s, "mtl_maps", 0.25f, 0.1f, one(rtk_lobe_plastic(grey(0.5), grey(0.5), phong_alpha(100))),
               "without RTK_NEED_TEXTURES the factors alone");
        rtk_scene_free(s);
    }
    const char *files[2] = {"textured.gltf", "instanced.gltf"};
    for (int f = 0; f < 2; f++) {
        s = load(in_tmp(files[f]), ALL_NEEDS);
        if (!s)
            continue;
        const int inst = f == 1;
        for (int side = 0; side < 2; side++) {
            const float *a = strip_a + 4 * side, *b = strip_b + 4 * side, *b_shift = strip_b + 4 * (1 - side);
            double rough = a[1], metal = 0.5 * a[2], t = b[0], weight = b[3];
            rtk_rgb f0 = rgb(0.04 * b_shift[0] * weight, 0.04 * b_shift[1] * weight, 0.04 * b_shift[2] * weight);
            float alpha = (float)(rough * rough);
            rtk_bsdf want = mix(metal, rtk_lobe_ggx_schlick(grey(1), alpha), (1 - metal) * (1 - t),
                                rtk_lobe_plastic(grey(1), f0, alpha), (1 - metal) * t,
                                rtk_lobe_rough_dielectric(1.5f, alpha, grey(1)));
            if (metal <= 0.0)
                want = mix((1 - metal) * (1 - t), rtk_lobe_plastic(grey(1), f0, alpha), (1 - metal) * t,
                           rtk_lobe_rough_dielectric(1.5f, alpha, grey(1)), 0, none);
            rtk_bsdf got = bsdf_at(s, inst ? 1 : RTK_INVALID_ID, 0, side ? 0.75f : 0.25f, 0.1f, NULL);
            char text[2048];
            describe(&got, text, sizeof text);
            check(same_bsdf(&got, &want),
                  "%s, %s texel%s: metallicRoughnessTexture G and B, transmissionTexture R (TEXCOORD_1), "
                  "specularTexture A, specularColorTexture RGB through its transform: %s",
                  files[f], side ? "right" : "left", inst ? " (a hit on instance 1)" : "", text);
        }
        rtk_scene_free(s);
    }
}

/* ---- white furnace ---- */

static uint64_t rng_state;
static double rnd(void)
{
    rng_state += 0x9E3779B97F4A7C15ull;
    uint64_t z = rng_state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (double)((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
}

/* Directional albedo of b for wo, per channel, from n samples: the mean
 * path weight f |wi.z| / pdf; se the standard error of its largest channel. */
static void albedo(const rtk_bsdf *b, rtk_vec3 wo, int n, double out[3], double *se)
{
    double sum[3] = {0, 0, 0}, sq = 0.0;
    for (int i = 0; i < n; i++) {
        rtk_bsdf_sample_out so;
        rtk_vec2 u = {(float)rnd(), (float)rnd()};
        float ul = (float)rnd();
        double w[3] = {0, 0, 0};
        if (rtk_bsdf_sample(b, wo, ul < 1.0f ? ul : 0.99999994f, u, &so) && so.pdf > 0.0f) {
            double c = fabs((double)so.wi.z) / so.pdf;
            w[0] = so.f.r * c, w[1] = so.f.g * c, w[2] = so.f.b * c;
        }
        double m = fmax(w[0], fmax(w[1], w[2]));
        sq += m * m;
        for (int k = 0; k < 3; k++)
            sum[k] += w[k];
    }
    for (int k = 0; k < 3; k++)
        out[k] = sum[k] / n;
    double mean = fmax(out[0], fmax(out[1], out[2]));
    *se = sqrt(fmax(sq / n - mean * mean, 0.0) / n);
}

/* The white furnace of a few mapped materials, with every colour input
 * pushed to 1 where a file allows: the directional albedo at 3 angles
 * stays <= 1 within 4 standard errors. */
static void test_furnace(void)
{
    static const struct {
        const char *file, *material;
    } cases[] = {{"materials.obj", "plastic2"},  {"materials.obj", "glass4"},       {"materials.obj", "glass9_tr"},
                 {"materials.obj", "out_of_range"}, {"materials.gltf", "half metal"}, {"materials.gltf", "rough glass"},
                 {"materials.gltf", "glass"},    {"materials.gltf", "out of range"}};
    const int n = 200000;
    const float cosines[3] = {1.0f, 0.5f, 0.1f};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char path[512];
        snprintf(path, sizeof path, "%s%s", DATA, cases[c].file);
        rtk_scene *s = load(path, ALL_NEEDS);
        if (!s)
            continue;
        rtk_bsdf b = bsdf_at(s, RTK_INVALID_ID, triangle_of(s, cases[c].material), 0.2f, 0.2f, NULL);
        rng_state = 12345 + c;
        double worst = 0.0, worst_se = 0.0, a[3], se;
        int ok = 1;
        for (int k = 0; k < 3; k++) {
            float z = cosines[k];
            albedo(&b, rtk_vec3_make(sqrtf(1.0f - z * z), 0.0f, z), n, a, &se);
            double m = fmax(a[0], fmax(a[1], a[2]));
            ok &= m <= 1.0 + 4.0 * se + 1e-6;
            if (m > worst)
                worst = m, worst_se = se;
        }
        check(ok, "%s %s: white furnace <= 1 at cos 1, 0.5, 0.1 (largest %.5f +- %.5f, %d samples each)",
              cases[c].file, cases[c].material, worst, worst_se, n);
        rtk_scene_free(s);
    }
}

/* ---- corpora ---- */

static int corpus_files, corpus_materials, corpus_bad;

/* Maps up to 8 triangles of every material of s (and of its instanced
 * meshes, through their first instance) and checks the ranges. */
static void check_scene_materials(const char *path, const rtk_scene *s)
{
    for (uint32_t part = 0; part <= s->instance_count; part++) {
        uint32_t inst = part == 0 ? RTK_INVALID_ID : part - 1;
        const rtk_scene *ms = part == 0 ? s : s->meshes[s->instances[inst].mesh];
        if (part > 0) {
            uint32_t first = 0;
            while (s->instances[first].mesh != s->instances[inst].mesh)
                first++;
            if (first != inst)
                continue;
        }
        uint32_t mats = ms->material_count + 1;
        unsigned *seen = calloc(mats, sizeof *seen);
        for (uint32_t t = 0; seen && t < ms->triangle_count; t++) {
            uint32_t m = ms->tri_material ? ms->tri_material[t] : RTK_INVALID_ID;
            uint32_t slot = m < ms->material_count ? m : ms->material_count;
            if (seen[slot]++ >= 8)
                continue;
            if (seen[slot] == 1)
                corpus_materials++;
            const float bary[8][2] = {{0.2f, 0.2f}, {0, 0}, {1, 0}, {0, 1}, {0.5f, 0.5f}, {0.1f, 0.7f},
                                      {0.6f, 0.1f}, {0.33f, 0.33f}};
            const float *uv = bary[(seen[slot] - 1) & 7];
            rtk_bsdf b = bsdf_at(s, inst, t, uv[0], uv[1], NULL);
            const char *why;
            if (!in_ranges(&b, &why) && corpus_bad++ < 20) {
                char text[2048];
                describe(&b, text, sizeof text);
                printf("FAIL  %s: triangle %u (material %s): %s: %s\n", path, t,
                       m < ms->material_count && ms->materials[m].name ? ms->materials[m].name : "(none)", why, text);
            }
        }
        free(seen);
    }
}

static int corpus_visit(const char *path, const struct stat *st, int type, struct FTW *ftw)
{
    (void)st;
    (void)ftw;
    const char *ext = strrchr(path, '.');
    if (type != FTW_F || !ext || (strcasecmp(ext, ".obj") != 0 && strcasecmp(ext, ".glb") != 0 &&
                                  strcasecmp(ext, ".gltf") != 0))
        return 0;
    int saved;
    rtk_scene *s = NULL;
    capture_begin(&saved);
    rtk_status loaded = rtk_scene_load(path, ALL_NEEDS, &s);
    capture_end(saved);
    if (loaded != RTK_OK)
        return 0; /* the loader tests check refusals; this one checks what loads */
    corpus_files++;
    check_scene_materials(path, s);
    rtk_scene_free(s);
    return 0;
}

/* Every material of the corpora maps within ranges, NaN-free. */
static void test_corpora(void)
{
    static const char *const folders[] = {RTK_SOURCE_ROOT "/tests/scene/material/data",
                                          RTK_SOURCE_ROOT "/../shared/data/gltf-samples",
                                          "/usr/share/assimp-testmodels", "/usr/share/assimp/models"};
    for (size_t f = 0; f < sizeof folders / sizeof folders[0]; f++) {
        struct stat st;
        if (stat(folders[f], &st) != 0 || !S_ISDIR(st.st_mode)) {
            printf("skip  %s is absent: its materials are not checked\n", folders[f]);
            continue;
        }
        corpus_files = corpus_materials = corpus_bad = 0;
        nftw(folders[f], corpus_visit, 16, FTW_PHYS);
        check(corpus_bad == 0 && corpus_files > 0,
              "%s: every material of %d loaded files (%d materials) maps within ranges, NaN-free", folders[f],
              corpus_files, corpus_materials);
    }
}

int main(void)
{
    scratch_begin("rtk-material");
    write_textured_files();
    test_obj_inputs();
    test_gltf_inputs();
    test_texture_slots();
    test_mtl_rules();
    test_gltf_rules();
    test_textured_rules();
    test_furnace();
    test_corpora();
    scratch_end();
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
