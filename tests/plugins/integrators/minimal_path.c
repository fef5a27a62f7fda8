/* minimal_path: a complete path tracer on rtk's services (README.md shows
 * this file; a test keeps the two equal). */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

typedef struct mp {
    int max_depth;
} mp;

static rtk_status mp_create(const rtk_params *params, void **state)
{
    mp *m = malloc(sizeof *m);
    if (!m)
        return rtk_error(RTK_ERR_NOMEM, "minimal_path: out of memory");
    m->max_depth = (int)rtk_params_int(params, "max_depth");
    *state = m;
    return RTK_OK;
}

static uint32_t mp_needs(const void *state)
{
    (void)state;
    return RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
}

static float mis(float a, float b)
{
    return a * a / (a * a + b * b);
}

static void mp_li(const void *state, rtk_ctx *ctx, const rtk_ray *camera_ray, rtk_li_result *out)
{
    const mp *m = state;
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_rgb L = {0, 0, 0}, beta = {1, 1, 1};
    rtk_ray ray = *camera_ray;
    float bsdf_pdf = 0.0f; /* 0: the ray's direction was not sampled from a density */
    rtk_vec3 from = ray.org;
    for (int depth = 0;; depth++) {
        rtk_sample_seek(ctx, 8u * (uint32_t)depth); /* 7 draws per bounce, in a block of 8 */
        rtk_hit hit;
        int found = rtk_trace(ctx, &ray, &hit);
        /* Light the ray finds: the sky on a miss, else an emitter's front side. */
        rtk_surface s;
        rtk_rgb le = {0, 0, 0};
        if (!found) {
            le = rtk_scene_environment(scene, ray.dir);
        } else {
            rtk_surface_at(scene, &ray, &hit, &s);
            if (s.front_face)
                le = s.emission;
        }
        float light_pdf = bsdf_pdf > 0.0f ? rtk_incident_light_pdf(scene, from, &ray, found ? &hit : NULL) : 0.0f;
        float w = light_pdf > 0.0f ? mis(bsdf_pdf, light_pdf) : 1.0f;
        L = rtk_rgb_add(L, rtk_rgb_scale(rtk_rgb_mul(beta, le), w));
        if (!found || depth == m->max_depth)
            break;
        rtk_bsdf bsdf;
        rtk_surface_bsdf(scene, &hit, &s, &bsdf);
        int flip = (rtk_bsdf_flags(&bsdf) & RTK_BSDF_TRANSMISSION) && !s.front_face; /* inside is -z */
        rtk_frame frame = rtk_frame_from_normal(flip ? rtk_vec3_neg(s.ns) : s.ns);
        rtk_vec3 wo = rtk_frame_to_local(&frame, rtk_vec3_neg(rtk_vec3_normalize(ray.dir)));
        /* Next-event estimation: one light, chosen by power. */
        float u_pick = rtk_sample_1d(ctx);
        rtk_vec2 u_light = rtk_sample_2d(ctx);
        rtk_light_incident li;
        if (rtk_sample_incident_light(scene, s.p, s.ng, u_pick, u_light, &li) && !rtk_occluded(ctx, &li.shadow)) {
            rtk_vec3 wi = rtk_frame_to_local(&frame, li.wi);
            rtk_rgb f = rtk_bsdf_eval(&bsdf, wo, wi);
            float wl = li.delta ? 1.0f : mis(li.pdf, rtk_bsdf_pdf(&bsdf, wo, wi));
            L = rtk_rgb_add(L, rtk_rgb_scale(rtk_rgb_mul(beta, rtk_rgb_mul(f, li.li)), fabsf(wi.z) * wl / li.pdf));
        }
        /* The BSDF picks the next direction. */
        float u_lobe = rtk_sample_1d(ctx);
        rtk_vec2 u_dir = rtk_sample_2d(ctx);
        rtk_bsdf_sample_out bs;
        if (!rtk_bsdf_sample(&bsdf, wo, u_lobe, u_dir, &bs))
            break;
        beta = rtk_rgb_mul(beta, rtk_rgb_scale(bs.f, fabsf(bs.wi.z) / bs.pdf));
        bsdf_pdf = (bs.flags & RTK_BSDF_DELTA) ? 0.0f : bs.pdf;
        from = s.p;
        if (depth >= 2) { /* Russian roulette */
            float q = fminf(1.0f, fmaxf(beta.r, fmaxf(beta.g, beta.b)));
            if (rtk_sample_1d(ctx) >= q)
                break;
            beta = rtk_rgb_scale(beta, 1.0f / q);
        }
        rtk_vec3 wi = rtk_frame_to_world(&frame, bs.wi);
        ray.org = rtk_offset_ray_origin(s.p, rtk_vec3_dot(wi, s.ng) > 0.0f ? s.ng : rtk_vec3_neg(s.ng));
        ray.dir = wi;
        ray.tmin = 0.0f;
        ray.tmax = INFINITY;
    }
    out->radiance = L;
}

static void mp_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc mp_params[] = {
    {.name = "max_depth", .type = RTK_PARAM_INT, .def = 8, .min = 0, .max = 1024,
     .doc = "bounces (0 = emitters only, 1 = direct light)"},
};

static const rtk_integrator_fns mp_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = mp_create,
    .needs = mp_needs,
    .li = mp_li,
    .destroy = mp_destroy,
};

static const rtk_plugin mp_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "minimal_path",
    .version = "1.0",
    .summary = "README's minimal path tracer",
    .params = mp_params,
    .param_count = RTK_COUNTOF(mp_params),
    .functions = &mp_fns,
    .conform = "path-tracing,environment-light",
};

RTK_PLUGIN_ENTRY(mp_plugin)
