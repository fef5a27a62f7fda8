/* path: unidirectional path tracing with next-event estimation. Every
 * vertex samples one light of all (emissive triangles, point, spot,
 * directional, environment; chosen by power) and one direction of the
 * surface's BSDF (the kernel's material mapping, rtk/bsdf.h); the two are
 * combined by multiple importance sampling with the power heuristic, delta
 * lights and delta lobes taking their one strategy whole. Paths end by
 * Russian roulette from rr_depth on (survival = the path throughput's
 * largest channel, at most 1), at max_depth, or on leaving the scene,
 * where they see the environment. Each bounce reads its random numbers
 * from its own block of 8 sampler dimensions (rtk_sample_seek), so
 * stratified and Sobol draws stay stratified along paths of any length.
 *
 * Parameters:
 *   max_depth  int [0, 1024]  8  bounces: 0 = emitters only, 1 = direct light
 *   rr_depth   int [1, 1024]  3  first bounce at which Russian roulette may end a path
 *   clamp      float >= 0     0  largest channel of one contribution (0 = no clamping; biased)
 *
 * Example: integrator = { plugin = "path"; max_depth = 8; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>

/* Sampler dimensions each bounce reserves (7 used: light pick, light
 * point, lobe, direction, roulette). */
#define DIMS_PER_BOUNCE 8

typedef struct path {
    int max_depth;
    int rr_depth;
    float clamp;
} path;

static rtk_status path_create(const rtk_params *params, void **state)
{
    path *p = malloc(sizeof *p);
    if (!p)
        return rtk_error(RTK_ERR_NOMEM, "path: out of memory");
    p->max_depth = (int)rtk_params_int(params, "max_depth");
    p->rr_depth = (int)rtk_params_int(params, "rr_depth");
    p->clamp = (float)rtk_params_float(params, "clamp");
    *state = p;
    return RTK_OK;
}

static uint32_t path_needs(const void *state)
{
    (void)state;
    return RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
}

/* A scene with nothing that emits renders black: say so once, up front. */
static rtk_status path_prepare(void *state, const rtk_scene *scene)
{
    (void)state;
    rtk_light_incident sky;
    const rtk_vec2 mid = {0.5f, 0.5f};
    if (!rtk_scene_light_count(scene) && !rtk_scene_punctual_count(scene) &&
        !rtk_sample_incident_light(scene, rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 0, 0), 0.5f, mid, &sky))
        rtk_log(RTK_LOG_WARN, "path: the scene has no lights (emissive triangles: MTL Ke, glTF emissive; config "
                              "lights or environment): the image will be black");
    return RTK_OK;
}

static float power_heuristic(float f, float g)
{
    return f * f / (f * f + g * g);
}

static float max3(rtk_rgb c)
{
    return fmaxf(c.r, fmaxf(c.g, c.b));
}

static int is_black(rtk_rgb c)
{
    return c.r <= 0.0f && c.g <= 0.0f && c.b <= 0.0f;
}

/* Adds beta x c to L, scaled down to the clamp when one is set. */
static void add(const path *pt, rtk_rgb *L, rtk_rgb beta, rtk_rgb c)
{
    rtk_rgb v = rtk_rgb_mul(beta, c);
    float m = max3(v);
    if (pt->clamp > 0.0f && m > pt->clamp)
        v = rtk_rgb_scale(v, pt->clamp / m);
    *L = rtk_rgb_add(*L, v);
}

/* One vertex's shading frame: the shading normal on the side the ray came
 * from, or, for BSDFs that transmit, on the side the surface was authored
 * to face (rtk/bsdf.h: inside is -z), with the geometric normal to match. */
typedef struct vertex {
    rtk_frame frame;
    rtk_vec3 ng; /* geometric normal on the frame's side */
    rtk_vec3 wo; /* local, towards where the ray came from */
} vertex;

static vertex make_vertex(const rtk_surface *s, const rtk_bsdf *bsdf, rtk_vec3 ray_dir)
{
    vertex v;
    int flip = (rtk_bsdf_flags(bsdf) & RTK_BSDF_TRANSMISSION) && !s->front_face;
    v.ng = flip ? rtk_vec3_neg(s->ng) : s->ng;
    v.frame = rtk_frame_from_normal(flip ? rtk_vec3_neg(s->ns) : s->ns);
    v.wo = rtk_frame_to_local(&v.frame, rtk_vec3_neg(rtk_vec3_normalize(ray_dir)));
    return v;
}

/* 1 when the world direction w lies on the side of the geometric surface
 * that the local direction's z says: no light through shading normals. */
static int same_side(const vertex *v, rtk_vec3 w, float local_z)
{
    float g = rtk_vec3_dot(w, v->ng);
    return (g > 0.0f && local_z > 0.0f) || (g < 0.0f && local_z < 0.0f);
}

/* Light sampled at the vertex, weighted against the BSDF's own sampling. */
static rtk_rgb next_event(rtk_ctx *ctx, const rtk_surface *s, const vertex *v, const rtk_bsdf *bsdf)
{
    rtk_rgb none = rtk_rgb_make(0, 0, 0);
    float u_pick = rtk_sample_1d(ctx);
    rtk_vec2 u = rtk_sample_2d(ctx);
    rtk_light_incident li;
    if (!rtk_sample_incident_light(rtk_ctx_scene(ctx), s->p, s->ng, u_pick, u, &li) || !(li.pdf > 0.0f))
        return none;
    rtk_vec3 wi = rtk_frame_to_local(&v->frame, li.wi);
    if (!same_side(v, li.wi, wi.z))
        return none;
    rtk_rgb f = rtk_bsdf_eval(bsdf, v->wo, wi);
    if (is_black(f) || rtk_occluded(ctx, &li.shadow))
        return none;
    float w = li.delta ? 1.0f : power_heuristic(li.pdf, rtk_bsdf_pdf(bsdf, v->wo, wi));
    return rtk_rgb_scale(rtk_rgb_mul(f, li.li), fabsf(wi.z) * w / li.pdf);
}

/* What the path has carried to the current ray: its throughput and how
 * the ray's direction was chosen, for weighting what the ray finds. */
typedef struct path_state {
    rtk_rgb beta;
    int depth;
    int delta;        /* camera ray or delta lobe: what it finds counts whole */
    float bsdf_pdf;   /* else the solid-angle density it was sampled with */
    rtk_vec3 from;    /* and the point it left */
} path_state;

/* Weight of light the ray finds (an emitter it hits, or the environment
 * when hit is NULL) against sampling that light from where the ray left. */
static float found_weight(const rtk_scene *scene, const path_state *ps, const rtk_ray *ray, const rtk_hit *hit)
{
    if (ps->delta)
        return 1.0f;
    float light_pdf = rtk_incident_light_pdf(scene, ps->from, ray, hit);
    return light_pdf > 0.0f ? power_heuristic(ps->bsdf_pdf, light_pdf) : 1.0f;
}

static void path_li(const void *state, rtk_ctx *ctx, const rtk_ray *camera_ray, rtk_li_result *out)
{
    const path *pt = state;
    const rtk_scene *scene = rtk_ctx_scene(ctx);
    rtk_rgb L = rtk_rgb_make(0, 0, 0);
    path_state ps = {rtk_rgb_make(1, 1, 1), 0, 1, 0.0f, camera_ray->org};
    rtk_ray ray = *camera_ray;
    for (;; ps.depth++) {
        rtk_sample_seek(ctx, (uint32_t)ps.depth * DIMS_PER_BOUNCE);
        rtk_hit hit;
        if (!rtk_trace(ctx, &ray, &hit)) {
            rtk_rgb env = rtk_scene_environment(scene, ray.dir);
            if (!is_black(env))
                add(pt, &L, ps.beta, rtk_rgb_scale(env, found_weight(scene, &ps, &ray, NULL)));
            break;
        }
        rtk_surface s;
        rtk_ray_differential diff;
        if (ps.depth == 0 && rtk_ctx_camera_differential(ctx, &diff))
            rtk_surface_at_footprint(scene, &ray, &diff, &hit, &s);
        else
            rtk_surface_at(scene, &ray, &hit, &s);
        if (ps.depth == 0) {
            out->albedo = s.base_color;
            out->normal = s.ns;
            out->depth = hit.t * rtk_vec3_length(ray.dir);
        }
        if (s.front_face && !is_black(s.emission))
            add(pt, &L, ps.beta, rtk_rgb_scale(s.emission, found_weight(scene, &ps, &ray, &hit)));
        if (ps.depth >= pt->max_depth)
            break;
        rtk_bsdf bsdf;
        rtk_surface_bsdf(scene, &hit, &s, &bsdf);
        unsigned flags = rtk_bsdf_flags(&bsdf);
        if (bsdf.count == 0)
            break;
        vertex v = make_vertex(&s, &bsdf, ray.dir);
        if (flags & (RTK_BSDF_DIFFUSE | RTK_BSDF_GLOSSY))
            add(pt, &L, ps.beta, next_event(ctx, &s, &v, &bsdf));
        float u_lobe = rtk_sample_1d(ctx);
        rtk_vec2 u = rtk_sample_2d(ctx);
        rtk_bsdf_sample_out bs;
        if (!rtk_bsdf_sample(&bsdf, v.wo, u_lobe, u, &bs) || !(bs.pdf > 0.0f))
            break;
        rtk_vec3 wi = rtk_frame_to_world(&v.frame, bs.wi);
        if (!same_side(&v, wi, bs.wi.z))
            break;
        ps.beta = rtk_rgb_mul(ps.beta, rtk_rgb_scale(bs.f, fabsf(bs.wi.z) / bs.pdf));
        ps.delta = (bs.flags & RTK_BSDF_DELTA) != 0;
        ps.bsdf_pdf = bs.pdf;
        ps.from = s.p;
        float m = max3(ps.beta);
        if (!(m > 0.0f))
            break;
        if (ps.depth + 1 >= pt->rr_depth && m < 1.0f) {
            if (rtk_sample_1d(ctx) >= m)
                break;
            ps.beta = rtk_rgb_scale(ps.beta, 1.0f / m);
        }
        rtk_vec3 side = rtk_vec3_dot(wi, s.ng) > 0.0f ? s.ng : rtk_vec3_neg(s.ng);
        ray.org = rtk_offset_ray_origin(s.p, side);
        ray.dir = wi;
        ray.tmin = 0.0f;
        ray.tmax = INFINITY;
    }
    out->radiance = L;
}

static void path_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc path_params[] = {
    {.name = "max_depth", .type = RTK_PARAM_INT, .def = 8, .min = 0, .max = 1024,
     .doc = "bounces (0 = emitters only, 1 = direct light)"},
    {.name = "rr_depth", .type = RTK_PARAM_INT, .def = 3, .min = 1, .max = 1024,
     .doc = "first bounce at which Russian roulette may end a path"},
    {.name = "clamp", .type = RTK_PARAM_FLOAT, .def = 0, .min = 0, .max = INFINITY,
     .doc = "largest channel of one light contribution, 0 = no clamping (clamping is biased)"},
};

static const rtk_integrator_fns path_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = path_create,
    .needs = path_needs,
    .prepare = path_prepare,
    .li = path_li,
    .destroy = path_destroy,
};

static const rtk_plugin path_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "path",
    .version = "1.0",
    .summary = "path tracing: BSDFs, every light type, next-event estimation with MIS, Russian roulette",
    .params = path_params,
    .param_count = RTK_COUNTOF(path_params),
    .functions = &path_fns,
    .conform = "path-tracing,environment-light",
};

RTK_PLUGIN_ENTRY(path_plugin)
