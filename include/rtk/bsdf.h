/* BSDF service: evaluate, sample and query the pdf of a surface's
 * scattering, for any integrator. A BSDF (rtk_bsdf) is a weighted sum of
 * up to RTK_BSDF_MAX_LOBES lobes (rtk_lobe): f = sum_i weight_i f_i.
 *
 * Conventions (every function here follows them):
 * - Directions are unit vectors in the local shading frame, where the
 *   shading normal is +z (rtk_frame_from_normal, rtk_frame_to_local and
 *   rtk_frame_to_world move between it and world space).
 * - Both point away from the surface: wo toward the viewer (the negated
 *   ray direction), wi toward the light.
 * - f() excludes the cosine: reflected radiance is the integral of
 *   f(wo, wi) Li(wi) |wi.z| over wi.
 * - pdfs are densities in solid angle over wi.
 * - Lambert, Oren-Nayar, GGX and plastic reflect only: wo.z <= 0 or
 *   wi.z <= 0 gives f = 0 and pdf = 0, and their sampling fails for
 *   wo.z <= 0. The two dielectrics take wo on either side (wo.z < 0: the
 *   ray arrives from inside, -z) and return wi on either side; wo.z = 0
 *   or wi.z = 0 gives f = pdf = 0 and sampling fails.
 * - A lobe that scatters into single directions (the smooth dielectric)
 *   is flagged RTK_BSDF_DELTA: eval() and pdf() leave it out, and when
 *   sample() picks it, it returns f = weight f_lobe with f_lobe =
 *   (event weight) / |wi.z| and pdf = p_i (discrete probability of the
 *   direction), so that f |wi.z| / pdf is the path weight as for the other
 *   lobes.
 * - Transmission f excludes the radiance scale 1 / eta^2 of refraction
 *   (pbrt's TransportMode::Radiance includes it): the factors of entering
 *   and leaving a closed object cancel, and an integrator that carries
 *   radiance into or out of a medium (camera or light inside it)
 *   multiplies a transmission's weight by 1 / eta^2 itself. Reciprocity
 *   across the interface therefore holds as f(wo, wi) / n_i^2 =
 *   f(wi, wo) / n_o^2, n_i the index on wi's side and n_o on wo's.
 *
 * Mixtures and sample(): lobe i is chosen with probability
 *   p_i = s_i / sum_j s_j, s_i = luminance(weight_i) x nominal_i
 * (luminance = 0.2126 r + 0.7152 g + 0.0722 b, negative counted as 0),
 * nominal_i a fixed estimate of the lobe's albedo: luminance(albedo) for
 * Lambert and Oren-Nayar; for GGX with Schlick luminance(f0 + (1 - f0) / 21)
 * (Schlick's cosine-weighted mean, > 0 even at f0 = 0), with the conductor
 * Fresnel 1; 1 for both dielectrics; for plastic
 * luminance(Fa + (1 - Fa) albedo), Fa = f0 + (1 - f0) / 21. Where every
 * s_i is 0 each lobe gets 1 / count. u_lobe in [0, 1) picks the lobe by
 * these p_i (cumulative, in lobe order); what is left of it, rescaled to
 * [0, 1), makes the lobe's own discrete choice (a dielectric's reflection
 * or refraction, plastic's coat or base); u in [0, 1)^2 makes the
 * direction. For a non-delta lobe, sample() returns f = rtk_bsdf_eval and
 * pdf = rtk_bsdf_pdf at wi (sums over every non-delta lobe, so
 * f |wi.z| / pdf is the one-sample MIS-over-lobes weight); for a delta
 * lobe, f = weight_i f_i and pdf = p_i x the event's probability.
 * rtk_bsdf_pdf is sum_i p_i pdf_i over the non-delta lobes.
 *
 * Energy: every lobe keeps its white-furnace albedo (the mean of
 * f |wi.z| / pdf with albedo 1, F = 1 for GGX, white tint) <= 1; Lambert
 * and the smooth dielectric keep all of it. The others lose this much
 * (1 - albedo, wo at 0 / 60 / 89 degrees from the normal; tests/scene/bsdf
 * measures it against quadrature and prints the full tables):
 *   Oren-Nayar sigma 0.5            0.126 / 0.076 / 0.002 (Fujii's model)
 *   Oren-Nayar sigma 1              0.223 / 0.134 / 0.003
 *   GGX alpha 0.05 / 0.2            0.003 / 0.007 / 0.064, 0.052 / 0.105 / 0.029
 *   GGX alpha 0.5 / 1               0.312 / 0.301 / 0.040, 0.693 / 0.548 / 0.071
 *   rough dielectric 1.5, outside   alpha 0.05: 0.0003 / 0.002 / 0.056,
 *                                   0.2: 0.005 / 0.028 / 0.033, 0.5: 0.032 /
 *                                   0.107 / 0.066, 1: 0.106 / 0.258 / 0.118
 *   rough dielectric 1.5, inside    alpha 0.05: 0.003 / 0.009 / 0.083,
 *                                   1: 0.58 / 0.49 / 0.44
 *   plastic f0 0.04                 alpha 0.05: 0.082 / 0.079 / 0.378,
 *                                   1: 0.110 / 0.129 / 0.850
 *   plastic f0 0.2                  alpha 0.05: 0.191 / 0.185 / 0.336,
 *                                   1: 0.329 / 0.317 / 0.731
 * The microfacet lobes lose the light that would scatter again between
 * microfacets (single scattering; Kulla and Conty's 2017 compensation is
 * not applied), plastic also Fa (1 - F(wo.z)) of its base (see
 * RTK_LOBE_PLASTIC). A mixture's albedo is the weighted sum of its lobes'.
 * All functions are pure: [any thread]. */
#ifndef RTK_BSDF_H
#define RTK_BSDF_H

#include <rtk/math.h>

#include <stdint.h>

RTK_EXTERN_C_BEGIN

/* An orthonormal frame: s, t tangents, n the normal (local +z). */
typedef struct rtk_frame {
    rtk_vec3 s, t, n;
} rtk_frame;

/* The frame around unit normal n, continuous except across n.z = 0, with
 * no branch (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"). */
RTK_SDK_INLINE rtk_frame rtk_frame_from_normal(rtk_vec3 n)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float b = n.x * n.y * a;
    rtk_frame f;
    f.s = rtk_vec3_make(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = rtk_vec3_make(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

/* World direction v in frame f's coordinates (n becomes +z). */
RTK_SDK_INLINE rtk_vec3 rtk_frame_to_local(const rtk_frame *f, rtk_vec3 v)
{
    return rtk_vec3_make(rtk_vec3_dot(v, f->s), rtk_vec3_dot(v, f->t), rtk_vec3_dot(v, f->n));
}

/* Local direction v of frame f in world coordinates. */
RTK_SDK_INLINE rtk_vec3 rtk_frame_to_world(const rtk_frame *f, rtk_vec3 v)
{
    return rtk_vec3_add(rtk_vec3_add(rtk_vec3_scale(f->s, v.x), rtk_vec3_scale(f->t, v.y)),
                        rtk_vec3_scale(f->n, v.z));
}

/* The kind of a rtk_lobe; its parameters are the fields named. */
typedef enum rtk_lobe_type {
    /* f = albedo / pi; sampled cosine-weighted, never fails for wo.z > 0. */
    RTK_LOBE_LAMBERT = 0,
    /* Fujii's improved Oren-Nayar (2013): f = albedo (A + B s / t),
     * A = 1 / (pi + (pi/2 - 2/3) sigma), B = sigma A,
     * s = wi.wo - wi.z wo.z, t = max(wi.z, wo.z) where s > 0, else 1;
     * sigma in [0, 1] (clamped; 0 is Lambert), sampled cosine-weighted. */
    RTK_LOBE_OREN_NAYAR = 1,
    /* GGX / Trowbridge-Reitz conductor: f = F(wo.m) D(m) G2 / (4 wo.z wi.z),
     * m = normalize(wo + wi), D = alpha^2 / (pi (sin^2 + alpha^2 cos^2)^2 of m),
     * G2 = 1 / (1 + L(wo) + L(wi)) height-correlated Smith with
     * L(w) = (sqrt(1 + alpha^2 tan^2 w) - 1) / 2, F Schlick with f0 or the
     * exact conductor Fresnel with eta, k (field fresnel). Sampled by
     * visible normals (Heitz 2018): pdf = D_wo(m) / (4 wo.m),
     * D_wo(m) = G1(wo) (wo.m) D(m) / wo.z, G1 = 1 / (1 + L(wo)); a sampled
     * direction below the horizon fails, so the pdf integrates over the
     * hemisphere to the probability that sample() succeeds. alpha is
     * clamped to at least RTK_GGX_ALPHA_MIN. */
    RTK_LOBE_GGX = 2,
    /* Smooth dielectric interface of relative index ior = n inside / n
     * outside (inside is -z), finite and > 0 (else sample() fails). For
     * wo on the inside (wo.z < 0) the relative index is eta = 1 / ior,
     * else eta = ior. F is the exact unpolarised Fresnel reflectance at
     * c = |wo.z|: F = (rs^2 + rp^2) / 2, rs = (c - eta ct) / (c + eta ct),
     * rp = (eta c - ct) / (eta c + ct), ct = sqrt(1 - (1 - c^2) / eta^2);
     * F = 1 where that root is imaginary (total internal reflection).
     * With T = luminance(tint), the lobe reflects, wi = (-wo.x, -wo.y,
     * wo.z), with probability P = F / (F + (1 - F) T) (1 where that is
     * 0 / 0): f = F / |wi.z|, event pdf P; else it refracts by Snell,
     * wi = (-wo.x / eta, -wo.y / eta, -sign(wo.z) ct): f = tint (1 - F) /
     * |wi.z|, event pdf 1 - P. With a white tint the path weight
     * f |wi.z| / pdf is 1 for either event (white furnace = 1 exactly).
     * Flags: RTK_BSDF_DELTA with RTK_BSDF_REFLECTION or
     * RTK_BSDF_TRANSMISSION. */
    RTK_LOBE_DIELECTRIC = 3,
    /* Rough dielectric interface (Walter, Marschner, Li and Torrance 2007),
     * ior and the sides as RTK_LOBE_DIELECTRIC (eta relative to wo's side),
     * GGX D of alpha (clamped to at least RTK_GGX_ALPHA_MIN), the
     * height-correlated G2 = 1 / (1 + L(wo) + L(wi)) for reflection and
     * transmission alike (as pbrt-v4; for transmission the exact
     * height-correlated term is a Beta function, this is its common
     * symmetric stand-in), exact dielectric Fresnel F = F(wo.m, eta) as
     * above (1 beyond the critical angle). Reflection (wi on wo's side):
     * m = normalize(wo + wi), f = F D G2 / (4 |wo.z| |wi.z|).
     * Transmission: the generalized half vector m = normalize(wo + eta wi)
     * turned to wo's side, f = tint (1 - F) D G2 |wo.m| |wi.m| /
     * (|wo.z| |wi.z| (wi.m + wo.m / eta)^2) (without 1 / eta^2, see the
     * top), 0 where m faces away from wo or toward wi. Sampling: a visible
     * normal m from wo's side (Heitz 2018), then reflection about m with
     * probability P = F / (F + (1 - F) T) (T = luminance(tint)), else
     * refraction through m; pdf = P D_wo(m) / (4 |wo.m|) for reflection,
     * (1 - P) D_wo(m) |wi.m| / (wi.m + wo.m / eta)^2 for transmission; a
     * direction that lands on the wrong side fails. For |ior - 1| < 1e-3
     * the interface does not bend light and the lobe is the smooth
     * dielectric (delta) instead. Flags: RTK_BSDF_GLOSSY with reflection
     * and transmission (sample(): the one taken). */
    RTK_LOBE_ROUGH_DIELECTRIC = 4,
    /* Plastic: a Lambert base under a dielectric coat. Coat: the GGX
     * reflection of alpha with Schlick's F from f0 (f0 in [0, 1] per
     * channel, 0.04 for ior 1.5): F(wo.m) D G2 / (4 wo.z wi.z). Base:
     * f = albedo / pi (1 - F(wo.z)) (1 - F(wi.z)), reciprocal, of albedo
     * albedo (1 - F(wo.z)) (1 - Fa), Fa = f0 + (1 - f0) / 21 the cosine-
     * weighted mean of Schlick's F. Dividing the base by (1 - Fa) would
     * keep the smooth coat's energy exactly, but a rough coat reflects
     * more than F(wo.z) (Schlick's F is convex in the cosine) and the sum
     * then exceeds 1 (1.0009 at f0 0.04, alpha 0.05, 60 degrees), so the
     * base is not normalised: the lobe loses up to Fa (1 - F(wo.z)) of
     * the light, 0.08 at f0 0.04 (the table at the top). Sampling: the
     * coat with probability
     * Pc = c / (c + luminance(albedo (1 - F(wo.z)))), c = max(luminance(
     * F(wo.z)), 0.05), else the base cosine-weighted; pdf =
     * Pc pdf_coat + (1 - Pc) wi.z / pi. Flags: reflection, glossy and
     * diffuse (sample(): glossy for the coat, diffuse for the base). This
     * is glTF's dielectric base (metallic 0) and MTL's Kd + Ks. */
    RTK_LOBE_PLASTIC = 5
} rtk_lobe_type;

/* Fresnel term of the GGX lobe. */
typedef enum rtk_fresnel_type {
    /* Schlick: F = f0 + (1 - f0) (1 - cos)^5, per channel. */
    RTK_FRESNEL_SCHLICK = 0,
    /* Exact conductor reflectance for the complex index eta + i k relative
     * to the outside medium, unpolarised, per channel. */
    RTK_FRESNEL_CONDUCTOR = 1
} rtk_fresnel_type;

/* What a lobe does: sample() reports the flags of the event it sampled,
 * rtk_bsdf_flags the union over the BSDF's lobes. */
typedef enum rtk_bsdf_flag {
    RTK_BSDF_REFLECTION = 1,
    RTK_BSDF_TRANSMISSION = 2,
    RTK_BSDF_DIFFUSE = 4,
    RTK_BSDF_GLOSSY = 8,
    RTK_BSDF_DELTA = 16 /* single directions: eval() and pdf() leave it out */
} rtk_bsdf_flag;

/* Smallest GGX alpha used: at 1e-3 D peaks at 1 / (pi 1e-6) ~ 3.2e5,
 * finite and representable for every direction in float. */
#define RTK_GGX_ALPHA_MIN 1e-3f

/* One lobe, a value: the type and its parameters; zero-initialised it is
 * a black Lambert. */
typedef struct rtk_lobe {
    rtk_lobe_type type;
    rtk_rgb albedo;           /* Lambert, Oren-Nayar, plastic's base: reflectance, each in [0, 1] */
    float sigma;              /* Oren-Nayar roughness in [0, 1] (rtk_oren_nayar_sigma) */
    float alpha;              /* GGX, rough dielectric, plastic's coat: width (rtk_ggx_alpha) */
    rtk_fresnel_type fresnel; /* GGX: which Fresnel */
    rtk_rgb f0;               /* GGX with Schlick, plastic: reflectance at normal incidence, in [0, 1] */
    rtk_rgb eta, k;           /* GGX, conductor: complex index of refraction */
    float ior;                /* dielectrics: index inside / index outside, > 0 */
    rtk_rgb tint;             /* dielectrics: scale of the transmitted part, each in [0, 1] */
} rtk_lobe;

/* Most lobes in one rtk_bsdf. */
#define RTK_BSDF_MAX_LOBES 4

/* A BSDF, a value: f = sum over the first count lobes of weight[i] f_i.
 * Zero-initialised (count 0) it is black: eval and pdf 0, sample fails. */
typedef struct rtk_bsdf {
    uint32_t count;
    rtk_rgb weight[RTK_BSDF_MAX_LOBES];
    rtk_lobe lobe[RTK_BSDF_MAX_LOBES];
} rtk_bsdf;

/* Oren-Nayar sigma for a material roughness in [0, 1]: sigma = roughness,
 * clamped to [0, 1], the range over which Fujii's f stays >= 0 (at
 * sigma > 1, A + B s / t < 0 for back-scattering at grazing angles). */
RTK_SDK_INLINE float rtk_oren_nayar_sigma(float roughness)
{
    return roughness < 0.0f ? 0.0f : roughness > 1.0f ? 1.0f : roughness;
}

/* GGX alpha for a perceptual roughness (glTF, Burley 2012): roughness^2,
 * at least RTK_GGX_ALPHA_MIN. */
RTK_SDK_INLINE float rtk_ggx_alpha(float roughness)
{
    float a = roughness * roughness;
    return a > RTK_GGX_ALPHA_MIN ? a : RTK_GGX_ALPHA_MIN;
}

/* A Lambert lobe of reflectance albedo. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_lambert(rtk_rgb albedo)
{
    rtk_lobe l = {RTK_LOBE_LAMBERT, albedo, 0.0f, 0.0f, RTK_FRESNEL_SCHLICK, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 0.0f,
                  {1, 1, 1}};
    return l;
}

/* An Oren-Nayar (Fujii) lobe of reflectance albedo and roughness sigma. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_oren_nayar(rtk_rgb albedo, float sigma)
{
    rtk_lobe l = rtk_lobe_lambert(albedo);
    l.type = RTK_LOBE_OREN_NAYAR;
    l.sigma = sigma;
    return l;
}

/* A GGX conductor of width alpha with Schlick's Fresnel from f0. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_ggx_schlick(rtk_rgb f0, float alpha)
{
    rtk_lobe l = rtk_lobe_lambert(rtk_rgb_make(0, 0, 0));
    l.type = RTK_LOBE_GGX;
    l.alpha = alpha;
    l.fresnel = RTK_FRESNEL_SCHLICK;
    l.f0 = f0;
    return l;
}

/* A GGX conductor of width alpha with the exact Fresnel of eta + i k. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_ggx_conductor(rtk_rgb eta, rtk_rgb k, float alpha)
{
    rtk_lobe l = rtk_lobe_ggx_schlick(rtk_rgb_make(0, 0, 0), alpha);
    l.fresnel = RTK_FRESNEL_CONDUCTOR;
    l.eta = eta;
    l.k = k;
    return l;
}

/* A smooth dielectric (delta) of relative index ior (inside / outside,
 * e.g. 1.5 for glass in air), transmission scaled by tint. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_dielectric(float ior, rtk_rgb tint)
{
    rtk_lobe l = rtk_lobe_lambert(rtk_rgb_make(0, 0, 0));
    l.type = RTK_LOBE_DIELECTRIC;
    l.ior = ior;
    l.tint = tint;
    return l;
}

/* A rough dielectric of relative index ior and GGX width alpha,
 * transmission scaled by tint. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_rough_dielectric(float ior, float alpha, rtk_rgb tint)
{
    rtk_lobe l = rtk_lobe_dielectric(ior, tint);
    l.type = RTK_LOBE_ROUGH_DIELECTRIC;
    l.alpha = alpha;
    return l;
}

/* A plastic: Lambert base of albedo under a GGX coat of width alpha with
 * Schlick's Fresnel from f0. */
RTK_SDK_INLINE rtk_lobe rtk_lobe_plastic(rtk_rgb albedo, rtk_rgb f0, float alpha)
{
    rtk_lobe l = rtk_lobe_lambert(albedo);
    l.type = RTK_LOBE_PLASTIC;
    l.f0 = f0;
    l.alpha = alpha;
    return l;
}

/* The BSDF of lobe l alone, weight 1. */
RTK_SDK_INLINE rtk_bsdf rtk_bsdf_of(rtk_lobe l)
{
    rtk_bsdf b;
    for (int i = 0; i < RTK_BSDF_MAX_LOBES; i++) {
        b.weight[i] = rtk_rgb_make(0, 0, 0);
        b.lobe[i] = rtk_lobe_lambert(b.weight[i]);
    }
    b.count = 1;
    b.weight[0] = rtk_rgb_make(1, 1, 1);
    b.lobe[0] = l;
    return b;
}

/* Appends lobe l with weight to b; returns 1, or 0 and adds nothing when
 * b holds RTK_BSDF_MAX_LOBES lobes already or weight is black (no
 * component > 0). */
RTK_SDK_INLINE int rtk_bsdf_add(rtk_bsdf *b, rtk_rgb weight, rtk_lobe l)
{
    if (b->count >= RTK_BSDF_MAX_LOBES || !(weight.r > 0.0f || weight.g > 0.0f || weight.b > 0.0f))
        return 0;
    b->weight[b->count] = weight;
    b->lobe[b->count] = l;
    b->count++;
    return 1;
}

/* A direction sampled by rtk_bsdf_sample. */
typedef struct rtk_bsdf_sample_out {
    rtk_vec3 wi;    /* local, unit, away from the surface (either side for transmission) */
    rtk_rgb f;      /* rtk_bsdf_eval(bsdf, wo, wi) (delta: see the top) */
    float pdf;      /* rtk_bsdf_pdf(bsdf, wo, wi), > 0 (delta: see the top) */
    unsigned flags; /* rtk_bsdf_flag of the sampled lobe's event */
} rtk_bsdf_sample_out;

/* f(wo, wi) = sum of weight_i f_i over the non-delta lobes, without the
 * cosine. [any thread] */
RTK_API rtk_rgb rtk_bsdf_eval(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi);

/* Samples wi for wo: u_lobe in [0, 1) picks the lobe (and its discrete
 * choice), u in [0, 1)^2 (rtk_sample_2d) the direction (see the top);
 * returns 1 and fills out, or 0 (out untouched) when no direction
 * results: no lobes, wo in or (reflecting lobes) below the surface, a
 * dielectric's ior not a finite positive number, or a microfacet
 * direction on the wrong side, which the estimator counts as zero.
 * [any thread] */
RTK_API int rtk_bsdf_sample(const rtk_bsdf *bsdf, rtk_vec3 wo, float u_lobe, rtk_vec2 u, rtk_bsdf_sample_out *out);

/* Solid-angle density with which rtk_bsdf_sample returns wi for wo:
 * sum of p_i pdf_i over the non-delta lobes. [any thread] */
RTK_API float rtk_bsdf_pdf(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi);

/* Union of the rtk_bsdf_flag of bsdf's lobes. [any thread] */
RTK_API unsigned rtk_bsdf_flags(const rtk_bsdf *bsdf);

RTK_EXTERN_C_END

/* ---- Material mapping (kernel/scene/material.c) ----
 * rtk_surface_bsdf maps the material of a hit to a mixture of the lobes
 * above. Factors are clamped to their ranges (colours and fractions to
 * [0, 1], Ns to >= 0), a factor texture multiplies its factor (read at
 * the hit's texture coordinates at the finest level, only when the
 * integrator asked for RTK_NEED_TEXTURES), and weights are grey.
 * - glTF metallic-roughness, and MTL with Pr, Pm, map_Pr or map_Pm:
 *   base = s->base_color (baseColor or Kd x texture x vertex colour),
 *   m = metallic x texture B (MTL: Pm x map_Pm; map_Pm alone: Pm = 1),
 *   r = roughness x texture G (MTL: Pr x map_Pr), alpha = rtk_ggx_alpha(r),
 *   t = transmission x texture R (MTL: 1 - d for illum 4, 6, 7, 9, else 0),
 *   f0_d = min(((ior - 1) / (ior + 1))^2 x specularColor x texture RGB, 1)
 *   x specular x texture A (KHR_materials_specular; MTL: both 1):
 *     m          ggx_schlick(f0 = base, alpha)
 *   + (1-m)(1-t) plastic(base, f0_d, alpha)
 *   + (1-m) t    rough_dielectric(ior, alpha, tint = base), the smooth
 *                dielectric where alpha is RTK_GGX_ALPHA_MIN (roughness 0);
 *   its Fresnel is the exact one of ior: KHR_materials_specular scales
 *   the plastic's coat only.
 * - MTL by illum, with Kd = s->base_color (Kd x map_Kd), Ks x map_Ks,
 *   Ns x map_Ns and alpha = sqrt(2 / (Ns + 2)) (Walter et al. 2007's
 *   Phong exponent to Beckmann width, used as the GGX alpha), at least
 *   RTK_GGX_ALPHA_MIN:
 *     0, 1                 Lambert(Kd)
 *     2, 3, 8, no illum    plastic(Kd, f0 = Ks, alpha)
 *     5                    ggx_schlick(f0 = Ks, alpha)
 *     4, 6, 7, 9           with tr = 1 - d (s->alpha, d x map_d):
 *                          (1 - tr) plastic(Kd, Ks, alpha)
 *                          + tr rough_dielectric(Ni, alpha, tint = Tf, or
 *                          Kd without Tf), smooth at RTK_GGX_ALPHA_MIN
 *   and Lambert(Kd) in place of plastic and ggx_schlick where Ks = 0;
 *   other illum values map as 2. d < 1 with another illum is coverage
 *   (s->alpha), not transmission.
 * - No material, or one made in memory: Lambert(s->base_color), white
 *   with rtk_surface's neutral values.
 * Emission is not part of the BSDF (s->emission). Every result has
 * weights in [0, 1] summing to at most 1, albedo, f0 and tint in [0, 1],
 * alpha in [RTK_GGX_ALPHA_MIN, 1] and ior finite and > 0. */

#include <rtk/scene.h>

RTK_EXTERN_C_BEGIN

/* The BSDF of surface s, filled by rtk_surface_at or
 * rtk_surface_at_footprint for hit on scene, as mapped above. [any thread]
 * (ABI 3.3) */
RTK_API void rtk_surface_bsdf(const rtk_scene *scene, const rtk_hit *hit, const rtk_surface *s, rtk_bsdf *out);

RTK_EXTERN_C_END

#endif
