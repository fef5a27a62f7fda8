/* kernel/render/sample.h's generators compiled by nvcc (as the CUDA
 * backend compiles them): for independent, stratified and Sobol draws at
 * several seeds, sample counts (square, not square, prime, powers of two)
 * and pixels, a sequence of 1D and 2D draws and seeks equals the
 * kernel's rtk_sample_1d / rtk_sample_2d / rtk_sample_seek bit for bit;
 * on a GPU, when one is present, the device code's equal the host
 * code's. Without a GPU the device code is compiled (for sm_90) but not
 * run, and the test says so. */
#include "render/render.h"
#include "scene/camera.h"

#include <rtk/sampler.h>

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {

/* One pixel sample's draws: DRAWS values, a fixed pattern of 2D draws,
 * 1D draws and seeks (as a path tracer makes them). */
enum { DRAWS = 24 };

struct draw_case {
    rtk_sample_gen gen;
    uint64_t pixel, sample;
};

struct draw_out {
    float v[DRAWS];
};

/* Step k of the pattern: 0 a 2D draw, 1 a 1D draw, 2 a seek to a bounce
 * then a 2D draw. */
RTK_HD int step_kind(int k)
{
    return k % 5 == 4 ? 2 : k % 3 == 1;
}

RTK_HD void draw_shared(const draw_case *c, draw_out *o)
{
    rtk_sample_pos p;
    rtk_sample_start(&c->gen, &p, c->pixel, c->sample);
    int n = 0;
    for (int k = 0; n < DRAWS; k++) {
        int kind = step_kind(k);
        if (kind == 1) {
            o->v[n++] = rtk_sample_next_1d(&c->gen, &p);
            continue;
        }
        if (kind == 2)
            rtk_sample_seek_pos(&c->gen, &p, 7u * (uint32_t)k);
        rtk_vec2 v = rtk_sample_next_2d(&c->gen, &p);
        o->v[n++] = v.x;
        if (n < DRAWS)
            o->v[n++] = v.y;
    }
}

/* The same pattern through the kernel's rtk_ctx functions. */
void draw_kernel(const draw_case *c, draw_out *o)
{
    rtk_ctx ctx;
    std::memset(&ctx, 0, sizeof ctx);
    rtk_ctx_set_sampler(&ctx, c->gen.type, c->gen.seed, c->gen.spp);
    rtk_ctx_start_sample(&ctx, c->pixel, c->sample);
    int n = 0;
    for (int k = 0; n < DRAWS; k++) {
        int kind = step_kind(k);
        if (kind == 1) {
            o->v[n++] = rtk_sample_1d(&ctx);
            continue;
        }
        if (kind == 2)
            rtk_sample_seek(&ctx, 7u * (uint32_t)k);
        rtk_vec2 v = rtk_sample_2d(&ctx);
        o->v[n++] = v.x;
        if (n < DRAWS)
            o->v[n++] = v.y;
    }
}

__global__ void draw_kernel_gpu(const draw_case *in, draw_out *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        draw_shared(&in[i], &out[i]);
}

/* The device code's draws; false when CUDA fails. */
bool draw_on_gpu(const std::vector<draw_case> &cases, std::vector<draw_out> &out)
{
    draw_case *din = nullptr;
    draw_out *dout = nullptr;
    size_t n = cases.size();
    bool ok = cudaMalloc(&din, n * sizeof *din) == cudaSuccess && cudaMalloc(&dout, n * sizeof *dout) == cudaSuccess &&
              cudaMemcpy(din, cases.data(), n * sizeof *din, cudaMemcpyHostToDevice) == cudaSuccess;
    if (ok) {
        draw_kernel_gpu<<<(unsigned)(n + 127) / 128, 128>>>(din, dout, (int)n);
        ok = cudaGetLastError() == cudaSuccess &&
             cudaMemcpy(out.data(), dout, n * sizeof *dout, cudaMemcpyDeviceToHost) == cudaSuccess;
    }
    cudaFree(din);
    cudaFree(dout);
    return ok;
}

/* Camera rays: nvcc's rtk_camera_ray_at against the kernel's
 * rtk_camera_ray, for random cameras and film positions. */
void compare_camera()
{
    rng g = {0x51ed2701ull};
    int bad = 0, cameras = 0;
    const int positions = 2000;
    for (int k = 0; k < 50; k++) {
        rtk_camera_desc d;
        d.position = {g.next(-50, 50), g.next(-50, 50), g.next(-50, 50)};
        d.look_at = {g.next(-50, 50), g.next(-50, 50), g.next(-50, 50)};
        d.up = {g.next(-1, 1), g.next(-1, 1), g.next(-1, 1)};
        d.fov_deg = g.next(5, 170);
        rtk_camera cam;
        if (rtk_camera_init(&cam, &d, 1 + (uint32_t)g.next(0, 2048), 1 + (uint32_t)g.next(0, 2048)) != RTK_OK)
            continue;
        cameras++;
        for (int i = 0; i < positions; i++) {
            float fx = g.next(-1.0f, (float)cam.width + 1.0f), fy = g.next(-1.0f, (float)cam.height + 1.0f);
            rtk_ray a = rtk_camera_ray(&cam, fx, fy), b = rtk_camera_ray_at(&cam, fx, fy);
            bad += std::memcmp(&a, &b, sizeof a) != 0;
        }
    }
    char what[256];
    std::snprintf(what, sizeof what, "camera rays: nvcc's host code = the kernel's rtk_camera_ray, bit for bit (%d "
                  "cameras x %d film positions): %d differ", cameras, positions, bad);
    check(bad == 0 && cameras > 40, what);
}

} // namespace

int main()
{
    compare_camera();
    static const char *const names[3] = {"independent", "stratified", "sobol"};
    static const uint32_t spps[] = {1, 2, 7, 8, 12, 16, 97, 256};
    static const uint64_t seeds[] = {0, 7, 0x9e3779b97f4a7c15ull};
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    for (int type = 0; type < 3; type++) {
        std::vector<draw_case> cases;
        for (uint64_t seed : seeds)
            for (uint32_t spp : spps)
                for (uint64_t pixel = 0; pixel < 40; pixel++)
                    for (uint64_t s = 0; s < 2u * spp + 3u; s += 1u + s / 16u) {
                        draw_case c;
                        rtk_sample_gen_init(&c.gen, (rtk_sampler_type)type, seed, spp);
                        c.pixel = pixel * 104729u;
                        c.sample = s + (pixel % 3 == 2 ? 0xfffffff0ull : 0);
                        cases.push_back(c);
                    }
        std::vector<draw_out> host(cases.size()), kernel(cases.size()), device(cases.size());
        size_t bad = 0;
        for (size_t i = 0; i < cases.size(); i++) {
            draw_shared(&cases[i], &host[i]);
            draw_kernel(&cases[i], &kernel[i]);
            bad += std::memcmp(&host[i], &kernel[i], sizeof host[i]) != 0;
        }
        char what[256];
        std::snprintf(what, sizeof what, "%s: nvcc's host code = the kernel's rtk_sample_1d/2d/seek, bit for bit "
                      "(%zu samples x %d draws): %zu differ", names[type], cases.size(), (int)DRAWS, bad);
        check(bad == 0, what);
        if (!gpu)
            continue;
        bool ran = draw_on_gpu(cases, device);
        bad = 0;
        for (size_t i = 0; ran && i < cases.size(); i++)
            bad += std::memcmp(&device[i], &host[i], sizeof host[i]) != 0;
        std::snprintf(what, sizeof what, "%s: the GPU's device code = the host code, bit for bit (%zu samples): "
                      "%s%zu differ", names[type], cases.size(), ran ? "" : "CUDA failed; ", bad);
        check(ran && bad == 0, what);
    }
    return finish(gpu, e);
}
