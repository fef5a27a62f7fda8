/* plugins/integrators/device_programs.h's "path" program compiled by nvcc
 * as the cuda plugin compiles it, against the path plugin's own li (built
 * by the C compiler, through the kernel's rtk_trace, rtk_surface_at and
 * rtk_sample_incident_light): in the Cornell box lit by its ceiling, a
 * point, a spot and a directional light and an environment map, and in
 * tests/scenes/textured (every surface textured), over the
 * scene as the kernel hands it to a device (rtk_device_tree_view), for
 * the same camera rays and sample streams, under each sampler and two
 * settings (the defaults; max_depth 4, rr_depth 1, clamp 2), the host
 * code gives li's results bit for bit (radiance, AOVs, rays counted).
 * Only the host side is compiled here: the cuda plugin's gpu.cu compiles
 * the device side, and tools/gpu-check judges its path images on a GPU.
 *
 *   test_path_program_cuda SOURCE_ROOT */
#include "../../plugins/integrators/device_programs.h"
#include "render/render.h"
#include "scene/scene.h"

#include <rtk/host.h>

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace {

/* An equirectangular map of w x h, values 0..2 at strength 0.1: dim, so that the lights in the box are chosen
 * often too. */
rtk_environment *random_map(rng *g, int w, int h)
{
    std::vector<float> px(3 * (size_t)w * h);
    for (float &v : px)
        v = g->next(0.0f, 2.0f);
    rtk_environment *env = nullptr;
    if (rtk_environment_from_pixels("test map", w, h, 3, px.data(), 0.1f, 37.0f, &env) != RTK_OK)
        return nullptr;
    return env;
}

/* scenes/cornell/cornell.obj as path needs it, with a point, a spot and a
 * directional light (in through the open front) and a map: every kind of
 * light path samples. */
rtk_scene *lit_cornell(const char *root, rng *g)
{
    const uint32_t needs = RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
    const std::string path = std::string(root) + "/scenes/cornell/cornell.obj";
    rtk_scene *s = nullptr;
    if (rtk_scene_load(path.c_str(), needs, &s) != RTK_OK)
        return nullptr;
    const rtk_punctual_light point = {RTK_LIGHT_POINT, {0.2f, 0.45f, 0.3f}, {0, 0, 0}, {0.05f, 0.05f, 0.05f}, 0, 0};
    const rtk_punctual_light spot = {RTK_LIGHT_SPOT, {0.4f, 0.5f, 0.25f}, {0, -1, 0}, {0.1f, 0.1f, 0.1f}, 0.866f,
                                     0.7071f};
    const rtk_punctual_light sun = {RTK_LIGHT_DIRECTIONAL, {0, 0, 0}, {0.1f, -0.3f, 0.9487f}, {0.5f, 0.5f, 0.5f}, 0, 0};
    rtk_environment *env = random_map(g, 64, 32);
    if (!env || rtk_scene_add_punctual(s, &point) != RTK_OK || rtk_scene_add_punctual(s, &spot) != RTK_OK ||
        rtk_scene_add_punctual(s, &sun) != RTK_OK || rtk_scene_set_environment(s, env) != RTK_OK) {
        rtk_scene_free(s);
        return nullptr;
    }
    return s;
}

/* From the camera's side of the front opening towards points inside the
 * box; one in eight from inside the box out through the opening, to see
 * the map. */
std::vector<rtk_ray> camera_rays(int n, rng *g)
{
    std::vector<rtk_ray> rays(n);
    for (int i = 0; i < n; i++) {
        rtk_vec3 org, at;
        if (i % 8 == 7) {
            org = rtk_vec3_make(g->next(0.05f, 0.5f), g->next(0.05f, 0.5f), g->next(0.1f, 0.5f));
            at = rtk_vec3_make(g->next(-0.5f, 1.0f), g->next(-0.5f, 1.0f), -1.0f);
        } else {
            org = rtk_vec3_make(0.278f + g->next(-0.2f, 0.2f), 0.273f + g->next(-0.2f, 0.2f), g->next(-0.8f, -0.1f));
            at = rtk_vec3_make(g->next(0.02f, 0.54f), g->next(0.02f, 0.53f), g->next(0.02f, 0.54f));
        }
        rays[i] = {org, 0.0f, rtk_vec3_sub(at, org), INFINITY};
    }
    return rays;
}

/* tests/scenes/textured/textured.obj as path needs it: every surface
 * reads textures (colour, normal, roughness, metalness, shininess and
 * emission maps). */
rtk_scene *textured(const char *root)
{
    const uint32_t needs = RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
    const std::string path = std::string(root) + "/tests/scenes/textured/textured.obj";
    rtk_scene *s = nullptr;
    return rtk_scene_load(path.c_str(), needs, &s) == RTK_OK ? s : nullptr;
}


bool same_bits(const rtk_li_result &a, const rtk_li_result &b)
{
    return std::memcmp(&a, &b, sizeof a) == 0;
}

void compare(rtk_scene *s, const rtk_program_scene &ps, const rtk_program &p, const rtk_integrator_fns *path,
             const void *state, rtk_sampler_type type, const char *name, const char *setting,
             const std::vector<rtk_ray> &rays)
{
    const int n = (int)rays.size();
    rtk_ctx ctx;
    std::memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    rtk_ctx_set_sampler(&ctx, type, 7, 16);
    int differ = 0, count_differ = 0, hits = 0, lit = 0;
    for (int i = 0; i < n; i++) {
        rtk_ctx_start_sample(&ctx, (uint64_t)i / 16, (uint64_t)i % 16);
        const rtk_sample_pos pos = ctx.pos;
        const uint64_t before = ctx.rays, invalid_before = ctx.invalid_rays;
        rtk_li_result want = rtk_li_result(), got = rtk_li_result();
        want.depth = INFINITY;
        path->li(state, &ctx, &rays[i], &want);
        rtk_program_count c;
        rtk_program_run(&p, &ps, &ctx.gen, &pos, &rays[i], nullptr, &got, &c);
        differ += !same_bits(want, got);
        count_differ += c.traced != ctx.rays - before || c.invalid != ctx.invalid_rays - invalid_before;
        hits += std::isfinite(want.depth);
        lit += want.radiance.r > 0.0f || want.radiance.g > 0.0f || want.radiance.b > 0.0f;
    }
    char what[320];
    std::snprintf(what, sizeof what, "%s, %s: nvcc's host program equals path's li on %d samples (%d hit, %d lit): "
                  "%d differ, %d count other rays", setting, name, n, hits, lit, differ, count_differ);
    check(differ == 0 && count_differ == 0 && hits > n / 2 && hits < n && lit > n / 4, what);
}

/* The three samplers under one setting of path's parameters (set: name,
 * value pairs over the defaults), whose program must be max_depth,
 * rr_depth, clamp. */
void compare_setting(rtk_scene *s, const rtk_program_scene &ps, const rtk_plugin *plugin,
                     const std::vector<std::pair<const char *, const char *>> &set, int max_depth, int rr_depth,
                     float clamp, const char *setting, const std::vector<rtk_ray> &rays)
{
    const rtk_integrator_fns *fns = static_cast<const rtk_integrator_fns *>(plugin->functions);
    rtk_params *ip = rtk_params_defaults(plugin);
    bool ready = ip != nullptr;
    for (const auto &kv : set)
        ready = ready && rtk_params_set_text(ip, kv.first, kv.second) == RTK_OK;
    void *state = nullptr;
    ready = ready && fns->create(ip, &state) == RTK_OK;
    rtk_device_program desc = rtk_device_program();
    ready = ready && fns->device_program(state, &desc) == 1;
    const rtk_program p = rtk_program_of(&desc);
    char what[256];
    std::snprintf(what, sizeof what, "%s: the path plugin describes program path with max_depth %d, rr_depth %d, "
                  "clamp %g", setting, max_depth, rr_depth, (double)clamp);
    ready = ready && p.kind == RTK_PROGRAM_PATH && p.path.max_depth == max_depth && p.path.rr_depth == rr_depth &&
            p.path.clamp == clamp;
    check(ready, what);
    if (ready) {
        compare(s, ps, p, fns, state, RTK_SAMPLER_INDEPENDENT, "independent", setting, rays);
        compare(s, ps, p, fns, state, RTK_SAMPLER_STRATIFIED, "stratified", setting, rays);
        compare(s, ps, p, fns, state, RTK_SAMPLER_SOBOL, "sobol", setting, rays);
    }
    if (state)
        fns->destroy(state);
    rtk_params_destroy(ip);
}

} // namespace

int main(int argc, char **argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s SOURCE_ROOT\n", argv[0]);
        return 2;
    }
    rtk_log_set_level(RTK_LOG_WARN);
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x2545f4914f6cdd1dull};
    rtk_scene *s = lit_cornell(argv[1], &g);
    rtk_registry *reg = nullptr;
    const rtk_plugin *sah = nullptr, *path = nullptr;
    rtk_params *bp = nullptr;
    rtk_device_tree tree = rtk_device_tree();
    void *block = nullptr;
    void *program_block = nullptr;
    rtk_program_scene ps = rtk_program_scene();
    bool ready = s && rtk_registry_create(&reg) == RTK_OK &&
                 rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &sah) == RTK_OK &&
                 rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "path", &path) == RTK_OK &&
                 (bp = rtk_params_defaults(sah)) != nullptr && rtk_bvh_build(s, sah, bp, 1) == RTK_OK &&
                 rtk_device_tree_view(s, 1, &tree, &block) == RTK_OK;
    if (ready) {
        rtk_flat_scene flat;
        rtk_flat_scene_of(&tree, nullptr, &flat);
        ready = rtk_program_scene_of(&tree, &flat, &program_block, &ps) == 0;
        ps.albedo = rtk_material_default().base_color;
    }
    check(ready, "the Cornell box with a point, a spot, a directional light and a map, built with sah, as the "
                 "kernel hands it to a device");
    if (ready) {
        compare_setting(s, ps, path, {}, 8, 3, 0.0f, "defaults", camera_rays(3000, &g));
        compare_setting(s, ps, path, {{"max_depth", "4"}, {"rr_depth", "1"}, {"clamp", "2"}}, 4, 1, 2.0f,
                        "max_depth 4, rr_depth 1, clamp 2", camera_rays(3000, &g));
    }
    /* The textured scene through the same steps. */
    rtk_scene *t = ready ? textured(argv[1]) : nullptr;
    rtk_device_tree ttree = rtk_device_tree();
    void *tblock = nullptr, *tprogram_block = nullptr;
    rtk_program_scene tps = rtk_program_scene();
    bool tready = t && rtk_bvh_build(t, sah, bp, 1) == RTK_OK && rtk_device_tree_view(t, 1, &ttree, &tblock) == RTK_OK &&
                  ttree.textures && ttree.texture_count == 6 && ttree.uvs;
    if (tready) {
        rtk_flat_scene flat;
        rtk_flat_scene_of(&ttree, nullptr, &flat);
        tready = rtk_program_scene_of(&ttree, &flat, &tprogram_block, &tps) == 0;
        tps.albedo = rtk_material_default().base_color;
    }
    check(tready, "tests/scenes/textured, built with sah, as the kernel hands it to a device: its 6 textures and "
                  "texture coordinates");
    if (tready)
        compare_setting(t, tps, path, {{"max_depth", "4"}}, 4, 3, 0.0f, "textured, max_depth 4",
                        textured_camera_rays(3000, &g));
    free(tblock);
    free(tprogram_block);
    rtk_scene_free(t);
    if (gpu)
        std::printf("skip  path on the GPU: it needs the materials and lights uploaded as the cuda plugin uploads "
                    "them; tools/gpu-check judges its images (within noise)\n");
    free(block);
    free(program_block);
    rtk_params_destroy(bp);
    rtk_registry_destroy(reg);
    rtk_scene_free(s);
    return finish(gpu, e);
}
