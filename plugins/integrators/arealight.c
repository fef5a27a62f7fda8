/* arealight: direct lighting with soft shadows from every light the
 * kernel's light service knows: emissive triangles, point, spot and
 * directional lights and the environment, one chosen per light sample in
 * proportion to power (rtk_sample_incident_light); optionally combined
 * with cosine-weighted BSDF sampling by multiple importance sampling
 * (power heuristic; delta lights take the light sample alone). Surfaces
 * are Lambertian; camera rays that miss see the environment.
 *
 * Parameters:
 *   light_samples  int [1, 4096]  1      light samples per camera ray
 *   mis            bool           true   also sample the BSDF and weight both (MIS)
 *
 * Example: integrator = { plugin = "arealight"; light_samples = 4; mis = true; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct arealight {
    int samples;
    int mis;
} arealight;

static rtk_status arealight_create(const rtk_params *params, void **state)
{
    arealight *a = malloc(sizeof *a);
    if (!a)
        return rtk_error(RTK_ERR_NOMEM, "arealight: out of memory");
    a->samples = (int)rtk_params_int(params, "light_samples");
    a->mis = rtk_params_bool(params, "mis");
    *state = a;
    return RTK_OK;
}

static uint32_t arealight_needs(const void *state)
{
    (void)state;
    return RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
}

static rtk_status arealight_prepare(void *state, const rtk_scene *scene)
{
    (void)state;
    rtk_light_incident li;
    const rtk_vec2 mid = {0.5f, 0.5f};
    if (!rtk_scene_light_count(scene) && !rtk_scene_punctual_count(scene) &&
        !rtk_sample_incident_light(scene, rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 0, 0), 0.5f, mid, &li))
        rtk_log(RTK_LOG_WARN, "arealight: the scene has no lights (emissive triangles: MTL Ke, glTF emissive; "
                              "config lights or environment): the image will be black");
    return RTK_OK;
}

/* Orthonormal basis around unit n (Duff et al. 2017). */
static void basis(rtk_vec3 n, rtk_vec3 *b1, rtk_vec3 *b2)
{
    float s = copysignf(1.0f, n.z);
    float a = -1.0f / (s + n.z);
    float b = n.x * n.y * a;
    *b1 = rtk_vec3_make(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
    *b2 = rtk_vec3_make(b, s + n.y * n.y * a, -n.y);
}

static float power_heuristic(float f, float g)
{
    return f * f / (f * f + g * g);
}

/* Light the BSDF sample br from p (cosine pdf pdf_bsdf) finds: the front
 * of an emitter or, on a miss, the environment, with its MIS weight
 * against light sampling in *w (0: nothing found). */
static rtk_rgb bsdf_sample_light(rtk_ctx *ctx, rtk_vec3 p, const rtk_ray *br, float pdf_bsdf, float *w)
{
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_hit bh;
    int hit = rtk_trace(ctx, br, &bh);
    float pdf_light = rtk_incident_light_pdf(scene, p, br, hit ? &bh : NULL);
    *w = 0.0f;
    if (pdf_light <= 0.0f)
        return rtk_rgb_make(0, 0, 0);
    if (!hit) {
        *w = power_heuristic(pdf_bsdf, pdf_light);
        return rtk_scene_environment(scene, br->dir);
    }
    rtk_surface e;
    rtk_surface_at(scene, br, &bh, &e);
    if (e.front_face)
        *w = power_heuristic(pdf_bsdf, pdf_light);
    return e.emission;
}

static void arealight_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    const arealight *a = state;
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_hit hit;
    if (!rtk_trace(ctx, ray, &hit)) {
        out->radiance = rtk_scene_environment(scene, ray->dir);
        return;
    }
    rtk_surface s;
    rtk_surface_at(scene, ray, &hit, &s);
    out->albedo = s.base_color;
    out->normal = s.ns;
    out->depth = hit.t * rtk_vec3_length(ray->dir);
    rtk_rgb L = s.front_face ? s.emission : rtk_rgb_make(0, 0, 0);
    rtk_rgb direct = rtk_rgb_make(0, 0, 0);
    rtk_vec3 org = rtk_offset_ray_origin(s.p, s.ng);
    const float inv_pi = (float)(1.0 / RTK_PI);
    rtk_vec3 b1, b2;
    basis(s.ns, &b1, &b2);
    for (int i = 0; i < a->samples; i++) {
        rtk_light_incident li;
        float u_pick = rtk_sample_1d(ctx);
        rtk_vec2 u = rtk_sample_2d(ctx);
        if (rtk_sample_incident_light(scene, s.p, s.ng, u_pick, u, &li)) {
            float cos_s = rtk_vec3_dot(s.ns, li.wi);
            /* The shadow ray's ends sit off each surface along its own
             * normal: no self-hit, even where a light is seen edge-on. */
            if (cos_s > 0.0f && rtk_vec3_dot(s.ng, li.wi) > 0.0f && !rtk_occluded(ctx, &li.shadow)) {
                float w = a->mis && !li.delta ? power_heuristic(li.pdf, cos_s * inv_pi) : 1.0f;
                float k = inv_pi * cos_s / li.pdf * w;
                direct = rtk_rgb_add(direct, rtk_rgb_scale(rtk_rgb_mul(s.base_color, li.li), k));
            }
        }
        if (!a->mis)
            continue;
        /* BSDF sample: cosine-weighted; f cos / pdf = base colour. */
        rtk_vec2 v = rtk_sample_2d(ctx);
        float r = sqrtf(v.x), phi = 2.0f * (float)RTK_PI * v.y;
        float z = sqrtf(fmaxf(0.0f, 1.0f - v.x));
        rtk_vec3 dir = rtk_vec3_add(rtk_vec3_add(rtk_vec3_scale(b1, r * cosf(phi)), rtk_vec3_scale(b2, r * sinf(phi))),
                                    rtk_vec3_scale(s.ns, z));
        if (rtk_vec3_dot(dir, s.ng) <= 0.0f)
            continue;
        rtk_ray br = {org, 0.0f, dir, INFINITY};
        float w;
        rtk_rgb le = bsdf_sample_light(ctx, s.p, &br, z * inv_pi, &w);
        if (w > 0.0f)
            direct = rtk_rgb_add(direct, rtk_rgb_scale(rtk_rgb_mul(s.base_color, le), w));
    }
    out->radiance = rtk_rgb_add(L, rtk_rgb_scale(direct, 1.0f / (float)a->samples));
}

static void arealight_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc arealight_params[] = {
    {.name = "light_samples", .type = RTK_PARAM_INT, .def = 1, .min = 1, .max = 4096,
     .doc = "light samples (and BSDF samples with mis) per camera ray"},
    {.name = "mis", .type = RTK_PARAM_BOOL, .def = 1,
     .doc = "combine light and cosine BSDF sampling with the power heuristic"},
};

static const rtk_integrator_fns arealight_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = arealight_create,
    .needs = arealight_needs,
    .prepare = arealight_prepare,
    .li = arealight_li,
    .destroy = arealight_destroy,
};

static const rtk_plugin arealight_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "arealight",
    .version = "1.0",
    .summary = "direct light from every light (area, punctual, environment), soft shadows, optional MIS",
    .params = arealight_params,
    .param_count = RTK_COUNTOF(arealight_params),
    .functions = &arealight_fns,
    .conform = "direct-area-light,environment-light",
};

RTK_PLUGIN_ENTRY(arealight_plugin)
