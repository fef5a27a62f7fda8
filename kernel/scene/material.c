/* Materials: the values loaders store (checked and clamped here, with a
 * warning naming the file and material), and their mapping to a BSDF
 * (rtk_surface_bsdf, documented in include/rtk/bsdf.h and README.md). */
#include "material_bsdf.h"

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

/* Where a hit's factor textures are read: the triangle's scene (the
 * instanced mesh for a hit on an instance), triangle and barycentrics;
 * on is 0 when that scene keeps no decoded textures. */
typedef struct factor_reader {
    const rtk_scene *scene;
    uint32_t prim;
    float u, v;
    int on;
} factor_reader;

/* The texel of m's map k at the hit, at the finest level; 0 when the slot
 * has no decoded texture (rtk_map_read_fn). */
static int read_map(const void *ctx, const rtk_material *m, rtk_material_map k, float texel[4])
{
    const factor_reader *r = ctx;
    const rtk_tex_slot *slot = &m->maps[k];
    const rtk_scene *s = r->scene;
    if (!r->on || slot->tex < 0 || (uint32_t)slot->tex >= s->texture_count || !s->textures[slot->tex].decoded)
        return 0;
    rtk_vec2 uv = rtk_tex_map_uv(s, &slot->uv, r->prim, r->u, r->v);
    rtk_texture_sample(&s->textures[slot->tex], slot->wrap, uv.x, uv.y, 0.0f, texel);
    return 1;
}

RTK_API void rtk_surface_bsdf(const rtk_scene *scene, const rtk_hit *hit, const rtk_surface *s, rtk_bsdf *out)
{
    factor_reader r = {scene, hit->prim, hit->u, hit->v, 0};
    if (hit->inst != RTK_INVALID_ID && hit->inst < scene->instance_count)
        r.scene = scene->meshes[scene->instances[hit->inst].mesh];
    const rtk_scene *ms = r.scene;
    const rtk_material *m = s->material < ms->material_count ? &ms->materials[s->material] : NULL;
    r.on = ms->uvs && (ms->needs & RTK_NEED_TEXTURES) && hit->prim < ms->triangle_count;
    rtk_material_bsdf(m, s->base_color, s->alpha, s->ior, read_map, &r, out);
}
