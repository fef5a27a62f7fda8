/* kernel/scene/light_sample.h compiled by nvcc (as a CUDA backend
 * compiles it): nvcc's host code gives what the kernel gives, bit for
 * bit, for
 *   - an environment map (64 x 32, turned 37 degrees, two black rows) and
 *     a constant one: rtk_environment_sample, _pdf and _radiance;
 *   - a scene with every kind of light (two emitting quads, one placed by
 *     a mirroring instance, a point, a spot and a directional light, the
 *     map): rtk_sample_incident_light from random points and normals, and
 *     rtk_incident_light_pdf of the area and environment samples.
 * The emitters' corners and emission come through rtk_emitter_fns, here
 * read from the scene as lights.c reads them. On a GPU the device code
 * samples the map and the punctual lights, compared as shading compares
 * (CUDA's sinf, acosf, atan2f are not glibc's): the same successes and
 * the same pixel, values within 1e-3 relative. Without a GPU that part is
 * skipped, saying so. */
#include "scene/light_sample.h"

#include <rtk/host.h>

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {

bool same_bits(const void *a, const void *b, size_t n)
{
    return std::memcmp(a, b, n) == 0;
}

bool same_incident(int ra, const rtk_light_incident &a, int rb, const rtk_light_incident &b)
{
    if (ra != rb)
        return false;
    if (!ra)
        return true;
    return same_bits(&a.wi, &b.wi, sizeof a.wi) && same_bits(&a.dist, &b.dist, sizeof a.dist) &&
           same_bits(&a.li, &b.li, sizeof a.li) && same_bits(&a.pdf, &b.pdf, sizeof a.pdf) && a.delta == b.delta &&
           same_bits(&a.shadow, &b.shadow, sizeof a.shadow);
}

/* An equirectangular map of w x h with two black rows, values 0..4. */
rtk_environment *random_map(rng *g, int w, int h)
{
    std::vector<float> px(3 * (size_t)w * h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                px[3 * ((size_t)y * w + x) + c] = (y == 3 || y == 20) ? 0.0f : g->next(0.0f, 4.0f);
    rtk_environment *env = nullptr;
    if (rtk_environment_from_pixels("test map", w, h, 3, px.data(), 1.5f, 37.0f, &env) != RTK_OK)
        return nullptr;
    return env;
}

rtk_vec3 random_dir(rng *g)
{
    rtk_vec3 d;
    do
        d = {g->next(-1, 1), g->next(-1, 1), g->next(-1, 1)};
    while (rtk_vec3_dot(d, d) > 1.0f || rtk_vec3_dot(d, d) < 1e-6f);
    return d;
}

/* The map: sample, pdf and radiance, host code against the kernel. */
void compare_map(const rtk_environment *env, const char *name, rng *g)
{
    int bad = 0, zero = 0;
    const int n = 100000;
    for (int i = 0; i < n; i++) {
        rtk_vec2 u = {g->next(0, 1), g->next(0, 1)};
        if (i % 97 == 0)
            u = {i % 2 ? 1.0f : 0.0f, i % 3 ? 0.9999999f : -0.0f};
        rtk_vec3 wa, wb;
        rtk_rgb ra, rb;
        float pa = rtk_environment_sample(env, u, &wa, &ra), pb = rtk_env_sample(env, u, &wb, &rb);
        zero += pa == 0.0f;
        bad += !same_bits(&pa, &pb, sizeof pa) ||
               (pa > 0.0f && (!same_bits(&wa, &wb, sizeof wa) || !same_bits(&ra, &rb, sizeof ra)));
        rtk_vec3 d = random_dir(g);
        float qa = rtk_environment_pdf(env, d), qb = rtk_env_pdf(env, d);
        rtk_rgb la = rtk_environment_radiance(env, d), lb = rtk_env_radiance(env, d);
        bad += !same_bits(&qa, &qb, sizeof qa) || !same_bits(&la, &lb, sizeof la);
    }
    char what[256];
    std::snprintf(what, sizeof what, "%s: nvcc's host code = the kernel's sample, pdf and radiance, bit for bit "
                  "(%d samples, %d of pdf 0, %d directions): %d differ", name, n, zero, n, bad);
    check(bad == 0, what);
}

/* The emitters as lights.c reads them. */
void corners_of(const void *ctx, uint32_t light, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c, int *mirrored)
{
    const rtk_scene *s = static_cast<const rtk_scene *>(ctx);
    uint32_t prim = s->lights->prims[light], inst = s->lights->insts[light];
    if (inst == RTK_INVALID_ID) {
        rtk_scene_triangle(s, prim, a, b, c);
        *mirrored = 0;
    } else {
        rtk_instance_triangle(s, inst, prim, a, b, c);
        *mirrored = s->instances[inst].mirrored;
    }
}

rtk_rgb emission_of(const void *ctx, uint32_t light, float, float)
{
    const rtk_scene *s = static_cast<const rtk_scene *>(ctx);
    uint32_t prim = s->lights->prims[light], inst = s->lights->insts[light];
    const rtk_scene *mesh = inst == RTK_INVALID_ID ? s : s->meshes[s->instances[inst].mesh];
    return mesh->materials[mesh->tri_material[prim]].emission;
}

void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t mat)
{
    uint32_t v[4];
    const rtk_vec3 c[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, c[k].x, c[k].y, c[k].z, &v[k]);
    rtk_scene_add_triangle(s, v[0], v[1], v[2], nullptr, nullptr, mat);
    rtk_scene_add_triangle(s, v[0], v[2], v[3], nullptr, nullptr, mat);
}

uint32_t emitting(rtk_scene *s, float le)
{
    rtk_material m = rtk_material_default();
    m.emission = rtk_rgb_make(le, 0.5f * le, 0.25f * le);
    uint32_t id = RTK_INVALID_ID;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

/* Every kind of light; the map is given to the scene. */
rtk_scene *lit_scene(rtk_environment *env)
{
    const uint32_t needs = RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS;
    rtk_scene *s = rtk_scene_new("lights", needs);
    add_quad(s, {-0.25f, 1.0f, -0.25f}, {0.5f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.5f}, emitting(s, 4.0f));
    uint32_t mi = 0;
    rtk_scene_add_mesh(s, "placed emitter", &mi);
    add_quad(s->meshes[mi], {0.0f, 0.0f, 0.0f}, {0.3f, 0.0f, 0.0f}, {0.0f, 0.3f, 0.0f}, emitting(s, 2.0f));
    const double mirror[12] = {-1, 0, 0, 0.6, 0, 1, 0, 0.2, 0, 0, 1, -0.4};
    rtk_scene_add_instance(s, mi, mirror, "test");
    rtk_punctual_light point = {RTK_LIGHT_POINT, {0.5f, 0.8f, 0.0f}, {0, 0, 0}, {1, 1, 1}, 0, 0};
    rtk_punctual_light spot = {RTK_LIGHT_SPOT, {-0.5f, 0.9f, 0.0f}, {0, -1, 0}, {2, 2, 2}, 0.866f, 0.7071f};
    rtk_punctual_light sun = {RTK_LIGHT_DIRECTIONAL, {0, 0, 0}, {0.267f, -0.802f, 0.535f}, {0.5f, 0.5f, 0.5f}, 0, 0};
    rtk_scene_add_punctual(s, &point);
    rtk_scene_add_punctual(s, &spot);
    rtk_scene_add_punctual(s, &sun);
    if (rtk_scene_finish(s) != RTK_OK || rtk_scene_set_environment(s, env) != RTK_OK) {
        rtk_scene_free(s);
        return nullptr;
    }
    return s;
}

/* rtk_sample_incident_light and rtk_incident_light_pdf against the header. */
void compare_choice(const rtk_scene *s, rng *g)
{
    const rtk_emitter_fns fns = {corners_of, emission_of};
    const int n = 200000;
    int bad = 0, lit = 0, delta = 0, bad_pdf = 0, area = 0;
    for (int i = 0; i < n; i++) {
        rtk_vec3 p = {g->next(-1, 1), g->next(-0.2f, 0.9f), g->next(-1, 1)}, ng = random_dir(g);
        ng = rtk_vec3_normalize(ng);
        float u_pick = g->next(0, 1);
        rtk_vec2 u = {g->next(0, 1), g->next(0, 1)};
        rtk_light_incident a, b;
        std::memset(&a, 0, sizeof a), std::memset(&b, 0, sizeof b);
        int ra = rtk_sample_incident_light(s, p, ng, u_pick, u, &a);
        int rb = rtk_lights_incident(s->lights, s->punctual, s->punctual_count, &fns, s, p, ng, u_pick, u, &b);
        bad += !same_incident(ra, a, rb, b);
        lit += ra;
        delta += ra && a.delta;
        if (!ra || a.delta)
            continue;
        /* The sampled direction's pdf: the environment's on a miss, an
         * emitter's when the ray hits one. */
        rtk_ray ray = {p, 0.0f, a.wi, INFINITY};
        rtk_hit hit;
        if (!rtk_bvh_closest(s, &ray, &hit))
            hit.prim = hit.inst = RTK_INVALID_ID;
        float ka = rtk_incident_light_pdf(s, p, &ray, &hit), kb;
        if (hit.prim == RTK_INVALID_ID) {
            const float pick = s->lights->slot_pick[s->lights->slot_count - 1];
            kb = pick > 0.0f ? rtk_env_pdf(s->lights->environment, ray.dir) * pick : 0.0f;
        } else {
            const float pdf_area = rtk_scene_light_pdf(s, &hit);
            rtk_vec3 v0, v1, v2;
            if (hit.inst == RTK_INVALID_ID)
                rtk_scene_triangle(s, hit.prim, &v0, &v1, &v2);
            else
                rtk_instance_triangle(s, hit.inst, hit.prim, &v0, &v1, &v2);
            rtk_vec3 nl = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(v1, v0), rtk_vec3_sub(v2, v0)));
            if (hit.inst != RTK_INVALID_ID && s->instances[hit.inst].mirrored)
                nl = rtk_vec3_neg(nl);
            kb = pdf_area > 0.0f ? rtk_emitter_solid_pdf(nl, &ray, hit.t, pdf_area, s->lights->slot_pick[0]) : 0.0f;
            area += pdf_area > 0.0f;
        }
        bad_pdf += !same_bits(&ka, &kb, sizeof ka);
    }
    char what[384];
    std::snprintf(what, sizeof what, "every kind of light: nvcc's host code = the kernel's rtk_sample_incident_light, "
                  "bit for bit (%d samples, %d lit, %d of them delta): %d differ", n, lit, delta, bad);
    check(bad == 0 && lit > n / 4 && delta > 0 && delta < lit, what);
    std::snprintf(what, sizeof what, "every kind of light: rtk_incident_light_pdf = the header's densities, bit for "
                  "bit (%d non-delta samples, %d hitting an emitter): %d differ", lit - delta, area, bad_pdf);
    check(bad_pdf == 0 && area > 0, what);
}

/* ---- the device ---- */

struct light_case {
    rtk_vec2 u;
    rtk_vec3 dir, p, ng;
    uint32_t light;
};

struct light_out {
    float pdf, pdf_dir;
    rtk_vec3 wi;
    rtk_rgb radiance, along;
    size_t pixel;
    int lit;
    rtk_light_incident inc;
};

RTK_HD void run_shared(const rtk_environment *env, const rtk_punctual_light *lights, const light_case *c,
                       light_out *o)
{
    o->pdf = rtk_env_sample(env, c->u, &o->wi, &o->radiance);
    o->pdf_dir = rtk_env_pdf(env, c->dir);
    o->along = rtk_env_radiance(env, c->dir);
    float st;
    o->pixel = rtk_env_pixel(env, rtk_env_to_map(env, rtk_vec3_normalize(c->dir)), &st);
    o->lit = rtk_punctual_incident(&lights[c->light], c->p, c->ng, 0.25f, &o->inc);
}

__global__ void light_kernel(rtk_environment env, const rtk_punctual_light *lights, const light_case *in,
                             light_out *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        run_shared(&env, lights, &in[i], &out[i]);
}

/* Within 1e-3 relative; equal values too (a directional light's distance is inf on both sides). */
bool close(float a, float b)
{
    return a == b || std::fabs(a - b) <= 1e-3f * std::fmax(std::fabs(a), std::fabs(b)) + 1e-6f;
}

void compare_device(const rtk_environment *env, const rtk_scene *s, rng *g)
{
    const int n = 50000;
    std::vector<light_case> in(n);
    for (auto &c : in) {
        c.u = {g->next(0, 1), g->next(0, 1)};
        c.dir = random_dir(g);
        c.p = {g->next(-1, 1), g->next(-0.2f, 0.9f), g->next(-1, 1)};
        c.ng = rtk_vec3_normalize(random_dir(g));
        c.light = (uint32_t)(g->next(0, 1) * (float)s->punctual_count) % s->punctual_count;
    }
    std::vector<light_out> host(n), dev(n);
    for (int i = 0; i < n; i++)
        run_shared(env, s->punctual, &in[i], &host[i]);
    const size_t pixels = (size_t)env->width * env->height;
    rtk_environment d = *env;
    d.rgb = upload(env->rgb, 3 * pixels);
    d.func = upload(env->func, pixels);
    d.row_cdf = upload(env->row_cdf, (size_t)env->height + 1);
    d.col_cdf = upload(env->col_cdf, (size_t)env->height * (env->width + 1));
    rtk_punctual_light *dl = upload(s->punctual, s->punctual_count);
    light_case *din = upload(in.data(), in.size());
    light_out *dout = nullptr;
    bool ran = d.rgb && d.func && d.row_cdf && d.col_cdf && dl && din &&
               cudaMalloc(&dout, n * sizeof *dout) == cudaSuccess;
    if (ran) {
        light_kernel<<<(n + 127) / 128, 128>>>(d, dl, din, dout, n);
        ran = cudaGetLastError() == cudaSuccess &&
              cudaMemcpy(dev.data(), dout, n * sizeof *dout, cudaMemcpyDeviceToHost) == cudaSuccess;
    }
    cudaFree(d.rgb), cudaFree(d.func), cudaFree(d.row_cdf), cudaFree(d.col_cdf), cudaFree(dl), cudaFree(din);
    cudaFree(dout);
    int bad = 0, edge = 0;
    for (int i = 0; ran && i < n; i++) {
        const light_out &h = host[i], &v = dev[i];
        /* A direction within rounding of a pixel edge may land in the next pixel. */
        if (h.pixel != v.pixel) {
            edge++;
            continue;
        }
        bool ok = close(h.pdf_dir, v.pdf_dir) && close(h.along.r, v.along.r) && h.lit == v.lit &&
                  (!h.lit || (close(h.inc.li.r, v.inc.li.r) && close(h.inc.pdf, v.inc.pdf) &&
                              close(h.inc.wi.x, v.inc.wi.x) && close(h.inc.dist, v.inc.dist)));
        ok = ok && close(h.pdf, v.pdf) && (h.pdf == 0.0f || (close(h.wi.y, v.wi.y) && close(h.radiance.g, v.radiance.g)));
        bad += !ok;
    }
    char what[256];
    std::snprintf(what, sizeof what, "the GPU's device code = the host code within 1e-3 (map samples, pdfs, "
                  "punctual lights; %d cases, %d on a pixel edge left out): %s%d differ", n, edge,
                  ran ? "" : "CUDA failed; ", bad);
    check(ran && bad == 0 && edge < n / 100, what);
}

} // namespace

int main()
{
    rtk_log_set_level(RTK_LOG_WARN);
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x9e3779b97f4a7c15ull};
    rtk_environment *constant = nullptr;
    if (rtk_environment_constant(rtk_rgb_make(0.3f, 0.4f, 0.5f), 2.0f, &constant) == RTK_OK) {
        compare_map(constant, "constant environment", &g);
        rtk_environment_free(constant);
    }
    rtk_environment *map = random_map(&g, 64, 32);
    check(map != nullptr, "a 64 x 32 map with two black rows is accepted");
    if (!map)
        return finish(gpu, e);
    compare_map(map, "64 x 32 map turned 37 degrees", &g);
    rtk_scene *s = lit_scene(map); /* the scene owns the map from here */
    check(s != nullptr && s->lights && s->lights->count == 4 && s->lights->slot_count == 5,
          "a scene with two emitting quads (one instanced, mirrored), three punctual lights and the map");
    if (s) {
        const rtk_plugin *median = nullptr;
        rtk_registry *reg = nullptr;
        rtk_params *params = nullptr;
        rtk_bvh_cache_use use;
        bool built = rtk_registry_create(&reg) == RTK_OK &&
                     rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) == RTK_OK &&
                     (params = rtk_params_defaults(median)) != nullptr &&
                     rtk_bvh_build_cached(s, median, params, 1, nullptr, &use) == RTK_OK;
        check(built, "the scene's BVH is built (median)");
        if (built)
            compare_choice(s, &g);
        if (gpu)
            compare_device(s->lights->environment, s, &g);
        rtk_params_destroy(params);
        rtk_registry_destroy(reg);
        rtk_scene_free(s);
    }
    return finish(gpu, e);
}
