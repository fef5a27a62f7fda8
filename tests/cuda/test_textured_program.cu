/* The "headlight" device program over textures, through the cuda plugin's
 * own upload and launch (plugins/accelerators/cuda/gpu.cu, linked in):
 * tests/scenes/textured (a repeating colour map and a normal map on the
 * floor, a clamped colour map and a normal map over corner normals on the
 * ball) with its textures' texels made here, so that no image decoder is
 * needed (the GPU check's bundle carries none). nvcc's host build of the
 * program gives headlight's li bit for bit; on a GPU, the program run by
 * rtk_gpu_shade over rtk_gpu_upload's copy of the scene gives the host's
 * results bit for bit too (headlight draws nothing, so no cosf or sinf
 * can part them). With the textures filtered trilinearly, camera rays
 * through film positions and their differentials (rtk_shade_batch.diffs)
 * give headlight's li too, MIP levels read at each hit's footprint, on
 * the host and on a GPU. path (4 bounces) run as a wavefront
 * (rtk_program_path_wavefront on the host; gpu.cu's wavefront kernels on
 * a GPU) equals path run as one loop (one kernel) bit for bit. Without a
 * GPU the device code is compiled (for sm_90) but not run, and the test
 * says so.
 *
 *   test_textured_program_cuda SOURCE_ROOT */
#include "gpu_run.h"
#include "render/render.h"
#include "scene/scene.h"
#include "scene/texture.h"

#include <rtk/host.h>

#include "cuda_test.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

/* Texture t's texels replaced by a 16 x 16 pattern of its own (a normal
 * map's leaning around +z, a colour map's two hues), as if decoded. */
bool fill_texture(rtk_texture *t, int seed)
{
    const int n = 16;
    float *rgba = static_cast<float *>(std::malloc(sizeof(float) * 4 * n * n));
    if (!rgba)
        return false;
    const bool normal = t->name && std::strstr(t->name, "bumps");
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            float *p = rgba + 4 * (y * n + x);
            const float u = (x + 0.5f) / n, v = (y + 0.5f) / n;
            if (normal) {
                p[0] = 0.5f + 0.35f * std::sin(6.2831853f * u), p[1] = 0.5f + 0.35f * std::cos(6.2831853f * v);
                p[2] = 0.85f;
            } else {
                const bool odd = ((x / 4 + y / 4 + seed) & 1) != 0;
                p[0] = odd ? 0.9f : 0.2f, p[1] = odd ? 0.3f : 0.5f + 0.02f * seed, p[2] = odd ? 0.2f : 0.9f;
            }
            p[3] = 1.0f;
        }
    for (int l = 1; l < t->levels; l++)
        std::free(t->mip[l].rgba);
    std::free(t->mip);
    std::free(t->rgba);
    t->mip = nullptr, t->levels = 0;
    t->rgba = rgba, t->width = t->height = n;
    t->decoded = 1, t->missing = 0, t->has_alpha = 0;
    t->normal_map_checked = normal ? 1 : 0;
    t->filter = RTK_TEX_BILINEAR;
    return true;
}


bool same_bits(const rtk_li_result &a, const rtk_li_result &b)
{
    return std::memcmp(&a, &b, sizeof a) == 0;
}

/* Program p (megakernel) on the GPU through gpu.cu gives host's results
 * bit for bit; what names the check. */
void check_gpu_equals_host(const rtk_device_tree &tree, const rtk_program &p, rtk_rgb albedo, const rtk_sample_gen &gen,
                           const std::vector<rtk_ray> &rays, const std::vector<rtk_sample_pos> &pos,
                           const rtk_ray_differential *diffs, const std::vector<rtk_li_result> &host, const char *what)
{
    std::vector<rtk_li_result> dev;
    uint64_t counts[2];
    char line[320];
    if (!run_on_gpu(tree, p, 0, albedo, gen, rays, pos, dev, counts, diffs)) {
        std::snprintf(line, sizeof line, "%s: the program ran", what);
        check(false, line);
        return;
    }
    int differ = 0;
    for (size_t i = 0; i < host.size(); i++)
        differ += !same_bits(dev[i], host[i]);
    std::snprintf(line, sizeof line, "%s: %d of %zu samples differ from the host's (want 0)", what, differ,
                  host.size());
    check(differ == 0, line);
}

/* Headlight (p, its plugin fns and state) over s with every texture
 * made trilinear: n camera rays through random film positions of a 64 x
 * 64 film, li given each ray's film position (so its differentials), the
 * host's program given the same differentials; and on a GPU, gpu.cu's
 * upload of the MIP levels and the batch's differentials. */
void check_trilinear(rtk_scene *s, bool gpu, const rtk_integrator_fns *fns, void *state, const rtk_program &p, rng *g)
{
    bool ready = true;
    for (uint32_t i = 0; ready && i < s->texture_count; i++)
        ready = rtk_texture_set_filter(&s->textures[i], RTK_TEX_TRILINEAR) == RTK_OK && s->textures[i].levels == 5;
    rtk_device_tree tree = rtk_device_tree();
    void *block = nullptr, *program_block = nullptr;
    rtk_program_scene ps = rtk_program_scene();
    ready = ready && rtk_device_tree_view(s, 1, &tree, &block) == RTK_OK && tree.texture_levels &&
            tree.textures[0].levels == 5;
    if (ready) {
        rtk_flat_scene flat;
        rtk_flat_scene_of(&tree, nullptr, &flat);
        ready = rtk_program_scene_of(&tree, &flat, &program_block, &ps) == 0;
        ps.albedo = rtk_material_default().base_color;
    }
    rtk_camera cam;
    const rtk_camera_desc desc = {rtk_vec3_make(0.0f, 1.5f, -2.2f), rtk_vec3_make(0.0f, 0.3f, 0.0f),
                                  rtk_vec3_make(0.0f, 1.0f, 0.0f), 50.0f};
    ready = ready && rtk_camera_init(&cam, &desc, 64, 64) == RTK_OK;
    check(ready, "the 16 x 16 textures filtered trilinearly (5 MIP levels each) in the device's view; a 64 x 64 "
                 "camera");
    if (!ready) {
        free(block), free(program_block);
        return;
    }
    const int n = 4000;
    rtk_ctx ctx;
    std::memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    ctx.camera = &cam;
    rtk_ctx_set_sampler(&ctx, RTK_SAMPLER_INDEPENDENT, 7, 16);
    std::vector<rtk_ray> rays(n);
    std::vector<rtk_ray_differential> diffs(n);
    std::vector<rtk_sample_pos> pos(n);
    std::vector<rtk_li_result> got(n);
    int differ = 0, hits = 0, mip = 0;
    for (int i = 0; i < n; i++) {
        const float fx = g->next(0.0f, 64.0f), fy = g->next(0.0f, 64.0f);
        rays[i] = rtk_camera_ray(&cam, fx, fy);
        /* rtk_camera_differential's rays: one pixel right, one down. */
        const rtk_ray rx = rtk_camera_ray(&cam, fx + 1.0f, fy), ry = rtk_camera_ray(&cam, fx, fy + 1.0f);
        diffs[i] = {rx.org, rx.dir, ry.org, ry.dir};
        rtk_ctx_start_sample(&ctx, (uint64_t)i / 16, (uint64_t)i % 16);
        ctx.film_x = fx, ctx.film_y = fy;
        pos[i] = ctx.pos;
        rtk_li_result want = rtk_li_result(), level0 = rtk_li_result();
        want.depth = INFINITY;
        fns->li(state, &ctx, &rays[i], &want);
        rtk_program_count c;
        rtk_program_run(&p, &ps, &ctx.gen, &pos[i], &rays[i], &diffs[i], &got[i], &c);
        rtk_program_run(&p, &ps, &ctx.gen, &pos[i], &rays[i], nullptr, &level0, &c);
        differ += !same_bits(want, got[i]);
        hits += std::isfinite(want.depth);
        mip += !same_bits(level0, got[i]);
    }
    char what[256];
    std::snprintf(what, sizeof what, "trilinear: nvcc's host program given the camera differentials equals "
                  "headlight's li on %d samples (%d hit, %d read past level 0): %d differ", n, hits, mip, differ);
    check(differ == 0 && hits > n / 3 && mip > n / 10, what);
    if (gpu)
        check_gpu_equals_host(tree, p, ps.albedo, ctx.gen, rays, pos, diffs.data(), got,
                              "trilinear on the GPU, through gpu.cu's upload of the MIP levels and differentials");
    free(block);
    free(program_block);
}

} // namespace

int main(int argc, char **argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s SOURCE_ROOT\n", argv[0]);
        return 2;
    }
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    /* Quiet: without an image decoder (the GPU check's bundle) every
     * texture warns that it is missing before fill_texture makes it. */
    rtk_log_set_level(RTK_LOG_ERROR);
    const std::string path = std::string(argv[1]) + "/tests/scenes/textured/textured.obj";
    rtk_scene *s = nullptr;
    const uint32_t needs = RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
    bool ready = rtk_scene_load(path.c_str(), needs, &s) == RTK_OK;
    rtk_log_set_level(RTK_LOG_WARN);
    for (uint32_t i = 0; ready && i < s->texture_count; i++)
        ready = fill_texture(&s->textures[i], (int)i);
    rtk_registry *reg = nullptr;
    const rtk_plugin *sah = nullptr, *headlight = nullptr;
    rtk_params *bp = nullptr, *ip = nullptr;
    void *state = nullptr;
    rtk_device_tree tree = rtk_device_tree();
    void *block = nullptr, *program_block = nullptr;
    rtk_program_scene ps = rtk_program_scene();
    ready = ready && s->texture_count == 6 && rtk_registry_create(&reg) == RTK_OK &&
            rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &sah) == RTK_OK &&
            rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "headlight", &headlight) == RTK_OK &&
            (bp = rtk_params_defaults(sah)) != nullptr && rtk_bvh_build(s, sah, bp, 1) == RTK_OK &&
            (ip = rtk_params_defaults(headlight)) != nullptr && rtk_params_set_text(ip, "ambient", "0.1") == RTK_OK &&
            rtk_device_tree_view(s, 1, &tree, &block) == RTK_OK && tree.textures && tree.texture_count == 6;
    const rtk_integrator_fns *fns = ready ? static_cast<const rtk_integrator_fns *>(headlight->functions) : nullptr;
    ready = ready && fns->create(ip, &state) == RTK_OK;
    if (ready) {
        rtk_flat_scene flat;
        rtk_flat_scene_of(&tree, nullptr, &flat);
        ready = rtk_program_scene_of(&tree, &flat, &program_block, &ps) == 0;
        ps.albedo = rtk_material_default().base_color;
    }
    check(ready, "tests/scenes/textured with its 6 textures made in memory, built with sah, as the kernel hands it "
                 "to a device; headlight with ambient 0.1");
    rtk_device_program desc = rtk_device_program();
    const rtk_program p = ready && fns->device_program(state, &desc) == 1 ? rtk_program_of(&desc) : rtk_program();
    check(p.kind == RTK_PROGRAM_HEADLIGHT && p.ambient == 0.1f, "headlight describes program headlight, ambient 0.1");
    if (ready && p.kind == RTK_PROGRAM_HEADLIGHT) {
        const int n = 4000;
        rng g = {0x9e3779b97f4a7c15ull};
        rtk_ctx ctx;
        std::memset(&ctx, 0, sizeof ctx);
        ctx.scene = s;
        rtk_ctx_set_sampler(&ctx, RTK_SAMPLER_INDEPENDENT, 7, 16);
        const std::vector<rtk_ray> rays = textured_camera_rays(n, &g);
        std::vector<rtk_sample_pos> pos(n);
        std::vector<rtk_li_result> got(n);
        int differ = 0, hits = 0, bent = 0;
        for (int i = 0; i < n; i++) {
            rtk_ctx_start_sample(&ctx, (uint64_t)i / 16, (uint64_t)i % 16);
            pos[i] = ctx.pos;
            rtk_li_result want = rtk_li_result();
            want.depth = INFINITY;
            fns->li(state, &ctx, &rays[i], &want);
            rtk_program_count c;
            rtk_program_run(&p, &ps, &ctx.gen, &pos[i], &rays[i], nullptr, &got[i], &c);
            differ += !same_bits(want, got[i]);
            hits += std::isfinite(want.depth);
            /* The floor's geometric normal is +y: a normal map bent it. */
            bent += std::isfinite(want.depth) && want.normal.y < 0.999f && std::fabs(want.normal.y) > 0.0f;
        }
        char what[256];
        std::snprintf(what, sizeof what, "nvcc's host program equals headlight's li on %d samples (%d hit, %d with "
                      "bent or curved normals): %d differ", n, hits, bent, differ);
        check(differ == 0 && hits > n / 2 && hits < n && bent > n / 4, what);
        /* path (max_depth 4, rr_depth 3) as a wavefront on the host equals
         * its one loop: the steps a GPU's wavefront kernels take. */
        rtk_device_program pd = rtk_device_program();
        std::snprintf(pd.name, sizeof pd.name, "path");
        pd.params[0] = 4.0f, pd.params[1] = 3.0f, pd.params[2] = 0.0f;
        const rtk_program path = rtk_program_of(&pd);
        std::vector<rtk_li_result> loop(n), wave(n);
        std::vector<rtk_program_count> loop_counts(n), wave_counts(n);
        std::vector<rtk_path_walk> walks(n);
        std::vector<uint32_t> live(n);
        for (int i = 0; i < n; i++)
            rtk_program_run(&path, &ps, &ctx.gen, &pos[i], &rays[i], nullptr, &loop[i], &loop_counts[i]);
        rtk_program_path_wavefront(&path, &ps, &ctx.gen, (uint32_t)n, rays.data(), nullptr, pos.data(), wave.data(),
                                   wave_counts.data(), walks.data(), live.data());
        int wave_differ = 0, lit = 0;
        for (int i = 0; i < n; i++) {
            wave_differ += !same_bits(loop[i], wave[i]) || loop_counts[i].traced != wave_counts[i].traced ||
                           loop_counts[i].invalid != wave_counts[i].invalid;
            lit += loop[i].radiance.r > 0.0f || loop[i].radiance.g > 0.0f || loop[i].radiance.b > 0.0f;
        }
        std::snprintf(what, sizeof what, "path (max_depth 4) as a wavefront on the host equals its one loop on %d "
                      "samples (%d lit): %d differ", n, lit, wave_differ);
        check(path.kind == RTK_PROGRAM_PATH && wave_differ == 0 && lit > n / 4, what);
        if (gpu) {
            check_gpu_equals_host(tree, p, ps.albedo, ctx.gen, rays, pos, nullptr, got,
                                  "on the GPU, through gpu.cu's upload of the textures");
            /* On the GPU the two runs of path share the device's cosf and
             * sinf, so they agree bit for bit as on the host. */
            std::vector<rtk_li_result> mega, front;
            uint64_t mega_counts[2], front_counts[2];
            if (!run_on_gpu(tree, path, 0, ps.albedo, ctx.gen, rays, pos, mega, mega_counts) ||
                !run_on_gpu(tree, path, 1, ps.albedo, ctx.gen, rays, pos, front, front_counts)) {
                check(false, "path ran on the GPU as one kernel and as a wavefront");
            } else {
                int gpu_wave_differ = 0;
                for (int i = 0; i < n; i++)
                    gpu_wave_differ += !same_bits(mega[i], front[i]);
                std::snprintf(what, sizeof what, "on the GPU, path as a wavefront equals path as one kernel: %d of "
                              "%d samples differ (want 0); rays %llu and %llu", gpu_wave_differ, n,
                              (unsigned long long)front_counts[0], (unsigned long long)mega_counts[0]);
                check(gpu_wave_differ == 0 && front_counts[0] == mega_counts[0] &&
                          front_counts[1] == mega_counts[1], what);
            }
        }
        check_trilinear(s, gpu, fns, state, p, &g);
    }
    if (state)
        fns->destroy(state);
    free(block);
    free(program_block);
    rtk_params_destroy(bp);
    rtk_params_destroy(ip);
    rtk_registry_destroy(reg);
    rtk_scene_free(s);
    return finish(gpu, e);
}
