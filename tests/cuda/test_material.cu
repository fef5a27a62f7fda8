/* kernel/scene/material_bsdf.h, the mapping of a material to its BSDF,
 * compiled by nvcc as a GPU backend compiles it: over 3,000 random
 * materials (MTL by every illum, with and without Ks and Tf, and
 * metallic-roughness with transmission and specular factors; no
 * textures), the host code gives the BSDF the kernel's rtk_surface_bsdf
 * gives, bit for bit (weights and lobes), and on a GPU, when one is
 * present, the device code gives the host's bit for bit (the mapping uses
 * +, *, / and sqrtf only, which CUDA rounds as IEEE does with
 * --fmad=false). Without a GPU the device code is compiled (for sm_90)
 * but not run, and the test says so.
 *
 *   test_material_cuda */
#include "scene/material_bsdf.h"

#include <rtk/host.h>

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {

struct material_case {
    uint32_t material; /* in the scene */
    rtk_rgb base;
    float coverage, ior;
};

/* What a GPU backend runs per hit: the mapping without textures. */
RTK_HD void map_shared(const rtk_material *materials, const material_case *c, rtk_bsdf *out)
{
    rtk_material_bsdf(&materials[c->material], c->base, c->coverage, c->ior, rtk_no_maps, nullptr, out);
}

__global__ void map_kernel(const rtk_material *materials, const material_case *cases, int n, rtk_bsdf *out)
{
    const int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        map_shared(materials, &cases[i], &out[i]);
}

rtk_rgb colour(rng *g, float lo, float hi)
{
    return rtk_rgb_make(g->next(lo, hi), g->next(lo, hi), g->next(lo, hi));
}

/* A random material of either model, within and past the ranges loaders
 * keep (the mapping clamps). */
rtk_material random_material(rng *g, int k)
{
    rtk_material m = rtk_material_default();
    m.base_color = colour(g, 0.0f, 1.2f);
    m.alpha = g->next(0.0f, 1.0f);
    m.ior = g->next(1.0f, 2.5f);
    if (k % 2) {
        m.model = RTK_MODEL_MTL;
        static const int illums[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
        m.has_illum = k % 5 != 0;
        m.illum = m.has_illum ? illums[(k / 2) % 11] : 0;
        m.specular = k % 3 ? colour(g, 0.0f, 1.1f) : rtk_rgb_make(0, 0, 0);
        m.shininess = g->next(-10.0f, 2000.0f);
        m.has_filter = k % 4 == 1;
        m.filter = colour(g, 0.0f, 1.2f);
    } else {
        m.model = RTK_MODEL_METALLIC_ROUGHNESS;
        m.illum = k % 6 == 0 ? 4 : -1;
        m.metallic = g->next(-0.1f, 1.1f);
        m.roughness = g->next(0.0f, 1.0f);
        m.transmission = k % 3 ? g->next(0.0f, 1.0f) : 0.0f;
        m.specular_color = colour(g, 0.0f, 1.5f);
        m.specular_weight = g->next(0.0f, 1.1f);
    }
    return m;
}

bool same_bsdf(const rtk_bsdf &a, const rtk_bsdf &b)
{
    if (a.count != b.count)
        return false;
    for (uint32_t i = 0; i < a.count; i++)
        if (std::memcmp(&a.weight[i], &b.weight[i], sizeof a.weight[i]) != 0 ||
            std::memcmp(&a.lobe[i], &b.lobe[i], sizeof a.lobe[i]) != 0)
            return false;
    return true;
}

} // namespace

int main()
{
    rtk_log_set_level(RTK_LOG_ERROR);
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x853c49e6748fea9bull};
    const int n_materials = 600, n = 3000;
    rtk_scene *s = rtk_scene_new("materials", RTK_NEED_MATERIALS);
    std::vector<rtk_material> materials;
    bool made = s != nullptr;
    for (int k = 0; made && k < n_materials; k++) {
        rtk_material m = random_material(&g, k);
        uint32_t id;
        made = rtk_scene_add_material(s, &m, &id) == RTK_OK && id == (uint32_t)k;
    }
    check(made, "600 random materials (MTL by every illum, metallic-roughness) in a scene");
    if (!made) {
        rtk_scene_free(s);
        return finish(gpu, e);
    }
    materials.assign(s->materials, s->materials + s->material_count);
    std::vector<material_case> cases(n);
    std::vector<rtk_bsdf> want(n), got(n);
    int differ = 0, lobes = 0;
    for (int i = 0; i < n; i++) {
        material_case &c = cases[i];
        c.material = (uint32_t)(i % n_materials);
        c.base = colour(&g, 0.0f, 1.3f);
        c.coverage = g.next(-0.2f, 1.2f);
        c.ior = i % 17 == 0 ? NAN : g.next(0.5f, 2.5f);
        rtk_surface sf;
        std::memset(&sf, 0, sizeof sf);
        sf.material = c.material;
        sf.base_color = c.base;
        sf.alpha = c.coverage;
        sf.ior = c.ior;
        rtk_hit hit;
        hit.t = 1.0f, hit.u = 0.2f, hit.v = 0.3f;
        hit.prim = 0, hit.inst = RTK_INVALID_ID;
        rtk_surface_bsdf(s, &hit, &sf, &want[i]);
        map_shared(materials.data(), &c, &got[i]);
        differ += !same_bsdf(want[i], got[i]);
        lobes += (int)want[i].count;
    }
    char what[256];
    std::snprintf(what, sizeof what, "nvcc's host mapping equals rtk_surface_bsdf on %d hits (%d lobes): %d differ", n,
                  lobes, differ);
    check(differ == 0 && lobes > n, what);
    if (gpu) {
        rtk_material *dm = upload(materials.data(), materials.size());
        material_case *dc = upload(cases.data(), cases.size());
        rtk_bsdf *dout = nullptr;
        bool ok = dm && dc && cudaMalloc(&dout, sizeof *dout * (size_t)n) == cudaSuccess;
        std::vector<rtk_bsdf> dev(n);
        if (ok) {
            map_kernel<<<(n + 127) / 128, 128>>>(dm, dc, n, dout);
            ok = cudaGetLastError() == cudaSuccess &&
                 cudaMemcpy(dev.data(), dout, sizeof *dout * (size_t)n, cudaMemcpyDeviceToHost) == cudaSuccess;
        }
        int gdiffer = 0;
        for (int i = 0; ok && i < n; i++)
            gdiffer += !same_bsdf(dev[i], got[i]);
        std::snprintf(what, sizeof what, "the GPU's mapping equals the host's on %d hits: %d differ", n, gdiffer);
        check(ok && gdiffer == 0, ok ? what : "the mapping ran on the GPU");
        cudaFree(dm), cudaFree(dc), cudaFree(dout);
    }
    rtk_scene_free(s);
    return finish(gpu, e);
}
