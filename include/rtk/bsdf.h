/* BSDF service: evaluate, sample and query the pdf of a surface's
 * scattering, for any integrator.
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
 * - Every lobe but the dielectric reflects only: wo.z <= 0 or wi.z <= 0
 *   gives f = 0 and pdf = 0, and sample() fails for wo.z <= 0. The
 *   dielectric takes wo on either side (wo.z < 0: the ray arrives from
 *   inside) and returns wi on either side.
 * - A lobe that scatters into single directions (a smooth mirror or
 *   dielectric) is flagged RTK_BSDF_DELTA: eval() and pdf() return 0 for
 *   it, and sample() returns f = weight / |wi.z| with pdf = the discrete
 *   probability of the direction, so f |wi.z| / pdf is the path weight as
 *   for the other lobes. RTK_BSDF_DIELECTRIC is the delta lobe.
 * - The GGX lobe is single-scattering only: it loses the light that
 *   would scatter again between microfacets (white furnace, F = 1: 0.003
 *   of it at alpha 0.05, 0.05 at alpha 0.2, 0.31 at alpha 0.5, 0.69 at
 *   alpha 1, wo normal; tests/scene/bsdf prints the table). Energy
 *   compensation (Kulla and Conty 2017) is not applied yet.
 * - Lambert and Oren-Nayar sampling never fails for wo above the surface.
 * All functions are pure: [any thread]. */
#ifndef RTK_BSDF_H
#define RTK_BSDF_H

#include <rtk/math.h>

RTK_EXTERN_C_BEGIN

/* An orthonormal frame: s, t tangents, n the normal (local +z). */
typedef struct rtk_frame {
    rtk_vec3 s, t, n;
} rtk_frame;

/* The frame around unit normal n, continuous except across n.z = 0, with
 * no branch (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"). */
static inline rtk_frame rtk_frame_from_normal(rtk_vec3 n)
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
static inline rtk_vec3 rtk_frame_to_local(const rtk_frame *f, rtk_vec3 v)
{
    return rtk_vec3_make(rtk_vec3_dot(v, f->s), rtk_vec3_dot(v, f->t), rtk_vec3_dot(v, f->n));
}

/* Local direction v of frame f in world coordinates. */
static inline rtk_vec3 rtk_frame_to_world(const rtk_frame *f, rtk_vec3 v)
{
    return rtk_vec3_add(rtk_vec3_add(rtk_vec3_scale(f->s, v.x), rtk_vec3_scale(f->t, v.y)),
                        rtk_vec3_scale(f->n, v.z));
}

/* The lobe a rtk_bsdf describes; its parameters are the fields named. */
typedef enum rtk_bsdf_type {
    /* f = albedo / pi; sampled cosine-weighted. */
    RTK_BSDF_LAMBERT = 0,
    /* Fujii's improved Oren-Nayar (2013): f = albedo (A + B s / t),
     * A = 1 / (pi + (pi/2 - 2/3) sigma), B = sigma A,
     * s = wi.wo - wi.z wo.z, t = max(wi.z, wo.z) where s > 0, else 1;
     * sigma in [0, 1] (clamped; 0 is Lambert), sampled cosine-weighted. */
    RTK_BSDF_OREN_NAYAR = 1,
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
    RTK_BSDF_GGX = 2,
    /* Smooth dielectric interface of relative index ior = n inside / n
     * outside (inside is -z), finite and > 0 (else sample() fails). For
     * wo on the inside (wo.z < 0) the relative index is eta = 1 / ior,
     * else eta = ior. F is the exact unpolarised Fresnel reflectance at
     * c = |wo.z|: F = (rs^2 + rp^2) / 2, rs = (c - eta ct) / (c + eta ct),
     * rp = (eta c - ct) / (eta c + ct), ct = sqrt(1 - (1 - c^2) / eta^2);
     * F = 1 where that root is imaginary (total internal reflection).
     * sample() reflects, wi = (-wo.x, -wo.y, wo.z), with probability F
     * and returns f = F / |wi.z|, pdf = F; else it refracts by Snell,
     * wi = (-wo.x / eta, -wo.y / eta, -sign(wo.z) ct), and returns
     * f = (1 - F) / |wi.z|, pdf = 1 - F. The path weight f |wi.z| / pdf
     * is therefore 1 for either event (white furnace = 1 exactly). f
     * excludes the radiance scale 1 / eta^2 of refraction (pbrt's
     * TransportMode::Radiance includes it): the factors of entering and
     * leaving a closed object cancel, and an integrator that carries
     * radiance into or out of a medium (camera or light inside it)
     * multiplies a transmission's weight by 1 / eta^2 itself. Flags:
     * RTK_BSDF_DELTA with RTK_BSDF_REFLECTION or RTK_BSDF_TRANSMISSION. */
    RTK_BSDF_DIELECTRIC = 3
} rtk_bsdf_type;

/* Fresnel term of the GGX lobe. */
typedef enum rtk_fresnel_type {
    /* Schlick: F = f0 + (1 - f0) (1 - cos)^5, per channel. */
    RTK_FRESNEL_SCHLICK = 0,
    /* Exact conductor reflectance for the complex index eta + i k relative
     * to the outside medium, unpolarised, per channel. */
    RTK_FRESNEL_CONDUCTOR = 1
} rtk_fresnel_type;

/* What a lobe does: sample() reports the flags of the lobe it sampled,
 * rtk_bsdf_flags the union over the BSDF's lobes. */
typedef enum rtk_bsdf_flag {
    RTK_BSDF_REFLECTION = 1,
    RTK_BSDF_TRANSMISSION = 2,
    RTK_BSDF_DIFFUSE = 4,
    RTK_BSDF_GLOSSY = 8,
    RTK_BSDF_DELTA = 16 /* single directions: eval() and pdf() are 0 */
} rtk_bsdf_flag;

/* Smallest GGX alpha used: at 1e-3 D peaks at 1 / (pi 1e-6) ~ 3.2e5,
 * finite and representable for every direction in float. */
#define RTK_GGX_ALPHA_MIN 1e-3f

/* One BSDF, a value: the type and its parameters; zero-initialised it is
 * a black Lambert. */
typedef struct rtk_bsdf {
    rtk_bsdf_type type;
    rtk_rgb albedo;           /* Lambert, Oren-Nayar: reflectance, each in [0, 1] */
    float sigma;              /* Oren-Nayar roughness in [0, 1] (rtk_oren_nayar_sigma) */
    float alpha;              /* GGX width (rtk_ggx_alpha) */
    rtk_fresnel_type fresnel; /* GGX: which Fresnel */
    rtk_rgb f0;               /* GGX, Schlick: reflectance at normal incidence */
    rtk_rgb eta, k;           /* GGX, conductor: complex index of refraction */
    float ior;                /* dielectric: index inside / index outside, > 0 */
} rtk_bsdf;

/* Oren-Nayar sigma for a material roughness in [0, 1]: sigma = roughness,
 * clamped to [0, 1], the range over which Fujii's f stays >= 0 (at
 * sigma > 1, A + B s / t < 0 for back-scattering at grazing angles). */
static inline float rtk_oren_nayar_sigma(float roughness)
{
    return roughness < 0.0f ? 0.0f : roughness > 1.0f ? 1.0f : roughness;
}

/* GGX alpha for a perceptual roughness (glTF, Burley 2012): roughness^2,
 * at least RTK_GGX_ALPHA_MIN. */
static inline float rtk_ggx_alpha(float roughness)
{
    float a = roughness * roughness;
    return a > RTK_GGX_ALPHA_MIN ? a : RTK_GGX_ALPHA_MIN;
}

/* A Lambert BSDF of reflectance albedo. */
static inline rtk_bsdf rtk_bsdf_lambert(rtk_rgb albedo)
{
    rtk_bsdf b = {RTK_BSDF_LAMBERT, albedo, 0.0f, 0.0f, RTK_FRESNEL_SCHLICK, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 0.0f};
    return b;
}

/* An Oren-Nayar (Fujii) BSDF of reflectance albedo and roughness sigma. */
static inline rtk_bsdf rtk_bsdf_oren_nayar(rtk_rgb albedo, float sigma)
{
    rtk_bsdf b = rtk_bsdf_lambert(albedo);
    b.type = RTK_BSDF_OREN_NAYAR;
    b.sigma = sigma;
    return b;
}

/* A GGX conductor of width alpha with Schlick's Fresnel from f0. */
static inline rtk_bsdf rtk_bsdf_ggx_schlick(rtk_rgb f0, float alpha)
{
    rtk_bsdf b = rtk_bsdf_lambert(rtk_rgb_make(0, 0, 0));
    b.type = RTK_BSDF_GGX;
    b.alpha = alpha;
    b.fresnel = RTK_FRESNEL_SCHLICK;
    b.f0 = f0;
    return b;
}

/* A GGX conductor of width alpha with the exact Fresnel of eta + i k. */
static inline rtk_bsdf rtk_bsdf_ggx_conductor(rtk_rgb eta, rtk_rgb k, float alpha)
{
    rtk_bsdf b = rtk_bsdf_ggx_schlick(rtk_rgb_make(0, 0, 0), alpha);
    b.fresnel = RTK_FRESNEL_CONDUCTOR;
    b.eta = eta;
    b.k = k;
    return b;
}

/* A smooth dielectric of relative index ior (inside / outside, e.g. 1.5
 * for glass in air). */
static inline rtk_bsdf rtk_bsdf_dielectric(float ior)
{
    rtk_bsdf b = rtk_bsdf_lambert(rtk_rgb_make(0, 0, 0));
    b.type = RTK_BSDF_DIELECTRIC;
    b.ior = ior;
    return b;
}

/* A direction sampled by rtk_bsdf_sample. */
typedef struct rtk_bsdf_sample_out {
    rtk_vec3 wi;    /* local, unit, away from the surface (either side for transmission) */
    rtk_rgb f;      /* rtk_bsdf_eval(bsdf, wo, wi) (delta: see the top) */
    float pdf;      /* rtk_bsdf_pdf(bsdf, wo, wi), > 0 (delta: see the top) */
    unsigned flags; /* rtk_bsdf_flag of the sampled lobe */
} rtk_bsdf_sample_out;

/* f(wo, wi), without the cosine; 0 when either is below the surface. [any thread] */
RTK_API rtk_rgb rtk_bsdf_eval(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi);

/* Samples wi for wo from u in [0, 1)^2 (rtk_sample_2d); returns 1 and
 * fills out, or 0 (out untouched) when no direction results: wo below the
 * surface (the dielectric: wo.z = 0, or ior not a finite positive number),
 * or a GGX direction below the horizon, which the estimator counts as
 * zero. [any thread] */
RTK_API int rtk_bsdf_sample(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec2 u, rtk_bsdf_sample_out *out);

/* Solid-angle density with which rtk_bsdf_sample returns wi for wo. [any thread] */
RTK_API float rtk_bsdf_pdf(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi);

/* Union of the rtk_bsdf_flag of bsdf's lobes. [any thread] */
RTK_API unsigned rtk_bsdf_flags(const rtk_bsdf *bsdf);

RTK_EXTERN_C_END

#endif
