/* plugins/integrators/device_programs.h's "ao" program compiled by nvcc as the
 * cuda plugin compiles it, against the ao plugin's own li (built by the C
 * compiler, through the kernel's rtk_trace and rtk_surface_at): over the
 * scene as the kernel hands it to a device (rtk_device_tree_view), for the
 * same camera rays and sample streams, under each sampler, the host code
 * gives li's results bit for bit (radiance, AOVs, rays counted). On a GPU,
 * when one is present, the program run by the cuda plugin's own upload and
 * launch (plugins/accelerators/cuda/gpu.cu, linked in) gives the host's
 * hits, normals and depths bit for bit; its occlusion rays go where cosf
 * and sinf send them on the GPU, so radiance may differ by a ray now and
 * then: at most 1 % of samples differ, by one ray each. Without a GPU the
 * device code is compiled (for sm_90) but not run, and the test says so.
 *
 *   test_program_cuda */
#include "gpu_run.h"
#include "render/render.h"
#include "scene/scene.h"

#include <rtk/host.h>

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

const int rays_per_sample = 6;
const float distance = 0.5f;

void add_corner(rtk_scene *s, double th, double ph, uint32_t *index, float *normal)
{
    const double x = std::sin(th) * std::cos(ph), y = std::cos(th), z = std::sin(th) * std::sin(ph);
    rtk_scene_add_vertex(s, 0.3 * x, 0.3 * y + 0.3, 0.3 * z, index);
    normal[0] = (float)x, normal[1] = (float)y, normal[2] = (float)z;
}

/* A smooth sphere of radius 0.3 (corner normals) resting on a 2 x 2 floor. */
rtk_scene *sphere_on_floor()
{
    rtk_scene *s = rtk_scene_new("sphere on a floor", RTK_NEED_NORMALS);
    const int nu = 24, nv = 12;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            uint32_t v[4];
            float n[4][3];
            for (int k = 0; k < 4; k++) {
                int ii = i + (k == 1 || k == 2), jj = j + (k >= 2);
                add_corner(s, M_PI * jj / nv, 2.0 * M_PI * (ii % nu) / nu, &v[k], n[k]);
            }
            float n012[9], n023[9];
            std::memcpy(n012, n[0], 12), std::memcpy(n012 + 3, n[1], 12), std::memcpy(n012 + 6, n[2], 12);
            std::memcpy(n023, n[0], 12), std::memcpy(n023 + 3, n[2], 12), std::memcpy(n023 + 6, n[3], 12);
            if (j > 0) /* at the poles one of the two is a point */
                rtk_scene_add_triangle(s, v[0], v[1], v[2], n012, nullptr, RTK_INVALID_ID);
            if (j < nv - 1)
                rtk_scene_add_triangle(s, v[0], v[2], v[3], n023, nullptr, RTK_INVALID_ID);
        }
    uint32_t f[4];
    const double corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, corners[k][0], 0.0, corners[k][1], &f[k]);
    rtk_scene_add_triangle(s, f[0], f[2], f[1], nullptr, nullptr, RTK_INVALID_ID);
    rtk_scene_add_triangle(s, f[0], f[3], f[2], nullptr, nullptr, RTK_INVALID_ID);
    if (rtk_scene_finish(s) != RTK_OK) { /* the floor's normals, the bounds */
        rtk_scene_free(s);
        return nullptr;
    }
    return s;
}

/* Camera rays from around the sphere towards points near it, some past it. */
std::vector<rtk_ray> camera_rays(int n, rng *g)
{
    std::vector<rtk_ray> rays(n);
    for (int i = 0; i < n; i++) {
        rtk_vec3 org = rtk_vec3_make(g->next(-1.5f, 1.5f), g->next(0.2f, 1.5f), g->next(-1.5f, -0.8f));
        rtk_vec3 at = rtk_vec3_make(g->next(-0.6f, 0.6f), g->next(0.0f, 0.7f), g->next(-0.6f, 0.6f));
        rays[i] = {org, 0.0f, rtk_vec3_sub(at, org), INFINITY};
    }
    return rays;
}

bool same_bits(const rtk_li_result &a, const rtk_li_result &b)
{
    return std::memcmp(&a, &b, sizeof a) == 0;
}

/* ao's device program over s as the kernel hands it to a device (tree,
 * ps) against ao's li, under sampler type; on the GPU too when gpu. */
void compare_on(const rtk_device_tree &tree, const rtk_program_scene &ps, rtk_scene *s, const rtk_integrator_fns *ao,
                const void *state, rtk_sampler_type type, const char *name, bool gpu, rng *g)
{
    const int n = 4000;
    rtk_device_program desc = rtk_device_program();
    check(ao->device_program(state, &desc) == 1, "ao (rays 6, distance 0.5) describes its device program");
    const rtk_program p = rtk_program_of(&desc);
    check(p.kind == RTK_PROGRAM_AO && p.rays == rays_per_sample && p.distance == distance,
          "the program is ao with the plugin's rays and distance");

    rtk_ctx ctx;
    std::memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    rtk_ctx_set_sampler(&ctx, type, 7, 16);
    std::vector<rtk_ray> rays = camera_rays(n, g);
    std::vector<rtk_sample_pos> pos(n);
    std::vector<rtk_li_result> want(n), got(n);
    int differ = 0, count_differ = 0, hits = 0;
    for (int i = 0; i < n; i++) {
        rtk_ctx_start_sample(&ctx, (uint64_t)i / 16, (uint64_t)i % 16);
        pos[i] = ctx.pos;
        const uint64_t before = ctx.rays, invalid_before = ctx.invalid_rays;
        want[i] = rtk_li_result();
        want[i].depth = INFINITY;
        ao->li(state, &ctx, &rays[i], &want[i]);
        rtk_program_count c;
        rtk_program_run(&p, &ps, &ctx.gen, &pos[i], &rays[i], nullptr, &got[i], &c);
        differ += !same_bits(want[i], got[i]);
        count_differ += c.traced != ctx.rays - before || c.invalid != ctx.invalid_rays - invalid_before;
        hits += std::isfinite(want[i].depth);
    }
    char what[256];
    std::snprintf(what, sizeof what, "%s: nvcc's host program equals ao's li on %d samples (%d hit): %d differ, "
                  "%d count other rays", name, n, hits, differ, count_differ);
    check(differ == 0 && count_differ == 0 && hits > n / 2 && hits < n, what);
    if (!gpu)
        return;
    std::vector<rtk_li_result> dev;
    uint64_t counts[2];
    if (!run_on_gpu(tree, p, 0, ps.albedo, ctx.gen, rays, pos, dev, counts)) {
        check(false, "the program ran on the GPU");
        return;
    }
    int geometry = 0, radiance = 0, far = 0;
    for (int i = 0; i < n; i++) {
        geometry += std::memcmp(&dev[i].normal, &got[i].normal, sizeof got[i].normal) != 0 ||
                    std::memcmp(&dev[i].depth, &got[i].depth, sizeof got[i].depth) != 0 ||
                    std::memcmp(&dev[i].albedo, &got[i].albedo, sizeof got[i].albedo) != 0;
        const float d = std::fabs(dev[i].radiance.r - got[i].radiance.r);
        radiance += d != 0.0f;
        far += d > 1.0f / rays_per_sample + 1e-6f;
    }
    std::snprintf(what, sizeof what, "%s: on the GPU, %d of %d samples' normal, depth or albedo differ (want 0); "
                  "%d radiances differ (want <= 1 %%), %d by more than one ray (want 0)", name, geometry, n, radiance,
                  far);
    check(geometry == 0 && radiance * 100 <= n && far == 0, what);
}

void compare(rtk_scene *s, const rtk_integrator_fns *ao, const void *state, rtk_sampler_type type, const char *name,
             bool gpu, rng *g)
{
    rtk_device_tree tree = rtk_device_tree();
    void *block = nullptr, *program_block = nullptr;
    rtk_program_scene ps = rtk_program_scene();
    bool ready = rtk_device_tree_view(s, 1, &tree, &block) == RTK_OK;
    if (ready) {
        rtk_flat_scene flat;
        rtk_flat_scene_of(&tree, nullptr, &flat);
        ready = rtk_program_scene_of(&tree, &flat, &program_block, &ps) == 0;
        ps.albedo = rtk_material_default().base_color;
    }
    check(ready, "the scene as the kernel hands it to a device");
    if (ready)
        compare_on(tree, ps, s, ao, state, type, name, gpu, g);
    free(block);
    free(program_block);
}

} // namespace

int main()
{
    rtk_log_set_level(RTK_LOG_WARN);
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x2545f4914f6cdd1dull};
    rtk_scene *s = sphere_on_floor();
    rtk_registry *reg = nullptr;
    const rtk_plugin *sah = nullptr, *ao = nullptr;
    rtk_params *bp = nullptr, *ip = nullptr;
    void *state = nullptr;
    bool ready = s && rtk_registry_create(&reg) == RTK_OK &&
                 rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &sah) == RTK_OK &&
                 rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "ao", &ao) == RTK_OK &&
                 (bp = rtk_params_defaults(sah)) != nullptr && rtk_bvh_build(s, sah, bp, 1) == RTK_OK &&
                 (ip = rtk_params_defaults(ao)) != nullptr && rtk_params_set_text(ip, "rays", "6") == RTK_OK &&
                 rtk_params_set_text(ip, "distance", "0.5") == RTK_OK;
    const rtk_integrator_fns *fns = ready ? static_cast<const rtk_integrator_fns *>(ao->functions) : nullptr;
    ready = ready && fns->create(ip, &state) == RTK_OK;
    check(ready, "a smooth sphere on a floor, built with sah; the ao plugin made with rays 6, distance 0.5");
    if (ready) {
        compare(s, fns, state, RTK_SAMPLER_INDEPENDENT, "independent", gpu, &g);
        compare(s, fns, state, RTK_SAMPLER_STRATIFIED, "stratified", gpu, &g);
        compare(s, fns, state, RTK_SAMPLER_SOBOL, "sobol", gpu, &g);
        fns->destroy(state);
    }
    rtk_params_destroy(bp);
    rtk_params_destroy(ip);
    rtk_registry_destroy(reg);
    rtk_scene_free(s);
    return finish(gpu, e);
}
