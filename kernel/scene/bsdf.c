/* The BSDF lobes of include/rtk/bsdf.h: Lambert, Fujii's Oren-Nayar, the
 * GGX conductor sampled by visible normals and the smooth dielectric. Everything is in the local
 * shading frame (normal +z); the header states the conventions. */
#include <rtk/bsdf.h>

#include <math.h>

#define INV_PI ((float)(1.0 / RTK_PI))

static rtk_rgb rgb_zero(void)
{
    return rtk_rgb_make(0.0f, 0.0f, 0.0f);
}

/* A point on the unit disk from u, area-preserving (Shirley and Chiu 1997). */
static rtk_vec2 concentric_disk(rtk_vec2 u)
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
static rtk_vec3 cosine_hemisphere(rtk_vec2 u)
{
    rtk_vec2 d = concentric_disk(u);
    float z2 = 1.0f - d.x * d.x - d.y * d.y;
    return rtk_vec3_make(d.x, d.y, sqrtf(z2 > 1e-12f ? z2 : 1e-12f));
}

static float clamp_sigma(float sigma)
{
    return rtk_oren_nayar_sigma(sigma);
}

static float ggx_alpha(const rtk_bsdf *b)
{
    return b->alpha > RTK_GGX_ALPHA_MIN ? b->alpha : RTK_GGX_ALPHA_MIN;
}

/* Fujii's improved Oren-Nayar, without albedo. */
static float oren_nayar(float sigma, rtk_vec3 wo, rtk_vec3 wi)
{
    float a = 1.0f / (float)(RTK_PI + (RTK_PI / 2.0 - 2.0 / 3.0) * sigma);
    float s = rtk_vec3_dot(wi, wo) - wi.z * wo.z;
    float t = s > 0.0f ? fmaxf(wi.z, wo.z) : 1.0f;
    float f = a * (1.0f + sigma * s / t);
    return f > 0.0f ? f : 0.0f;
}

/* GGX normal distribution of the unit microfacet normal m. */
static float ggx_d(float alpha, rtk_vec3 m)
{
    float a2 = alpha * alpha;
    float t = m.x * m.x + m.y * m.y + a2 * m.z * m.z;
    return a2 / ((float)RTK_PI * t * t);
}

/* Smith's Lambda for direction w (w.z > 0). */
static float ggx_lambda(float alpha, rtk_vec3 w)
{
    float tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
    return 0.5f * (sqrtf(1.0f + alpha * alpha * tan2) - 1.0f);
}

/* Unpolarised reflectance of a conductor eta + i k at cosine c (pbrt-v3's FrConductor). */
static float fresnel_conductor(float c, float eta, float k)
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
static float fresnel_dielectric(float c, float eta, float *cos_t)
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

static float schlick(float c, float f0)
{
    float m = 1.0f - c;
    float m2 = m * m;
    return f0 + (1.0f - f0) * m2 * m2 * m;
}

static rtk_rgb ggx_fresnel(const rtk_bsdf *b, float c)
{
    if (b->fresnel == RTK_FRESNEL_CONDUCTOR)
        return rtk_rgb_make(fresnel_conductor(c, b->eta.r, b->k.r), fresnel_conductor(c, b->eta.g, b->k.g),
                            fresnel_conductor(c, b->eta.b, b->k.b));
    return rtk_rgb_make(schlick(c, b->f0.r), schlick(c, b->f0.g), schlick(c, b->f0.b));
}

/* The half vector of wo and wi, both above the surface. */
static rtk_vec3 half_vector(rtk_vec3 wo, rtk_vec3 wi)
{
    return rtk_vec3_normalize(rtk_vec3_add(wo, wi));
}

static rtk_rgb ggx_eval(const rtk_bsdf *b, rtk_vec3 wo, rtk_vec3 wi)
{
    float alpha = ggx_alpha(b);
    rtk_vec3 m = half_vector(wo, wi);
    float g2 = 1.0f / (1.0f + ggx_lambda(alpha, wo) + ggx_lambda(alpha, wi));
    float scale = ggx_d(alpha, m) * g2 / (4.0f * wo.z * wi.z);
    float c = rtk_vec3_dot(wo, m);
    return rtk_rgb_scale(ggx_fresnel(b, c > 0.0f ? (c < 1.0f ? c : 1.0f) : 0.0f), scale);
}

/* D_wo(m) / (4 wo.m) = G1(wo) D(m) / (4 wo.z). */
static float ggx_pdf(const rtk_bsdf *b, rtk_vec3 wo, rtk_vec3 wi)
{
    float alpha = ggx_alpha(b);
    rtk_vec3 m = half_vector(wo, wi);
    float g1 = 1.0f / (1.0f + ggx_lambda(alpha, wo));
    return g1 * ggx_d(alpha, m) / (4.0f * wo.z);
}

/* A visible normal for wo (Heitz 2018, "Sampling the GGX Distribution of
 * Visible Normals", listing 1, isotropic). */
static rtk_vec3 ggx_sample_visible_normal(float alpha, rtk_vec3 wo, rtk_vec2 u)
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

rtk_rgb rtk_bsdf_eval(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return rgb_zero();
    switch (bsdf->type) {
    case RTK_BSDF_LAMBERT:
        return rtk_rgb_scale(bsdf->albedo, INV_PI);
    case RTK_BSDF_OREN_NAYAR:
        return rtk_rgb_scale(bsdf->albedo, oren_nayar(clamp_sigma(bsdf->sigma), wo, wi));
    case RTK_BSDF_GGX:
        return ggx_eval(bsdf, wo, wi);
    case RTK_BSDF_DIELECTRIC:
        return rgb_zero();
    }
    return rgb_zero();
}

float rtk_bsdf_pdf(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return 0.0f;
    switch (bsdf->type) {
    case RTK_BSDF_LAMBERT:
    case RTK_BSDF_OREN_NAYAR:
        return wi.z * INV_PI;
    case RTK_BSDF_GGX:
        return ggx_pdf(bsdf, wo, wi);
    case RTK_BSDF_DIELECTRIC:
        return 0.0f;
    }
    return 0.0f;
}

unsigned rtk_bsdf_flags(const rtk_bsdf *bsdf)
{
    switch (bsdf->type) {
    case RTK_BSDF_LAMBERT:
    case RTK_BSDF_OREN_NAYAR:
        return RTK_BSDF_REFLECTION | RTK_BSDF_DIFFUSE;
    case RTK_BSDF_GGX:
        return RTK_BSDF_REFLECTION | RTK_BSDF_GLOSSY;
    case RTK_BSDF_DIELECTRIC:
        return RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA;
    }
    return 0;
}

/* The dielectric's mirror reflection with probability F, else Snell's
 * refraction; the header states f, pdf and the flags. */
static int dielectric_sample(float ior, rtk_vec3 wo, float u, rtk_bsdf_sample_out *out)
{
    if (!(ior > 0.0f && isfinite(ior) && wo.z != 0.0f && isfinite(wo.z)))
        return 0;
    int inside = wo.z < 0.0f;
    float eta = inside ? 1.0f / ior : ior;
    float c = fminf(fabsf(wo.z), 1.0f), cos_t;
    float fr = fresnel_dielectric(c, eta, &cos_t);
    if (u < fr) {
        out->wi = rtk_vec3_make(-wo.x, -wo.y, wo.z);
        out->pdf = fr;
        out->flags = RTK_BSDF_REFLECTION | RTK_BSDF_DELTA;
    } else {
        out->wi = rtk_vec3_make(-wo.x / eta, -wo.y / eta, inside ? cos_t : -cos_t);
        out->pdf = 1.0f - fr;
        out->flags = RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA;
    }
    float w = out->pdf / fabsf(out->wi.z);
    out->f = rtk_rgb_make(w, w, w);
    return 1;
}

int rtk_bsdf_sample(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec2 u, rtk_bsdf_sample_out *out)
{
    if (bsdf->type == RTK_BSDF_DIELECTRIC)
        return dielectric_sample(bsdf->ior, wo, u.x, out);
    if (!(wo.z > 0.0f))
        return 0;
    rtk_vec3 wi;
    switch (bsdf->type) {
    case RTK_BSDF_LAMBERT:
    case RTK_BSDF_OREN_NAYAR:
        wi = cosine_hemisphere(u);
        break;
    case RTK_BSDF_GGX: {
        rtk_vec3 m = ggx_sample_visible_normal(ggx_alpha(bsdf), wo, u);
        wi = rtk_vec3_sub(rtk_vec3_scale(m, 2.0f * rtk_vec3_dot(wo, m)), wo);
        break;
    }
    default:
        return 0;
    }
    /* f and pdf through eval and pdf, so that they agree with them exactly. */
    float pdf = rtk_bsdf_pdf(bsdf, wo, wi);
    if (!(pdf > 0.0f))
        return 0;
    out->wi = wi;
    out->f = rtk_bsdf_eval(bsdf, wo, wi);
    out->pdf = pdf;
    out->flags = rtk_bsdf_flags(bsdf);
    return 1;
}
