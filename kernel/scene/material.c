/* Materials: the values loaders store (checked and clamped here, with a
 * warning naming the file and material), and their mapping to a BSDF
 * (rtk_surface_bsdf, documented in include/rtk/bsdf.h and README.md). */
#include "scene.h"

#include <rtk/bsdf.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

float rtk_material_value(const char *path, const char *material, const char *key, double v, float fallback, float lo,
                         float hi)
{
    if (!isfinite(v)) {
        rtk_log(RTK_LOG_WARN, "%s: %s: %s is not a finite number; using %g", path, material, key, (double)fallback);
        return fallback;
    }
    if (v < lo || v > hi) {
        float bound = v < lo ? lo : hi;
        rtk_log(RTK_LOG_WARN, "%s: %s: %s is %g, %s %g; using %g", path, material, key, v,
                v < lo ? "below" : "above", (double)bound, (double)bound);
        return bound;
    }
    return (float)v;
}

rtk_rgb rtk_material_rgb(const char *path, const char *material, const char *key, double r, double g, double b,
                         rtk_rgb fallback, float lo, float hi)
{
    const double in[3] = {r, g, b};
    const float fb[3] = {fallback.r, fallback.g, fallback.b};
    float out[3];
    int bad = 0;
    for (int k = 0; k < 3; k++) {
        bad |= !isfinite(in[k]) || in[k] < lo || in[k] > hi;
        out[k] = !isfinite(in[k]) ? fb[k] : in[k] < lo ? lo : in[k] > hi ? hi : (float)in[k];
    }
    if (bad) {
        char range[64];
        if (hi < FLT_MAX)
            snprintf(range, sizeof range, "within [%g, %g]", (double)lo, (double)hi);
        else
            snprintf(range, sizeof range, "at least %g", (double)lo);
        rtk_log(RTK_LOG_WARN, "%s: %s: %s is (%g, %g, %g), not all finite and %s; using (%g, %g, %g)", path, material,
                key, r, g, b, range, (double)out[0], (double)out[1], (double)out[2]);
    }
    return rtk_rgb_make(out[0], out[1], out[2]);
}

static float clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

static rtk_rgb clamp_rgb(rtk_rgb c) { return rtk_rgb_make(clamp01(c.r), clamp01(c.g), clamp01(c.b)); }

static rtk_rgb grey(float v) { return rtk_rgb_make(v, v, v); }

/* Where a hit's factor textures are read: the triangle's scene (the
 * instanced mesh for a hit on an instance), triangle and barycentrics;
 * on is 0 when that scene keeps no decoded textures. */
typedef struct factor_reader {
    const rtk_scene *scene;
    const rtk_material *m;
    uint32_t prim;
    float u, v;
    int on;
} factor_reader;

/* The texel of m's map k at the hit, at the finest level; 0 when the slot
 * has no decoded texture. */
static int read_map(const factor_reader *r, rtk_material_map k, float texel[4])
{
    const rtk_tex_slot *slot = &r->m->maps[k];
    const rtk_scene *s = r->scene;
    if (!r->on || slot->tex < 0 || (uint32_t)slot->tex >= s->texture_count || !s->textures[slot->tex].decoded)
        return 0;
    rtk_vec2 uv = rtk_tex_map_uv(s, &slot->uv, r->prim, r->u, r->v);
    rtk_texture_sample(&s->textures[slot->tex], slot->wrap, uv.x, uv.y, 0.0f, texel);
    return 1;
}

/* factor x map k's channel at the hit (factor alone without the map). */
static float scalar_factor(const factor_reader *r, rtk_material_map k, float factor)
{
    float texel[4];
    return read_map(r, k, texel) ? factor * texel[r->m->maps[k].channel & 3] : factor;
}

/* factor x map k's RGB at the hit. */
static rtk_rgb colour_factor(const factor_reader *r, rtk_material_map k, rtk_rgb factor)
{
    float texel[4];
    return read_map(r, k, texel) ? rtk_rgb_mul(factor, rtk_rgb_make(texel[0], texel[1], texel[2])) : factor;
}

/* MTL illumination models with transparency (refraction or glass). */
static int transparent_illum(int illum) { return illum == 4 || illum == 6 || illum == 7 || illum == 9; }

/* The transmission lobe: smooth where alpha is at its minimum. */
static rtk_lobe transmission_lobe(float ior, float alpha, rtk_rgb tint)
{
    return alpha <= RTK_GGX_ALPHA_MIN ? rtk_lobe_dielectric(ior, tint) : rtk_lobe_rough_dielectric(ior, alpha, tint);
}

static void metallic_roughness(const factor_reader *r, const rtk_surface *s, rtk_rgb base, float ior, rtk_bsdf *out)
{
    const rtk_material *m = r->m;
    float metal = clamp01(scalar_factor(r, RTK_MAP_METALLIC, m->metallic));
    float alpha = rtk_ggx_alpha(clamp01(scalar_factor(r, RTK_MAP_ROUGHNESS, m->roughness)));
    float t = transparent_illum(m->illum) ? 1.0f - clamp01(s->alpha)
                                          : clamp01(scalar_factor(r, RTK_MAP_TRANSMISSION, m->transmission));
    rtk_rgb colour = colour_factor(r, RTK_MAP_SPECULAR_COLOR, m->specular_color);
    float weight = clamp01(scalar_factor(r, RTK_MAP_SPECULAR, m->specular_weight));
    float r0 = (ior - 1.0f) / (ior + 1.0f);
    r0 *= r0;
    rtk_rgb f0 = rtk_rgb_scale(clamp_rgb(rtk_rgb_scale(colour, r0)), weight);
    rtk_bsdf_add(out, grey(metal), rtk_lobe_ggx_schlick(base, alpha));
    rtk_bsdf_add(out, grey((1.0f - metal) * (1.0f - t)), rtk_lobe_plastic(base, f0, alpha));
    rtk_bsdf_add(out, grey((1.0f - metal) * t), transmission_lobe(ior, alpha, base));
}

static void mtl(const factor_reader *r, const rtk_surface *s, rtk_rgb kd, float ior, rtk_bsdf *out)
{
    const rtk_material *m = r->m;
    rtk_rgb ks = clamp_rgb(colour_factor(r, RTK_MAP_SPECULAR_COLOR, m->specular));
    float ns = scalar_factor(r, RTK_MAP_SHININESS, m->shininess);
    /* Walter et al. 2007's Phong exponent to Beckmann width, used as GGX's alpha. */
    float alpha = sqrtf(2.0f / ((ns > 0.0f ? ns : 0.0f) + 2.0f));
    alpha = alpha > RTK_GGX_ALPHA_MIN ? alpha : RTK_GGX_ALPHA_MIN;
    const int shiny = ks.r > 0.0f || ks.g > 0.0f || ks.b > 0.0f;
    const int illum = m->has_illum ? m->illum : -1;
    rtk_lobe surface = rtk_lobe_lambert(kd);
    if (shiny && illum == 5)
        surface = rtk_lobe_ggx_schlick(ks, alpha);
    else if (shiny && illum != 0 && illum != 1)
        surface = rtk_lobe_plastic(kd, ks, alpha);
    float tr = transparent_illum(illum) ? 1.0f - clamp01(s->alpha) : 0.0f;
    rtk_bsdf_add(out, grey(1.0f - tr), surface);
    rtk_bsdf_add(out, grey(tr), transmission_lobe(ior, alpha, m->has_filter ? clamp_rgb(m->filter) : kd));
}

RTK_API void rtk_surface_bsdf(const rtk_scene *scene, const rtk_hit *hit, const rtk_surface *s, rtk_bsdf *out)
{
    factor_reader r = {scene, NULL, hit->prim, hit->u, hit->v, 0};
    if (hit->inst != RTK_INVALID_ID && hit->inst < scene->instance_count)
        r.scene = scene->meshes[scene->instances[hit->inst].mesh];
    const rtk_scene *ms = r.scene;
    rtk_rgb base = clamp_rgb(s->base_color);
    if (s->material == RTK_INVALID_ID || s->material >= ms->material_count ||
        ms->materials[s->material].model == RTK_MODEL_DIFFUSE) {
        *out = rtk_bsdf_of(rtk_lobe_lambert(base));
        return;
    }
    r.m = &ms->materials[s->material];
    r.on = ms->uvs && (ms->needs & RTK_NEED_TEXTURES) && hit->prim < ms->triangle_count;
    float ior = isfinite(s->ior) && s->ior > 0.0f ? s->ior : 1.5f;
    memset(out, 0, sizeof *out);
    if (r.m->model == RTK_MODEL_METALLIC_ROUGHNESS)
        metallic_roughness(&r, s, base, ior, out);
    else
        mtl(&r, s, base, ior, out);
}
