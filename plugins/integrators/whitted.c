/* whitted: classic recursive ray tracing with the kernel's BSDFs
 * (rtk_surface_bsdf, include/rtk/bsdf.h). Rays that leave the scene see
 * the environment (rtk_scene_environment); front faces show their
 * emission.
 *
 * Direct light: every point, spot and directional light, each in turn
 * (deterministic), with a hard shadow (rtk_shadow_ray, rtk_occluded) and
 * the irradiance I / r^2 x rtk_spot_falloff (E for directional lights),
 * through rtk_bsdf_eval of the non-delta lobes: Lambert or Oren-Nayar
 * diffuse, GGX highlights, plastic. Lights below the geometric surface
 * are not seen (no light through transmission).
 *
 * Recursion, deterministic, up to max_depth bounces after the camera ray:
 * - a dielectric lobe (smooth, or rough: whitted follows single
 *   directions, so it is traced as the smooth one of its ior) sends a
 *   reflected ray weighted by its Fresnel reflectance and a refracted ray
 *   weighted by tint x (1 - F), both from rtk_bsdf_sample's two events;
 *   past the critical angle only the reflection (total internal reflection);
 * - a GGX or plastic coat with alpha <= mirror_alpha is treated as a
 *   mirror weighted by its Fresnel at wo (whitted's approximation of a
 *   glossy lobe; F read from rtk_bsdf_eval at the mirror direction, as the
 *   lobe over the same lobe with F = 1); its highlights from the lights
 *   stay, since reflected rays never see a punctual light.
 * The camera ray's differentials follow every mirror and refraction
 * bounce (pbrt-v3's specular differentials), so textures seen in a
 * mirror or through glass are filtered as if seen directly.
 *
 * diffuse = "oren-nayar" turns the diffuse parts into Fujii's Oren-Nayar
 * (as the real-time tracer rtk grew from): sigma = rtk_oren_nayar_sigma(r)
 * with r = sqrt(alpha) of the mixture's first microfacet lobe, the
 * material's perceptual roughness (glTF roughness x texture, MTL Pr; for
 * MTL without Pr, from Ns through alpha = sqrt(2 / (Ns + 2))), 0 at
 * alpha = RTK_GGX_ALPHA_MIN (roughness up to sqrt(1e-3) = 0.032). A Lambert
 * lobe alone (MTL illum 0 or 1 or Ks 0, materials made in memory) has no
 * roughness and stays Lambert. The plastic base becomes Oren-Nayar under
 * the same coat: the base's value (the plastic less its coat) times
 * Oren-Nayar over Lambert, each from rtk_bsdf_eval.
 *
 * ambient adds ambient x the diffuse albedo (Lambert, Oren-Nayar and
 * plastic bases, by their weights) regardless of the lights.
 *
 * Parameters:
 *   max_depth     int [0, 64]     4             mirror and refraction bounces
 *   ambient       float [0, 1]    0.0           diffuse albedo added regardless of lights
 *   diffuse       string          "oren-nayar"  "lambert" or "oren-nayar"
 *   mirror_alpha  float [0, 1]    0.15          GGX alpha up to which a coat reflects as a mirror
 *
 * Example: integrator = { plugin = "whitted"; max_depth = 8; diffuse = "lambert"; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct whitted {
    int max_depth;
    float ambient;
    int oren_nayar;
    float mirror_alpha;
} whitted;

static rtk_status whitted_create(const rtk_params *params, void **state)
{
    whitted *w = malloc(sizeof *w);
    if (!w)
        return rtk_error(RTK_ERR_NOMEM, "whitted: out of memory");
    w->max_depth = (int)rtk_params_int(params, "max_depth");
    w->ambient = (float)rtk_params_float(params, "ambient");
    w->oren_nayar = strcmp(rtk_params_string(params, "diffuse"), "oren-nayar") == 0;
    w->mirror_alpha = (float)rtk_params_float(params, "mirror_alpha");
    *state = w;
    return RTK_OK;
}

static uint32_t whitted_needs(const void *state)
{
    (void)state;
    return RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
}

static rtk_status whitted_prepare(void *state, const rtk_scene *scene)
{
    (void)state;
    if (rtk_scene_punctual_count(scene) == 0)
        rtk_log(RTK_LOG_WARN, "whitted: the scene has no point, spot or directional lights "
                              "(config `lights` or glTF KHR_lights_punctual): only emission will show");
    return RTK_OK;
}

static rtk_vec3 reflect(rtk_vec3 wo, rtk_vec3 n)
{
    return rtk_vec3_sub(rtk_vec3_scale(n, 2.0f * rtk_vec3_dot(wo, n)), wo);
}

static int is_black(rtk_rgb c)
{
    return !(c.r > 0.0f || c.g > 0.0f || c.b > 0.0f);
}

static float max3(rtk_rgb c)
{
    return fmaxf(c.r, fmaxf(c.g, c.b));
}

static int is_dielectric(const rtk_lobe *l)
{
    return l->type == RTK_LOBE_DIELECTRIC || l->type == RTK_LOBE_ROUGH_DIELECTRIC;
}

/* The shading at a hit: the BSDF, its frame and wo in it. */
typedef struct shading {
    rtk_bsdf bsdf;
    rtk_frame frame; /* around ns on wo's side, or on the authored side for a BSDF that transmits */
    rtk_vec3 wo;     /* local */
    float sigma;     /* Oren-Nayar sigma of the diffuse parts; 0: Lambert */
} shading;

/* Oren-Nayar sigma from the perceptual roughness sqrt(alpha) of b's first
 * microfacet lobe; 0 without one, or at the smallest alpha (roughness 0). */
static float diffuse_sigma(const rtk_bsdf *b)
{
    for (uint32_t i = 0; i < b->count; i++)
        if (b->lobe[i].type == RTK_LOBE_GGX || b->lobe[i].type == RTK_LOBE_PLASTIC ||
            b->lobe[i].type == RTK_LOBE_ROUGH_DIELECTRIC)
            return b->lobe[i].alpha > RTK_GGX_ALPHA_MIN ? rtk_oren_nayar_sigma(sqrtf(b->lobe[i].alpha)) : 0.0f;
    return 0.0f;
}

static void shading_at(const whitted *w, const rtk_scene *scene, const rtk_hit *hit, const rtk_surface *s,
                       rtk_vec3 wo_world, shading *out)
{
    rtk_surface_bsdf(scene, hit, s, &out->bsdf);
    int flip = (rtk_bsdf_flags(&out->bsdf) & RTK_BSDF_TRANSMISSION) && !s->front_face;
    out->frame = rtk_frame_from_normal(flip ? rtk_vec3_neg(s->ns) : s->ns);
    out->wo = rtk_frame_to_local(&out->frame, wo_world);
    out->sigma = w->oren_nayar ? diffuse_sigma(&out->bsdf) : 0.0f;
    if (out->sigma > 0.0f)
        for (uint32_t i = 0; i < out->bsdf.count; i++)
            if (out->bsdf.lobe[i].type == RTK_LOBE_LAMBERT)
                out->bsdf.lobe[i] = rtk_lobe_oren_nayar(out->bsdf.lobe[i].albedo, out->sigma);
}

/* weight x lobe l's f at (wo, wi), from rtk_bsdf_eval. */
static rtk_rgb lobe_eval(rtk_rgb weight, rtk_lobe l, rtk_vec3 wo, rtk_vec3 wi)
{
    rtk_bsdf b = rtk_bsdf_of(l);
    return rtk_rgb_mul(weight, rtk_bsdf_eval(&b, wo, wi));
}

/* f(wo, wi) of the non-delta lobes; with sigma > 0 the plastic bases are
 * Oren-Nayar: base (plastic less its coat) x Oren-Nayar / Lambert. */
static rtk_rgb shading_eval(const shading *sh, rtk_vec3 wi)
{
    if (!(sh->sigma > 0.0f))
        return rtk_bsdf_eval(&sh->bsdf, sh->wo, wi);
    rtk_rgb f = rtk_rgb_make(0, 0, 0), white = rtk_rgb_make(1, 1, 1);
    for (uint32_t i = 0; i < sh->bsdf.count; i++) {
        rtk_lobe l = sh->bsdf.lobe[i];
        rtk_rgb wt = sh->bsdf.weight[i];
        if (l.type != RTK_LOBE_PLASTIC) {
            f = rtk_rgb_add(f, lobe_eval(wt, l, sh->wo, wi));
            continue;
        }
        rtk_lobe coat = l;
        coat.albedo = rtk_rgb_make(0, 0, 0);
        rtk_rgb full = lobe_eval(wt, l, sh->wo, wi), spec = lobe_eval(wt, coat, sh->wo, wi);
        rtk_rgb lambert = lobe_eval(white, rtk_lobe_lambert(white), sh->wo, wi);
        rtk_rgb on = lobe_eval(white, rtk_lobe_oren_nayar(white, sh->sigma), sh->wo, wi);
        if (!(lambert.g > 0.0f))
            continue;
        float ratio = on.g / lambert.g;
        rtk_rgb base = rtk_rgb_make(fmaxf(0.0f, full.r - spec.r), fmaxf(0.0f, full.g - spec.g),
                                    fmaxf(0.0f, full.b - spec.b));
        f = rtk_rgb_add(f, rtk_rgb_add(spec, rtk_rgb_scale(base, ratio)));
    }
    return f;
}

/* Diffuse albedo of the mixture: its Lambert, Oren-Nayar and plastic
 * bases by their weights (what `ambient` shows). */
static rtk_rgb diffuse_albedo(const rtk_bsdf *b)
{
    rtk_rgb sum = rtk_rgb_make(0, 0, 0);
    for (uint32_t i = 0; i < b->count; i++)
        if (b->lobe[i].type == RTK_LOBE_LAMBERT || b->lobe[i].type == RTK_LOBE_OREN_NAYAR ||
            b->lobe[i].type == RTK_LOBE_PLASTIC)
            sum = rtk_rgb_add(sum, rtk_rgb_mul(b->weight[i], b->lobe[i].albedo));
    return sum;
}

/* Light from every punctual light reflected towards wo. */
static rtk_rgb direct(rtk_ctx *ctx, const rtk_surface *s, const shading *sh)
{
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_rgb sum = rtk_rgb_make(0, 0, 0);
    for (uint32_t i = 0; i < rtk_scene_punctual_count(scene); i++) {
        const rtk_punctual_light *l = rtk_scene_punctual(scene, i);
        rtk_vec3 wi;
        float scale;
        rtk_ray shadow;
        if (l->type == RTK_LIGHT_DIRECTIONAL) {
            wi = rtk_vec3_neg(l->direction);
            scale = 1.0f;
            shadow.org = rtk_offset_ray_origin(s->p, s->ng);
            shadow.tmin = 0.0f;
            shadow.dir = wi;
            shadow.tmax = INFINITY;
        } else {
            rtk_vec3 d = rtk_vec3_sub(l->position, s->p);
            float r2 = rtk_vec3_dot(d, d);
            if (!(r2 > 0.0f))
                continue;
            wi = rtk_vec3_scale(d, 1.0f / sqrtf(r2));
            scale = 1.0f / r2;
            if (l->type == RTK_LIGHT_SPOT) {
                float falloff = rtk_spot_falloff(l, -rtk_vec3_dot(wi, l->direction));
                if (falloff <= 0.0f)
                    continue;
                scale *= falloff;
            }
            shadow = rtk_shadow_ray(s->p, s->ng, l->position, rtk_vec3_make(0.0f, 0.0f, 0.0f));
        }
        if (rtk_vec3_dot(s->ng, wi) <= 0.0f)
            continue;
        rtk_vec3 wl = rtk_frame_to_local(&sh->frame, wi);
        rtk_rgb f = shading_eval(sh, wl);
        if (is_black(f) || rtk_occluded(ctx, &shadow))
            continue;
        sum = rtk_rgb_add(sum, rtk_rgb_scale(rtk_rgb_mul(f, l->intensity), fabsf(wl.z) * scale));
    }
    return sum;
}

/* Fresnel reflectance at wo (local, above) of a GGX or plastic coat l:
 * the coat's f at the mirror direction over the same with F = 1, so
 * F(wo.m) with m the normal; black where either is not finite and > 0. */
static rtk_rgb coat_fresnel(const rtk_lobe *l, rtk_vec3 wo)
{
    rtk_rgb white = rtk_rgb_make(1, 1, 1);
    rtk_lobe coat = l->type == RTK_LOBE_PLASTIC ? rtk_lobe_ggx_schlick(l->f0, l->alpha) : *l;
    rtk_lobe unit = rtk_lobe_ggx_schlick(white, coat.alpha);
    rtk_vec3 wi = rtk_vec3_make(-wo.x, -wo.y, wo.z);
    rtk_rgb f = lobe_eval(white, coat, wo, wi), one = lobe_eval(white, unit, wo, wi);
    if (!(one.g > 0.0f) || !isfinite(one.g))
        return rtk_rgb_make(0, 0, 0);
    return rtk_rgb_scale(f, 1.0f / one.g);
}

static rtk_rgb trace(const whitted *w, rtk_ctx *ctx, const rtk_ray *ray, const rtk_ray_differential *diff, int depth,
                     float weight, rtk_li_result *aov);

/* Radiance from the specular events at a hit: mirror-like coats and
 * dielectrics, each weighted as the top says. */
static rtk_rgb specular(const whitted *w, rtk_ctx *ctx, const rtk_ray *ray, const rtk_ray_differential *diff,
                        const rtk_hit *hit, const rtk_surface *s, const shading *sh, int depth, float weight)
{
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_rgb L = rtk_rgb_make(0, 0, 0), mirror = L;
    rtk_ray_differential next;
    for (uint32_t i = 0; i < sh->bsdf.count; i++) {
        const rtk_lobe *l = &sh->bsdf.lobe[i];
        rtk_rgb wt = sh->bsdf.weight[i];
        if ((l->type == RTK_LOBE_GGX || l->type == RTK_LOBE_PLASTIC) && l->alpha <= w->mirror_alpha &&
            sh->wo.z > 0.0f) {
            mirror = rtk_rgb_add(mirror, rtk_rgb_mul(wt, coat_fresnel(l, sh->wo)));
            continue;
        }
        if (!is_dielectric(l))
            continue;
        /* Both events of the smooth dielectric: u_lobe 0 reflects unless F = 0,
         * the largest u_lobe below 1 refracts unless F = 1. */
        rtk_bsdf smooth = rtk_bsdf_of(rtk_lobe_dielectric(l->ior, l->tint));
        const float u_lobe[2] = {0.0f, 0x1.fffffep-1f};
        const rtk_vec2 half = {0.5f, 0.5f};
        unsigned taken = 0;
        for (int e = 0; e < 2; e++) {
            rtk_bsdf_sample_out out;
            if (!rtk_bsdf_sample(&smooth, sh->wo, u_lobe[e], half, &out) || (out.flags & taken))
                continue;
            taken |= out.flags & (RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION);
            rtk_rgb ev = rtk_rgb_mul(wt, rtk_rgb_scale(out.f, fabsf(out.wi.z)));
            if (out.flags & RTK_BSDF_REFLECTION) {
                mirror = rtk_rgb_add(mirror, ev);
                continue;
            }
            if (is_black(ev))
                continue;
            /* eta: the index on the ray's side over the index on wi's side. */
            float eta = s->front_face ? 1.0f / l->ior : l->ior;
            rtk_vec3 dir = rtk_frame_to_world(&sh->frame, out.wi);
            rtk_ray tr = {rtk_offset_ray_origin(s->p, rtk_vec3_neg(s->ng)), 0.0f, dir, INFINITY};
            int has = diff && rtk_differential_refract(scene, ray, diff, hit, s, dir, eta, &next);
            rtk_rgb Lt = trace(w, ctx, &tr, has ? &next : NULL, depth + 1, weight * max3(ev), NULL);
            L = rtk_rgb_add(L, rtk_rgb_mul(ev, Lt));
        }
    }
    if (!is_black(mirror)) {
        rtk_vec3 wo = rtk_vec3_neg(rtk_vec3_normalize(ray->dir));
        rtk_ray r = {rtk_offset_ray_origin(s->p, s->ng), 0.0f, reflect(wo, s->ns), INFINITY};
        int has = diff && rtk_differential_reflect(scene, ray, diff, hit, s, r.dir, &next);
        rtk_rgb Lr = trace(w, ctx, &r, has ? &next : NULL, depth + 1, weight * max3(mirror), NULL);
        L = rtk_rgb_add(L, rtk_rgb_mul(mirror, Lr));
    }
    return L;
}

/* Radiance along ray; diff: its differentials, or NULL. */
static rtk_rgb trace(const whitted *w, rtk_ctx *ctx, const rtk_ray *ray, const rtk_ray_differential *diff, int depth,
                     float weight, rtk_li_result *aov)
{
    rtk_rgb black = rtk_rgb_make(0, 0, 0);
    rtk_hit hit;
    if (weight < 1e-4f)
        return black;
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    if (!rtk_trace(ctx, ray, &hit))
        return rtk_scene_environment(scene, ray->dir);
    rtk_surface s;
    rtk_surface_at_footprint(scene, ray, diff, &hit, &s);
    if (aov) {
        aov->albedo = s.base_color;
        aov->normal = s.ns;
        aov->depth = hit.t * rtk_vec3_length(ray->dir);
    }
    shading sh;
    shading_at(w, scene, &hit, &s, rtk_vec3_neg(rtk_vec3_normalize(ray->dir)), &sh);
    rtk_rgb L = s.front_face ? s.emission : black;
    L = rtk_rgb_add(L, direct(ctx, &s, &sh));
    if (w->ambient > 0.0f)
        L = rtk_rgb_add(L, rtk_rgb_scale(diffuse_albedo(&sh.bsdf), w->ambient));
    if (depth < w->max_depth)
        L = rtk_rgb_add(L, specular(w, ctx, ray, diff, &hit, &s, &sh, depth, weight));
    return L;
}

static void whitted_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    rtk_ray_differential diff;
    int has_diff = rtk_ctx_camera_differential(ctx, &diff);
    out->radiance = trace(state, ctx, ray, has_diff ? &diff : NULL, 0, 1.0f, out);
}

static void whitted_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc whitted_params[] = {
    {.name = "max_depth", .type = RTK_PARAM_INT, .def = 4, .min = 0, .max = 64,
     .doc = "mirror and refraction bounces after the camera ray"},
    {.name = "ambient", .type = RTK_PARAM_FLOAT, .def = 0.0, .min = 0.0, .max = 1.0,
     .doc = "fraction of the diffuse albedo shown regardless of the lights"},
    {.name = "diffuse", .type = RTK_PARAM_STRING, .def_string = "oren-nayar", .choices = "lambert|oren-nayar",
     .doc = "diffuse model: Lambert, or Fujii's Oren-Nayar with sigma from the material's roughness"},
    {.name = "mirror_alpha", .type = RTK_PARAM_FLOAT, .def = 0.15, .min = 0.0, .max = 1.0,
     .doc = "GGX alpha up to which a metal or plastic coat also reflects as a mirror, weighted by its Fresnel"},
};

static const rtk_integrator_fns whitted_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = whitted_create,
    .needs = whitted_needs,
    .prepare = whitted_prepare,
    .li = whitted_li,
    .destroy = whitted_destroy,
};

static const rtk_plugin whitted_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "whitted",
    .version = "2.0",
    .summary = "Whitted ray tracing with the kernel's BSDFs: every punctual light, mirrors, glass",
    .params = whitted_params,
    .param_count = RTK_COUNTOF(whitted_params),
    .functions = &whitted_fns,
    .conform = "whitted-recursion",
};

RTK_PLUGIN_ENTRY(whitted_plugin)
