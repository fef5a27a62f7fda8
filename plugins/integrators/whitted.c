/* whitted: classic recursive ray tracing. Point, spot and directional
 * lights with hard shadows; Lambert diffuse plus a Cook-Torrance GGX lobe
 * (Schlick Fresnel, Smith masking); perfect mirrors; dielectrics with
 * exact Fresnel, refraction and total internal reflection. Rays that
 * leave the scene see the environment (rtk_scene_environment).
 *
 * Materials: MTL illum 3 or 5 is a mirror of reflectance Ks; illum 4, 6, 7
 * or 9, or glTF transmission > 0, is a dielectric of index Ni / ior; glTF
 * metallic 1 with roughness 0 is a mirror of reflectance baseColor. The
 * GGX lobe uses F0 = Ks + metallic (baseColor - Ks) and roughness
 * sqrt(2 / (Ns + 2)) for MTL (illum >= 0) or the glTF roughness.
 * The camera ray's differentials follow every mirror and refraction
 * bounce (pbrt-v3's specular differentials), so textures seen in a
 * mirror or through glass are filtered as if seen directly.
 *
 * Parameters:
 *   max_depth  int [0, 64]    5      mirror and refraction bounces
 *   ambient    float [0, 1]   0.0    base colour added regardless of lights
 *
 * Example: integrator = { plugin = "whitted"; max_depth = 8; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct whitted {
    int max_depth;
    float ambient;
} whitted;

static rtk_status whitted_create(const rtk_params *params, void **state)
{
    whitted *w = malloc(sizeof *w);
    if (!w)
        return rtk_error(RTK_ERR_NOMEM, "whitted: out of memory");
    w->max_depth = (int)rtk_params_int(params, "max_depth");
    w->ambient = (float)rtk_params_float(params, "ambient");
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

/* Unpolarised Fresnel reflectance of a dielectric interface; 1 past the
 * critical angle. cos_i >= 0 is measured on the incident side. */
static float fresnel_dielectric(float cos_i, float eta_i, float eta_t)
{
    float sin_t = eta_i / eta_t * sqrtf(fmaxf(0.0f, 1.0f - cos_i * cos_i));
    if (sin_t >= 1.0f)
        return 1.0f;
    float cos_t = sqrtf(fmaxf(0.0f, 1.0f - sin_t * sin_t));
    float par = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    float perp = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    return 0.5f * (par * par + perp * perp);
}

static rtk_vec3 reflect(rtk_vec3 wo, rtk_vec3 n)
{
    return rtk_vec3_sub(rtk_vec3_scale(n, 2.0f * rtk_vec3_dot(wo, n)), wo);
}

/* GGX microfacet specular for unit wo, wi, n; alpha = roughness^2. */
static rtk_rgb ggx(rtk_vec3 n, rtk_vec3 wo, rtk_vec3 wi, rtk_rgb f0, float alpha)
{
    rtk_vec3 h = rtk_vec3_normalize(rtk_vec3_add(wo, wi));
    float nh = fmaxf(0.0f, rtk_vec3_dot(n, h)), no = rtk_vec3_dot(n, wo), ni = rtk_vec3_dot(n, wi);
    float a2 = fmaxf(alpha * alpha, 1e-7f);
    float d = nh * nh * (a2 - 1.0f) + 1.0f;
    float D = a2 / ((float)RTK_PI * d * d);
    float go = 2.0f * no / (no + sqrtf(a2 + (1.0f - a2) * no * no));
    float gi = 2.0f * ni / (ni + sqrtf(a2 + (1.0f - a2) * ni * ni));
    float s = powf(1.0f - fmaxf(0.0f, rtk_vec3_dot(wo, h)), 5.0f);
    rtk_rgb F = rtk_rgb_make(f0.r + (1.0f - f0.r) * s, f0.g + (1.0f - f0.g) * s, f0.b + (1.0f - f0.b) * s);
    return rtk_rgb_scale(F, D * go * gi / (4.0f * no * ni));
}

/* Light from the punctual lights reflected towards wo. */
static rtk_rgb direct(rtk_ctx *ctx, const rtk_surface *s, rtk_vec3 wo)
{
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_rgb sum = rtk_rgb_make(0, 0, 0);
    rtk_rgb kd = rtk_rgb_scale(s->base_color, (1.0f - s->metallic) / (float)RTK_PI);
    rtk_rgb f0 = rtk_rgb_make(s->specular.r + s->metallic * (s->base_color.r - s->specular.r),
                              s->specular.g + s->metallic * (s->base_color.g - s->specular.g),
                              s->specular.b + s->metallic * (s->base_color.b - s->specular.b));
    int glossy = f0.r > 0.0f || f0.g > 0.0f || f0.b > 0.0f;
    float rough = s->illum >= 0 ? sqrtf(2.0f / (s->shininess + 2.0f)) : s->roughness;
    rtk_vec3 org = rtk_offset_ray_origin(s->p, s->ng);
    for (uint32_t i = 0; i < rtk_scene_punctual_count(scene); i++) {
        const rtk_punctual_light *l = rtk_scene_punctual(scene, i);
        rtk_vec3 wi;
        float scale, tmax;
        rtk_ray shadow;
        shadow.org = org;
        shadow.tmin = 0.0f;
        if (l->type == RTK_LIGHT_DIRECTIONAL) {
            wi = rtk_vec3_neg(l->direction);
            scale = 1.0f;
            shadow.dir = wi;
            tmax = INFINITY;
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
            tmax = 1.0f;
        }
        float cos_i = rtk_vec3_dot(s->ns, wi);
        if (cos_i <= 0.0f || rtk_vec3_dot(s->ng, wi) <= 0.0f)
            continue;
        shadow.tmax = tmax;
        if (rtk_occluded(ctx, &shadow))
            continue;
        rtk_rgb f = kd;
        if (glossy && rtk_vec3_dot(s->ns, wo) > 0.0f)
            f = rtk_rgb_add(f, ggx(s->ns, wo, wi, f0, rough * rough));
        sum = rtk_rgb_add(sum, rtk_rgb_scale(rtk_rgb_mul(f, l->intensity), cos_i * scale));
    }
    return sum;
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
    rtk_ray_differential next;
    if (aov) {
        aov->albedo = s.base_color;
        aov->normal = s.ns;
        aov->depth = hit.t * rtk_vec3_length(ray->dir);
    }
    rtk_vec3 wo = rtk_vec3_neg(rtk_vec3_normalize(ray->dir));
    rtk_rgb L = s.front_face ? s.emission : black;
    int mirror = s.illum == 3 || s.illum == 5 || (s.illum < 0 && s.metallic >= 1.0f && s.roughness <= 0.0f);
    int glass = s.transmission > 0.0f || s.illum == 4 || s.illum == 6 || s.illum == 7 || s.illum == 9;
    if (mirror) {
        if (depth < w->max_depth) {
            rtk_rgb R = s.illum >= 0 ? s.specular : s.base_color;
            rtk_ray r = {rtk_offset_ray_origin(s.p, s.ng), 0.0f, reflect(wo, s.ns), INFINITY};
            int has = diff && rtk_differential_reflect(scene, ray, diff, &hit, &s, r.dir, &next);
            float m = fmaxf(R.r, fmaxf(R.g, R.b));
            L = rtk_rgb_add(L, rtk_rgb_mul(R, trace(w, ctx, &r, has ? &next : NULL, depth + 1, weight * m, NULL)));
        }
        return L;
    }
    rtk_rgb surface = rtk_rgb_add(direct(ctx, &s, wo), rtk_rgb_scale(s.base_color, w->ambient));
    if (!glass)
        return rtk_rgb_add(L, surface);
    /* Dielectric: ns faces the incoming ray; entering when the ray hit the
     * authored (outer) side. */
    float t = s.transmission > 0.0f ? fminf(s.transmission, 1.0f) : 1.0f;
    rtk_rgb through = black;
    if (depth < w->max_depth) {
        float eta_i = s.front_face ? 1.0f : s.ior, eta_t = s.front_face ? s.ior : 1.0f;
        float cos_i = fminf(1.0f, fmaxf(0.0f, rtk_vec3_dot(wo, s.ns)));
        float F = fresnel_dielectric(cos_i, eta_i, eta_t);
        rtk_ray r = {rtk_offset_ray_origin(s.p, s.ng), 0.0f, reflect(wo, s.ns), INFINITY};
        int has = diff && rtk_differential_reflect(scene, ray, diff, &hit, &s, r.dir, &next);
        through = rtk_rgb_scale(trace(w, ctx, &r, has ? &next : NULL, depth + 1, weight * t * F, NULL), F);
        if (F < 1.0f) {
            float eta = eta_i / eta_t;
            float cos_t = sqrtf(fmaxf(0.0f, 1.0f - eta * eta * (1.0f - cos_i * cos_i)));
            rtk_vec3 dir = rtk_vec3_add(rtk_vec3_scale(wo, -eta), rtk_vec3_scale(s.ns, eta * cos_i - cos_t));
            rtk_ray tr = {rtk_offset_ray_origin(s.p, rtk_vec3_neg(s.ng)), 0.0f, dir, INFINITY};
            has = diff && rtk_differential_refract(scene, ray, diff, &hit, &s, dir, eta, &next);
            rtk_rgb Lt = trace(w, ctx, &tr, has ? &next : NULL, depth + 1, weight * t * (1.0f - F), NULL);
            through = rtk_rgb_add(through, rtk_rgb_scale(Lt, 1.0f - F));
        }
    }
    return rtk_rgb_add(L, rtk_rgb_add(rtk_rgb_scale(through, t), rtk_rgb_scale(surface, 1.0f - t)));
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
    {.name = "max_depth", .type = RTK_PARAM_INT, .def = 5, .min = 0, .max = 64,
     .doc = "mirror and refraction bounces after the camera ray"},
    {.name = "ambient", .type = RTK_PARAM_FLOAT, .def = 0.0, .min = 0.0, .max = 1.0,
     .doc = "fraction of the base colour shown regardless of the lights"},
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
    .version = "1.0",
    .summary = "Whitted ray tracing: point lights, GGX highlights, mirrors, glass",
    .params = whitted_params,
    .param_count = RTK_COUNTOF(whitted_params),
    .functions = &whitted_fns,
    .conform = "whitted-recursion",
};

RTK_PLUGIN_ENTRY(whitted_plugin)
