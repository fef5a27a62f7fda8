/* A material's BSDF at a hit (the mapping include/rtk/bsdf.h and README
 * document), in plain C that nvcc compiles too (RTK_HD): material.c's
 * rtk_surface_bsdf reads the factor textures through its map reader,
 * device programs through theirs (plugins/integrators/device_programs.h),
 * so both map alike. */
#ifndef RTK_KERNEL_MATERIAL_BSDF_H
#define RTK_KERNEL_MATERIAL_BSDF_H

#include "scene.h"

#include <rtk/bsdf.h>

#include <math.h>
#include <string.h>

/* The texel of m's factor map k at the hit: 0 when there is none. */
typedef int (*rtk_map_read_fn)(const void *ctx, const rtk_material *m, rtk_material_map k, float texel[4]);

/* The reader of a hit that reads no textures. */
RTK_HD static inline int rtk_no_maps(const void *ctx, const rtk_material *m, rtk_material_map k, float texel[4])
{
    (void)ctx, (void)m, (void)k, (void)texel;
    return 0;
}

RTK_HD static inline float rtk_clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

RTK_HD static inline rtk_rgb rtk_clamp_rgb(rtk_rgb c)
{
    return rtk_rgb_make(rtk_clamp01(c.r), rtk_clamp01(c.g), rtk_clamp01(c.b));
}

/* factor x map k's channel at the hit (factor alone without the map). */
static RTK_HD_INLINE float rtk_scalar_factor(rtk_map_read_fn read, const void *ctx, const rtk_material *m,
                                             rtk_material_map k, float factor)
{
    float texel[4];
    return read(ctx, m, k, texel) ? factor * texel[m->maps[k].channel & 3] : factor;
}

/* factor x map k's RGB at the hit. */
static RTK_HD_INLINE rtk_rgb rtk_colour_factor(rtk_map_read_fn read, const void *ctx, const rtk_material *m,
                                               rtk_material_map k, rtk_rgb factor)
{
    float texel[4];
    return read(ctx, m, k, texel) ? rtk_rgb_mul(factor, rtk_rgb_make(texel[0], texel[1], texel[2])) : factor;
}

/* MTL illumination models with transparency (refraction or glass). */
RTK_HD static inline int rtk_transparent_illum(int illum)
{
    return illum == 4 || illum == 6 || illum == 7 || illum == 9;
}

/* The transmission lobe: smooth where alpha is at its minimum. */
RTK_HD static inline rtk_lobe rtk_transmission_lobe(float ior, float alpha, rtk_rgb tint)
{
    return alpha <= RTK_GGX_ALPHA_MIN ? rtk_lobe_dielectric(ior, tint) : rtk_lobe_rough_dielectric(ior, alpha, tint);
}

static RTK_HD_INLINE void rtk_metallic_roughness_bsdf(rtk_map_read_fn read, const void *ctx, const rtk_material *m,
                                                      float coverage, rtk_rgb base, float ior, rtk_bsdf *out)
{
    float metal = rtk_clamp01(rtk_scalar_factor(read, ctx, m, RTK_MAP_METALLIC, m->metallic));
    float alpha = rtk_ggx_alpha(rtk_clamp01(rtk_scalar_factor(read, ctx, m, RTK_MAP_ROUGHNESS, m->roughness)));
    float t = rtk_transparent_illum(m->illum)
                  ? 1.0f - rtk_clamp01(coverage)
                  : rtk_clamp01(rtk_scalar_factor(read, ctx, m, RTK_MAP_TRANSMISSION, m->transmission));
    rtk_rgb colour = rtk_colour_factor(read, ctx, m, RTK_MAP_SPECULAR_COLOR, m->specular_color);
    float weight = rtk_clamp01(rtk_scalar_factor(read, ctx, m, RTK_MAP_SPECULAR, m->specular_weight));
    float r0 = (ior - 1.0f) / (ior + 1.0f);
    r0 *= r0;
    rtk_rgb f0 = rtk_rgb_scale(rtk_clamp_rgb(rtk_rgb_scale(colour, r0)), weight);
    rtk_bsdf_add(out, rtk_rgb_make(metal, metal, metal), rtk_lobe_ggx_schlick(base, alpha));
    float plastic = (1.0f - metal) * (1.0f - t), glass = (1.0f - metal) * t;
    rtk_bsdf_add(out, rtk_rgb_make(plastic, plastic, plastic), rtk_lobe_plastic(base, f0, alpha));
    rtk_bsdf_add(out, rtk_rgb_make(glass, glass, glass), rtk_transmission_lobe(ior, alpha, base));
}

static RTK_HD_INLINE void rtk_mtl_bsdf(rtk_map_read_fn read, const void *ctx, const rtk_material *m, float coverage,
                                       rtk_rgb kd, float ior, rtk_bsdf *out)
{
    rtk_rgb ks = rtk_clamp_rgb(rtk_colour_factor(read, ctx, m, RTK_MAP_SPECULAR_COLOR, m->specular));
    float ns = rtk_scalar_factor(read, ctx, m, RTK_MAP_SHININESS, m->shininess);
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
    float tr = rtk_transparent_illum(illum) ? 1.0f - rtk_clamp01(coverage) : 0.0f;
    rtk_bsdf_add(out, rtk_rgb_make(1.0f - tr, 1.0f - tr, 1.0f - tr), surface);
    rtk_bsdf_add(out, rtk_rgb_make(tr, tr, tr),
                 rtk_transmission_lobe(ior, alpha, m->has_filter ? rtk_clamp_rgb(m->filter) : kd));
}

/* The BSDF of a hit whose surface has base colour base_color, coverage
 * alpha and index of refraction ior, on material m (NULL: none, or one
 * the scene lacks), its factor maps read through read. */
static RTK_HD_INLINE void rtk_material_bsdf(const rtk_material *m, rtk_rgb base_color, float coverage, float ior,
                                            rtk_map_read_fn read, const void *ctx, rtk_bsdf *out)
{
    rtk_rgb base = rtk_clamp_rgb(base_color);
    if (!m || m->model == RTK_MODEL_DIFFUSE) {
        *out = rtk_bsdf_of(rtk_lobe_lambert(base));
        return;
    }
    ior = isfinite(ior) && ior > 0.0f ? ior : 1.5f;
    memset(out, 0, sizeof *out);
    if (m->model == RTK_MODEL_METALLIC_ROUGHNESS)
        rtk_metallic_roughness_bsdf(read, ctx, m, coverage, base, ior, out);
    else
        rtk_mtl_bsdf(read, ctx, m, coverage, base, ior, out);
}

#endif
