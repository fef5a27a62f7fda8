/* The BSDF lobes of include/rtk/bsdf.h (Lambert, Fujii's Oren-Nayar, the
 * GGX conductor sampled by visible normals, the smooth and the rough
 * dielectric, plastic) and their weighted mixture, in plain C that nvcc
 * compiles too (RTK_HD, include/rtk/common.h): one source for the kernel's
 * rtk_bsdf_eval/pdf/flags/sample (bsdf.c) and a GPU backend's, checked
 * against each other by tests/cuda. Everything is in the local shading
 * frame (normal +z); the header states the conventions. Included by
 * bsdf.c, device programs (plugins/integrators/path_estimator.h) and CUDA
 * sources only: its helpers have short names. */
#ifndef RTK_KERNEL_BSDF_LOBES_H
#define RTK_KERNEL_BSDF_LOBES_H

#include <rtk/bsdf.h>

#include <math.h>

#define INV_PI ((float)(1.0 / RTK_PI))

RTK_HD static inline rtk_rgb rgb_zero(void)
{
    return rtk_rgb_make(0.0f, 0.0f, 0.0f);
}

/* A point on the unit disk from u, area-preserving (Shirley and Chiu 1997). */
RTK_HD static inline rtk_vec2 concentric_disk(rtk_vec2 u)
{
    float x = 2.0f * u.x - 1.0f, y = 2.0f * u.y - 1.0f;
    rtk_vec2 p = {0.0f, 0.0f};
    if (x == 0.0f && y == 0.0f)
        return p;
    float r, phi;
    if (fabsf(x) > fabsf(y)) {
        r = x;
        phi = (float)(RTK_PI / 4.0) * (y / x);
    } else {
        r = y;
        phi = (float)(RTK_PI / 2.0) - (float)(RTK_PI / 4.0) * (x / y);
    }
    p.x = r * cosf(phi);
    p.y = r * sinf(phi);
    return p;
}

/* A cosine-distributed direction about +z (pdf wi.z / pi); z >= 1e-6 on
 * the disk's rim (u = 0), so that it never fails. */
RTK_HD static inline rtk_vec3 cosine_hemisphere(rtk_vec2 u)
{
    rtk_vec2 d = concentric_disk(u);
    float z2 = 1.0f - d.x * d.x - d.y * d.y;
    return rtk_vec3_make(d.x, d.y, sqrtf(z2 > 1e-12f ? z2 : 1e-12f));
}

RTK_HD static inline float lobe_alpha(const rtk_lobe *l)
{
    return l->alpha > RTK_GGX_ALPHA_MIN ? l->alpha : RTK_GGX_ALPHA_MIN;
}

/* Rec. 709 luminance, negative counted as 0. */
RTK_HD static inline float luminance(rtk_rgb c)
{
    float y = 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b;
    return y > 0.0f ? y : 0.0f;
}

/* Fujii's improved Oren-Nayar, without albedo. */
RTK_HD static inline float oren_nayar(float sigma, rtk_vec3 wo, rtk_vec3 wi)
{
    float a = 1.0f / (float)(RTK_PI + (RTK_PI / 2.0 - 2.0 / 3.0) * sigma);
    float s = rtk_vec3_dot(wi, wo) - wi.z * wo.z;
    float t = s > 0.0f ? fmaxf(wi.z, wo.z) : 1.0f;
    float f = a * (1.0f + sigma * s / t);
    return f > 0.0f ? f : 0.0f;
}

/* GGX normal distribution of the unit microfacet normal m. */
RTK_HD static inline float ggx_d(float alpha, rtk_vec3 m)
{
    float a2 = alpha * alpha;
    float t = m.x * m.x + m.y * m.y + a2 * m.z * m.z;
    return a2 / ((float)RTK_PI * t * t);
}

/* Smith's Lambda for direction w (w.z > 0). */
RTK_HD static inline float ggx_lambda(float alpha, rtk_vec3 w)
{
    float tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
    return 0.5f * (sqrtf(1.0f + alpha * alpha * tan2) - 1.0f);
}

/* Unpolarised reflectance of a conductor eta + i k at cosine c (pbrt-v3's FrConductor). */
RTK_HD static inline float fresnel_conductor(float c, float eta, float k)
{
    float cos2 = c * c, sin2 = 1.0f - cos2;
    float eta2 = eta * eta, k2 = k * k;
    float t0 = eta2 - k2 - sin2;
    float a2b2 = sqrtf(t0 * t0 + 4.0f * eta2 * k2);
    float t1 = a2b2 + cos2;
    float a = sqrtf(fmaxf(0.0f, 0.5f * (a2b2 + t0)));
    float t2 = 2.0f * c * a;
    if (!(t1 + t2 > 0.0f))
        return 1.0f;
    float rs = (t1 - t2) / (t1 + t2);
    float t3 = cos2 * a2b2 + sin2 * sin2;
    float t4 = t2 * sin2;
    float rp = t3 + t4 > 0.0f ? rs * (t3 - t4) / (t3 + t4) : rs;
    return 0.5f * (rp + rs);
}

/* Unpolarised reflectance of a dielectric interface of relative index eta
 * at cosine c in [0, 1]; the transmitted cosine goes to *cos_t (0 under
 * total internal reflection, where F = 1). */
RTK_HD static inline float fresnel_dielectric(float c, float eta, float *cos_t)
{
    float sin2_t = (1.0f - c * c) / (eta * eta);
    if (sin2_t >= 1.0f) {
        *cos_t = 0.0f;
        return 1.0f;
    }
    float ct = sqrtf(1.0f - sin2_t);
    float rs = (c - eta * ct) / (c + eta * ct);
    float rp = (eta * c - ct) / (eta * c + ct);
    *cos_t = ct;
    return 0.5f * (rs * rs + rp * rp);
}

RTK_HD static inline float schlick(float c, float f0)
{
    float m = 1.0f - c;
    float m2 = m * m;
    return f0 + (1.0f - f0) * m2 * m2 * m;
}

/* A visible normal for wo (Heitz 2018, "Sampling the GGX Distribution of
 * Visible Normals", listing 1, isotropic). */
RTK_HD static inline rtk_vec3 ggx_sample_visible_normal(float alpha, rtk_vec3 wo, rtk_vec2 u)
{
    rtk_vec3 vh = rtk_vec3_normalize(rtk_vec3_make(alpha * wo.x, alpha * wo.y, wo.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    rtk_vec3 t1 = lensq > 0.0f ? rtk_vec3_scale(rtk_vec3_make(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(lensq))
                               : rtk_vec3_make(1.0f, 0.0f, 0.0f);
    rtk_vec3 t2 = rtk_vec3_cross(vh, t1);
    float r = sqrtf(u.x);
    float phi = 2.0f * (float)RTK_PI * u.y;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrtf(fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
    float pz = sqrtf(fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2));
    rtk_vec3 nh = rtk_vec3_add(rtk_vec3_add(rtk_vec3_scale(t1, p1), rtk_vec3_scale(t2, p2)), rtk_vec3_scale(vh, pz));
    return rtk_vec3_normalize(rtk_vec3_make(alpha * nh.x, alpha * nh.y, fmaxf(0.0f, nh.z)));
}


RTK_HD static inline int is_finite3(rtk_rgb c)
{
    return isfinite(c.r) && isfinite(c.g) && isfinite(c.b);
}

RTK_HD static inline rtk_rgb rgb_gray(float v)
{
    return rtk_rgb_make(v, v, v);
}

RTK_HD static inline rtk_rgb schlick_rgb(float c, rtk_rgb f0)
{
    return rtk_rgb_make(schlick(c, f0.r), schlick(c, f0.g), schlick(c, f0.b));
}

/* Schlick's F averaged over the hemisphere with weight 2 cos: f0 + (1 - f0) / 21. */
RTK_HD static inline rtk_rgb schlick_mean(rtk_rgb f0)
{
    return rtk_rgb_make(f0.r + (1.0f - f0.r) / 21.0f, f0.g + (1.0f - f0.g) / 21.0f, f0.b + (1.0f - f0.b) / 21.0f);
}

RTK_HD static inline rtk_rgb ggx_fresnel(const rtk_lobe *l, float c)
{
    if (l->fresnel == RTK_FRESNEL_CONDUCTOR)
        return rtk_rgb_make(fresnel_conductor(c, l->eta.r, l->k.r), fresnel_conductor(c, l->eta.g, l->k.g),
                            fresnel_conductor(c, l->eta.b, l->k.b));
    return schlick_rgb(c, l->f0);
}

RTK_HD static inline float clamp01(float c)
{
    return c > 0.0f ? (c < 1.0f ? c : 1.0f) : 0.0f;
}

/* The GGX reflection of wo and wi, both above the surface, about
 * m = normalize(wo + wi): *spec = D G2 / (4 wo.z wi.z) (f without
 * Fresnel), *cos_om = wo.m in [0, 1]; returns the visible-normal pdf
 * D_wo(m) / (4 wo.m) = G1(wo) D(m) / (4 wo.z). */
RTK_HD static inline float ggx_reflection(float alpha, rtk_vec3 wo, rtk_vec3 wi, float *spec, float *cos_om)
{
    rtk_vec3 m = rtk_vec3_normalize(rtk_vec3_add(wo, wi));
    float lo = ggx_lambda(alpha, wo), d = ggx_d(alpha, m);
    *spec = d / (1.0f + lo + ggx_lambda(alpha, wi)) / (4.0f * wo.z * wi.z);
    *cos_om = clamp01(rtk_vec3_dot(wo, m));
    return d / (1.0f + lo) / (4.0f * wo.z);
}

/* wo mirrored about the unit normal m. */
RTK_HD static inline rtk_vec3 reflect_about(rtk_vec3 wo, rtk_vec3 m)
{
    return rtk_vec3_sub(rtk_vec3_scale(m, 2.0f * rtk_vec3_dot(wo, m)), wo);
}

RTK_HD static inline int ior_valid(float ior)
{
    return ior > 0.0f && isfinite(ior);
}

/* Probability that a dielectric reflects, given Fresnel F and the tint
 * that scales its transmission: F / (F + (1 - F) luminance(tint)). */
RTK_HD static inline float reflect_probability(float fr, rtk_rgb tint)
{
    float total = fr + (1.0f - fr) * luminance(tint);
    return total > 0.0f ? fr / total : 1.0f;
}

/* A rough dielectric of relative index within this of 1 bends no light:
 * it is the smooth one. */
#define ROUGH_IOR_EPS 1e-3f

/* The type l behaves as. */
RTK_HD static inline rtk_lobe_type lobe_type(const rtk_lobe *l)
{
    if (l->type == RTK_LOBE_ROUGH_DIELECTRIC && fabsf(l->ior - 1.0f) < ROUGH_IOR_EPS)
        return RTK_LOBE_DIELECTRIC;
    return l->type;
}

/* Plastic's probability of sampling the coat for wo above the surface. */
RTK_HD static inline float plastic_coat_probability(const rtk_lobe *l, float cos_o)
{
    rtk_rgb fr = schlick_rgb(clamp01(cos_o), l->f0);
    float coat = fmaxf(luminance(fr), 0.05f);
    float base = luminance(rtk_rgb_mul(l->albedo, rtk_rgb_make(1.0f - fr.r, 1.0f - fr.g, 1.0f - fr.b)));
    return coat / (coat + base);
}

RTK_HD static inline float plastic_eval_pdf(const rtk_lobe *l, rtk_vec3 wo, rtk_vec3 wi, rtk_rgb *f)
{
    float spec, c;
    float coat_pdf = ggx_reflection(lobe_alpha(l), wo, wi, &spec, &c);
    float pc = plastic_coat_probability(l, wo.z);
    if (f) {
        rtk_rgb fr = schlick_rgb(c, l->f0);
        rtk_rgb fo = schlick_rgb(clamp01(wo.z), l->f0), fi = schlick_rgb(clamp01(wi.z), l->f0);
        f->r = fr.r * spec + l->albedo.r * INV_PI * (1.0f - fo.r) * (1.0f - fi.r);
        f->g = fr.g * spec + l->albedo.g * INV_PI * (1.0f - fo.g) * (1.0f - fi.g);
        f->b = fr.b * spec + l->albedo.b * INV_PI * (1.0f - fo.b) * (1.0f - fi.b);
    }
    return pc * coat_pdf + (1.0f - pc) * wi.z * INV_PI;
}

/* wo and wi in the frame where wo is above: the mirror image through the
 * surface when wo arrives from inside; *eta becomes the index across
 * relative to wo's side. */
RTK_HD static inline void to_wo_side(float ior, rtk_vec3 *wo, rtk_vec3 *wi, float *eta)
{
    *eta = ior;
    if (wo->z < 0.0f) {
        *eta = 1.0f / ior;
        wo->z = -wo->z;
        wi->z = -wi->z;
    }
}

RTK_HD static inline float rough_dielectric_eval_pdf(const rtk_lobe *l, rtk_vec3 wo, rtk_vec3 wi, rtk_rgb *f)
{
    if (!(ior_valid(l->ior) && wo.z != 0.0f && wi.z != 0.0f && isfinite(wo.z) && isfinite(wi.z)))
        return 0.0f;
    float eta;
    to_wo_side(l->ior, &wo, &wi, &eta);
    int reflect = wi.z > 0.0f;
    rtk_vec3 m = reflect ? rtk_vec3_add(wo, wi) : rtk_vec3_add(wo, rtk_vec3_scale(wi, eta));
    float len2 = rtk_vec3_dot(m, m);
    if (!(len2 > 0.0f))
        return 0.0f;
    m = rtk_vec3_scale(m, (m.z < 0.0f ? -1.0f : 1.0f) / sqrtf(len2));
    float om = rtk_vec3_dot(wo, m), im = rtk_vec3_dot(wi, m);
    if (!(om > 0.0f) || (reflect ? !(im > 0.0f) : !(im < 0.0f)))
        return 0.0f;
    float alpha = lobe_alpha(l), cos_t;
    float fr = fresnel_dielectric(fminf(om, 1.0f), eta, &cos_t);
    float pr = reflect_probability(fr, l->tint);
    float lo = ggx_lambda(alpha, wo), d = ggx_d(alpha, m);
    float g2 = 1.0f / (1.0f + lo + ggx_lambda(alpha, wi));
    float visible = d / (1.0f + lo) / wo.z; /* D_wo(m) / (wo.m) */
    if (reflect) {
        if (f)
            *f = rgb_gray(fr * d * g2 / (4.0f * wo.z * wi.z));
        return pr * visible / 4.0f;
    }
    float denom = im + om / eta;
    float jacobian = -im / (denom * denom); /* dm / dwi of refraction */
    if (f)
        *f = rtk_rgb_scale(l->tint, (1.0f - fr) * d * g2 * om * jacobian / (-wo.z * wi.z));
    return (1.0f - pr) * visible * om * jacobian;
}

/* f (when f is given) and pdf of lobe l for wo, wi; 0 for a delta lobe. */
RTK_HD static inline float lobe_eval_pdf(const rtk_lobe *l, rtk_vec3 wo, rtk_vec3 wi, rtk_rgb *f)
{
    if (f)
        *f = rgb_zero();
    rtk_lobe_type type = lobe_type(l);
    if (type == RTK_LOBE_ROUGH_DIELECTRIC)
        return rough_dielectric_eval_pdf(l, wo, wi, f);
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return 0.0f;
    switch (type) {
    case RTK_LOBE_LAMBERT:
        if (f)
            *f = rtk_rgb_scale(l->albedo, INV_PI);
        return wi.z * INV_PI;
    case RTK_LOBE_OREN_NAYAR:
        if (f)
            *f = rtk_rgb_scale(l->albedo, oren_nayar(rtk_oren_nayar_sigma(l->sigma), wo, wi));
        return wi.z * INV_PI;
    case RTK_LOBE_GGX: {
        float spec, c;
        float pdf = ggx_reflection(lobe_alpha(l), wo, wi, &spec, &c);
        if (f)
            *f = rtk_rgb_scale(ggx_fresnel(l, c), spec);
        return pdf;
    }
    case RTK_LOBE_PLASTIC:
        return plastic_eval_pdf(l, wo, wi, f);
    case RTK_LOBE_DIELECTRIC:
    case RTK_LOBE_ROUGH_DIELECTRIC:
        return 0.0f;
    }
    return 0.0f;
}

RTK_HD static inline unsigned lobe_flags(const rtk_lobe *l)
{
    switch (lobe_type(l)) {
    case RTK_LOBE_LAMBERT:
    case RTK_LOBE_OREN_NAYAR:
        return RTK_BSDF_REFLECTION | RTK_BSDF_DIFFUSE;
    case RTK_LOBE_GGX:
        return RTK_BSDF_REFLECTION | RTK_BSDF_GLOSSY;
    case RTK_LOBE_DIELECTRIC:
        return RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA;
    case RTK_LOBE_ROUGH_DIELECTRIC:
        return RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION | RTK_BSDF_GLOSSY;
    case RTK_LOBE_PLASTIC:
        return RTK_BSDF_REFLECTION | RTK_BSDF_GLOSSY | RTK_BSDF_DIFFUSE;
    }
    return 0;
}

/* The lobe's nominal albedo for choosing it (the header's table). */
RTK_HD static inline float lobe_nominal(const rtk_lobe *l)
{
    switch (l->type) {
    case RTK_LOBE_LAMBERT:
    case RTK_LOBE_OREN_NAYAR:
        return luminance(l->albedo);
    case RTK_LOBE_GGX:
        return l->fresnel == RTK_FRESNEL_CONDUCTOR ? 1.0f : luminance(schlick_mean(l->f0));
    case RTK_LOBE_DIELECTRIC:
    case RTK_LOBE_ROUGH_DIELECTRIC:
        return 1.0f;
    case RTK_LOBE_PLASTIC: {
        rtk_rgb fa = schlick_mean(l->f0);
        rtk_rgb rest = rtk_rgb_mul(rtk_rgb_make(1.0f - fa.r, 1.0f - fa.g, 1.0f - fa.b), l->albedo);
        return luminance(rtk_rgb_add(fa, rest));
    }
    }
    return 0.0f;
}

/* The smooth dielectric's mirror reflection or Snell's refraction, chosen
 * by u against reflect_probability; the header states f, pdf and flags. */
RTK_HD static inline int dielectric_sample(const rtk_lobe *l, rtk_vec3 wo, float u, rtk_bsdf_sample_out *out)
{
    if (!(ior_valid(l->ior) && wo.z != 0.0f && isfinite(wo.z)))
        return 0;
    int inside = wo.z < 0.0f;
    float eta = inside ? 1.0f / l->ior : l->ior;
    float c = fminf(fabsf(wo.z), 1.0f), cos_t;
    float fr = fresnel_dielectric(c, eta, &cos_t);
    float pr = reflect_probability(fr, l->tint);
    if (u < pr) {
        out->wi = rtk_vec3_make(-wo.x, -wo.y, wo.z);
        out->pdf = pr;
        out->f = rgb_gray(fr / fabsf(out->wi.z));
        out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_DELTA;
    } else {
        out->wi = rtk_vec3_make(-wo.x / eta, -wo.y / eta, inside ? cos_t : -cos_t);
        out->pdf = 1.0f - pr;
        out->f = rtk_rgb_scale(l->tint, (1.0f - fr) / fabsf(out->wi.z));
        out->flags = RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA;
    }
    return out->pdf > 0.0f && is_finite3(out->f);
}

/* A visible normal from wo's side, then reflection or refraction through
 * it chosen by u_choice; fills out->wi and out->flags. */
RTK_HD static inline int rough_dielectric_sample(const rtk_lobe *l, rtk_vec3 wo, float u_choice, rtk_vec2 u,
                                                  rtk_bsdf_sample_out *out)
{
    if (!(ior_valid(l->ior) && wo.z != 0.0f && isfinite(wo.z)))
        return 0;
    float eta, sign = wo.z < 0.0f ? -1.0f : 1.0f;
    rtk_vec3 wi = wo;
    to_wo_side(l->ior, &wo, &wi, &eta);
    rtk_vec3 m = ggx_sample_visible_normal(lobe_alpha(l), wo, u);
    float om = clamp01(rtk_vec3_dot(wo, m)), cos_t;
    float fr = fresnel_dielectric(om, eta, &cos_t);
    if (u_choice < reflect_probability(fr, l->tint)) {
        wi = reflect_about(wo, m);
        out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_GLOSSY;
        if (!(wi.z > 0.0f))
            return 0;
    } else {
        wi = rtk_vec3_add(rtk_vec3_scale(wo, -1.0f / eta), rtk_vec3_scale(m, om / eta - cos_t));
        out->flags = RTK_BSDF_TRANSMISSION | RTK_BSDF_GLOSSY;
        if (!(wi.z < 0.0f))
            return 0;
    }
    out->wi = rtk_vec3_make(wi.x, wi.y, sign * wi.z);
    return 1;
}

/* Lobe l's direction for wo; a delta lobe also fills out->f and out->pdf
 * (of the lobe alone), the others leave them to the mixture. */
RTK_HD static inline int lobe_sample(const rtk_lobe *l, rtk_vec3 wo, float u_choice, rtk_vec2 u,
                                     rtk_bsdf_sample_out *out)
{
    rtk_lobe_type type = lobe_type(l);
    if (type == RTK_LOBE_DIELECTRIC)
        return dielectric_sample(l, wo, u_choice, out);
    if (type == RTK_LOBE_ROUGH_DIELECTRIC)
        return rough_dielectric_sample(l, wo, u_choice, u, out);
    if (!(wo.z > 0.0f))
        return 0;
    switch (type) {
    case RTK_LOBE_LAMBERT:
    case RTK_LOBE_OREN_NAYAR:
        out->wi = cosine_hemisphere(u);
        out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_DIFFUSE;
        return 1;
    case RTK_LOBE_GGX:
        out->wi = reflect_about(wo, ggx_sample_visible_normal(lobe_alpha(l), wo, u));
        out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_GLOSSY;
        return 1;
    case RTK_LOBE_PLASTIC:
        if (u_choice < plastic_coat_probability(l, wo.z)) {
            out->wi = reflect_about(wo, ggx_sample_visible_normal(lobe_alpha(l), wo, u));
            out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_GLOSSY;
        } else {
            out->wi = cosine_hemisphere(u);
            out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_DIFFUSE;
        }
        return 1;
    case RTK_LOBE_DIELECTRIC:
    case RTK_LOBE_ROUGH_DIELECTRIC:
        return 0;
    }
    return 0;
}

RTK_HD static inline int lobe_count(const rtk_bsdf *b)
{
    return b->count < RTK_BSDF_MAX_LOBES ? (int)b->count : RTK_BSDF_MAX_LOBES;
}

/* The probability p[i] of choosing each lobe (the header's rule); returns
 * the number of lobes. */
RTK_HD static inline int lobe_probabilities(const rtk_bsdf *b, float p[RTK_BSDF_MAX_LOBES])
{
    int n = lobe_count(b);
    float total = 0.0f;
    for (int i = 0; i < n; i++) {
        float s = luminance(b->weight[i]) * lobe_nominal(&b->lobe[i]);
        p[i] = s > 0.0f && isfinite(s) ? s : 0.0f;
        total += p[i];
    }
    for (int i = 0; i < n; i++)
        p[i] = total > 0.0f && isfinite(total) ? p[i] / total : 1.0f / (float)n;
    return n;
}

/* Sum of weight_i f_i (into *f when given) and returns sum of p_i pdf_i
 * over the non-delta lobes; lobe `one`'s own pdf goes to *one_pdf when
 * given. */
RTK_HD static inline float mixture_eval_pdf(const rtk_bsdf *b, const float *p, int n, rtk_vec3 wo, rtk_vec3 wi,
                                            rtk_rgb *f, int one, float *one_pdf)
{
    float pdf = 0.0f;
    if (f)
        *f = rgb_zero();
    for (int i = 0; i < n; i++) {
        rtk_rgb fi;
        float pi = lobe_eval_pdf(&b->lobe[i], wo, wi, f ? &fi : NULL);
        if (i == one && one_pdf)
            *one_pdf = pi;
        pdf += p[i] * pi;
        if (f)
            *f = rtk_rgb_add(*f, rtk_rgb_mul(b->weight[i], fi));
    }
    return pdf;
}

RTK_HD static inline rtk_rgb rtk_lobes_eval(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi)
{
    float p[RTK_BSDF_MAX_LOBES];
    int n = lobe_probabilities(bsdf, p);
    rtk_rgb f;
    mixture_eval_pdf(bsdf, p, n, wo, wi, &f, -1, NULL);
    return f;
}

RTK_HD static inline float rtk_lobes_pdf(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi)
{
    float p[RTK_BSDF_MAX_LOBES];
    int n = lobe_probabilities(bsdf, p);
    return mixture_eval_pdf(bsdf, p, n, wo, wi, NULL, -1, NULL);
}

RTK_HD static inline unsigned rtk_lobes_flags(const rtk_bsdf *bsdf)
{
    unsigned flags = 0;
    for (int i = 0; i < lobe_count(bsdf); i++)
        flags |= lobe_flags(&bsdf->lobe[i]);
    return flags;
}

RTK_HD static inline int rtk_lobes_sample(const rtk_bsdf *bsdf, rtk_vec3 wo, float u_lobe, rtk_vec2 u,
                                          rtk_bsdf_sample_out *out)
{
    float p[RTK_BSDF_MAX_LOBES];
    int n = lobe_probabilities(bsdf, p);
    if (n == 0)
        return 0;
    int i = 0;
    float below = 0.0f;
    while (i < n - 1 && !(u_lobe < below + p[i]))
        below += p[i++];
    while (i > 0 && !(p[i] > 0.0f)) /* rounding ran past the last lobe that can be chosen */
        i--;
    if (!(p[i] > 0.0f))
        return 0;
    float u_choice = (u_lobe - below) / p[i];
    u_choice = u_choice > 0.0f ? (u_choice < 1.0f ? u_choice : 0x1.fffffep-1f) : 0.0f;
    rtk_bsdf_sample_out s;
    if (!lobe_sample(&bsdf->lobe[i], wo, u_choice, u, &s))
        return 0;
    if (s.flags & RTK_BSDF_DELTA) {
        s.f = rtk_rgb_mul(bsdf->weight[i], s.f);
        s.pdf *= p[i];
    } else {
        /* f and pdf through the same code as eval and pdf, so that they agree exactly; a
         * direction the chosen lobe cannot return (a reflection below the surface) fails
         * even where another lobe's pdf covers it. */
        float own = 0.0f;
        s.pdf = mixture_eval_pdf(bsdf, p, n, wo, s.wi, &s.f, i, &own);
        if (!(own > 0.0f))
            return 0;
    }
    if (!(s.pdf > 0.0f))
        return 0;
    *out = s;
    return 1;
}

#endif
