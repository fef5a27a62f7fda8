/* kernel/scene/texture_sample.h, filtered texture lookups, compiled by
 * nvcc as a GPU backend compiles it: on random textures (1 x 1 up to
 * 37 x 23, odd sizes among them) under nearest, bilinear and trilinear
 * filtering (the kernel's MIP pyramid), every pair of wrap modes (repeat,
 * clamp, mirror) and coordinates far outside [0, 1], on texel edges and
 * non-finite, at levels of detail below 0 to past the last level, the
 * host code gives the kernel's rtk_texture_sample bit for bit; on a GPU,
 * when one is present, the device code gives the host's bit for bit (the
 * lookups use floor, +, * and conversions only, which CUDA rounds as IEEE
 * does with --fmad=false). Without a GPU the device code is compiled (for
 * sm_90) but not run, and the test says so.
 *
 *   test_texture_cuda */
#include "scene/texture_sample.h"

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

struct lookup_case {
    rtk_tex_wrap wrap;
    float u, v, lod;
};

__global__ void lookup_kernel(rtk_texture_view view, const lookup_case *cases, int n, float *out)
{
    const int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        rtk_texture_view_sample(&view, cases[i].wrap, cases[i].u, cases[i].v, cases[i].lod, out + 4 * (size_t)i);
}

/* A decoded texture of w x h random texels with filter f (its pyramid
 * built by the kernel for trilinear); nullptr out of memory. */
rtk_texture *random_texture(rng *g, int w, int h, rtk_texture_filter f)
{
    rtk_texture *t = static_cast<rtk_texture *>(std::calloc(1, sizeof *t));
    float *px = static_cast<float *>(std::malloc(sizeof *px * 4 * (size_t)w * h));
    if (!t || !px) {
        std::free(t), std::free(px);
        return nullptr;
    }
    for (size_t k = 0; k < 4 * (size_t)w * h; k++)
        px[k] = g->next(0.0f, 1.0f);
    t->width = w, t->height = h, t->rgba = px, t->decoded = 1;
    if (rtk_texture_set_filter(t, f) != RTK_OK) {
        rtk_texture_free(t);
        std::free(t);
        return nullptr;
    }
    return t;
}

/* The view a device gets: the kernel's levels as they are. */
rtk_texture_view view_of(const rtk_texture *t, rtk_texture_level *base)
{
    *base = {t->width, t->height, t->rgba};
    const bool pyramid = t->filter == RTK_TEX_TRILINEAR && t->levels >= 2 && t->mip;
    return {t->filter, pyramid ? t->levels : 1, pyramid ? t->mip : base};
}

/* Coordinates of every kind: inside, far outside, on texel edges, non-finite. */
float coordinate(rng *g, int size, int k)
{
    switch (k % 6) {
    case 0: return g->next(0.0f, 1.0f);
    case 1: return g->next(-40.0f, 40.0f);
    case 2: return std::floor(g->next(-3.0f, 3.0f) * (float)size) / (float)size; /* a texel edge */
    case 3: return (std::floor(g->next(0.0f, 1.0f) * (float)size) + 0.5f) / (float)size; /* a texel centre */
    case 4: return g->next(-1e6f, 1e6f);
    default: return k % 60 == 5 ? NAN : k % 60 == 11 ? INFINITY : g->next(0.999f, 1.001f);
    }
}

/* The lookups on the GPU over a copy of the levels; false when CUDA failed. */
bool run_on_gpu(const rtk_texture_view &host, const std::vector<lookup_case> &cases, std::vector<float> &out)
{
    std::vector<rtk_texture_level> levels(host.level, host.level + host.levels);
    std::vector<float *> copies;
    bool ok = true;
    for (rtk_texture_level &l : levels) {
        float *d = upload(l.rgba, 4 * (size_t)l.width * l.height);
        copies.push_back(d);
        ok = ok && d;
        l.rgba = d;
    }
    rtk_texture_level *dl = ok ? upload(levels.data(), levels.size()) : nullptr;
    lookup_case *dc = upload(cases.data(), cases.size());
    float *dout = nullptr;
    ok = ok && dl && dc && cudaMalloc(&dout, sizeof(float) * 4 * cases.size()) == cudaSuccess;
    if (ok) {
        const rtk_texture_view view = {host.filter, host.levels, dl};
        const int n = (int)cases.size();
        lookup_kernel<<<(n + 127) / 128, 128>>>(view, dc, n, dout);
        out.resize(4 * cases.size());
        ok = cudaGetLastError() == cudaSuccess &&
             cudaMemcpy(out.data(), dout, sizeof(float) * out.size(), cudaMemcpyDeviceToHost) == cudaSuccess;
    }
    for (float *d : copies)
        cudaFree(d);
    cudaFree(dl), cudaFree(dc), cudaFree(dout);
    return ok;
}

} // namespace

int main()
{
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x9e3779b97f4a7c15ull};
    const int sizes[][2] = {{1, 1}, {2, 1}, {1, 5}, {8, 8}, {37, 23}, {64, 16}};
    const rtk_texture_filter filters[] = {RTK_TEX_NEAREST, RTK_TEX_BILINEAR, RTK_TEX_TRILINEAR};
    const char *const names[] = {"nearest", "bilinear", "trilinear"};
    for (int f = 0; f < 3; f++) {
        int bad = 0, count = 0, gpu_bad = 0, levels = 0;
        bool gpu_ran = true;
        for (const auto &size : sizes) {
            rtk_texture *t = random_texture(&g, size[0], size[1], filters[f]);
            if (!t) {
                check(false, "a random texture (out of memory)");
                continue;
            }
            rtk_texture_level base;
            const rtk_texture_view view = view_of(t, &base);
            levels += view.levels;
            std::vector<lookup_case> cases;
            for (int k = 0; k < 6000; k++) {
                lookup_case c;
                c.wrap.s = (uint8_t)(k % 3), c.wrap.t = (uint8_t)(k / 3 % 3);
                c.u = coordinate(&g, size[0], k), c.v = coordinate(&g, size[1], k / 7);
                c.lod = k % 5 == 0 ? std::floor(g.next(0.0f, 8.0f)) : g.next(-1.0f, 8.0f);
                cases.push_back(c);
            }
            std::vector<float> host(4 * cases.size());
            for (size_t i = 0; i < cases.size(); i++) {
                float want[4];
                const lookup_case &c = cases[i];
                rtk_texture_sample(t, c.wrap, c.u, c.v, c.lod, want);
                rtk_texture_view_sample(&view, c.wrap, c.u, c.v, c.lod, &host[4 * i]);
                bad += std::memcmp(want, &host[4 * i], sizeof want) != 0;
                count++;
            }
            std::vector<float> dev;
            if (gpu && !(gpu_ran = gpu_ran && run_on_gpu(view, cases, dev)))
                check(false, "the lookups ran on the GPU");
            if (gpu && gpu_ran)
                gpu_bad += std::memcmp(dev.data(), host.data(), sizeof(float) * host.size()) != 0 ? 1 : 0;
            rtk_texture_free(t);
            std::free(t);
        }
        char what[256];
        std::snprintf(what, sizeof what, "%s: nvcc's host lookups equal rtk_texture_sample on %d lookups over 6 "
                      "textures (%d levels in all): %d differ", names[f], count, levels, bad);
        check(bad == 0 && count == 36000 && (filters[f] != RTK_TEX_TRILINEAR || levels > 6), what);
        if (gpu && gpu_ran) {
            std::snprintf(what, sizeof what, "%s: on the GPU, the lookups of %d of 6 textures differ from the host's "
                          "(want 0)", names[f], gpu_bad);
            check(gpu_bad == 0, what);
        }
    }
    return finish(gpu, e);
}
