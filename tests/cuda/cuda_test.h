/* What the tests/cuda programs share: the ok/FAIL lines and their count,
 * a repeatable random spread, camera rays into tests/scenes/textured,
 * copies to the device, and the GPU probe with its closing lines. */
#ifndef RTK_TESTS_CUDA_TEST_H
#define RTK_TESTS_CUDA_TEST_H

#include <rtk/ray.h>

#include <cuda_runtime.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <vector>

inline int passed = 0, failed = 0;

inline void check(bool ok, const char *what)
{
    std::printf("%s  %s\n", ok ? "ok  " : "FAIL", what);
    (ok ? passed : failed)++;
}

/* xorshift64*: the cases need no more than a repeatable spread. */
struct rng {
    uint64_t s;
    float next(float lo, float hi)
    {
        s ^= s >> 12, s ^= s << 25, s ^= s >> 27;
        uint32_t r = (uint32_t)((s * 2685821657736338717ull) >> 40);
        return lo + (hi - lo) * ((float)r * (1.0f / 16777216.0f));
    }
};

/* n camera rays from around tests/scenes/textured/textured.cfg's camera
 * towards points on the floor and the ball; one in eight past the
 * floor's side. */
inline std::vector<rtk_ray> textured_camera_rays(int n, rng *g)
{
    std::vector<rtk_ray> rays(n);
    for (int i = 0; i < n; i++) {
        const rtk_vec3 org = rtk_vec3_make(g->next(-0.3f, 0.3f), g->next(1.2f, 1.8f), g->next(-2.4f, -2.0f));
        const float x = i % 8 == 7 ? g->next(1.1f, 1.6f) : g->next(-0.9f, 0.9f);
        const rtk_vec3 at = rtk_vec3_make(x, g->next(0.0f, 0.3f), g->next(-0.9f, 0.9f));
        rays[i] = {org, 0.0f, rtk_vec3_sub(at, org), INFINITY};
    }
    return rays;
}

/* Whether a GPU is there to run the device code on; *why holds
 * cudaGetDeviceCount's answer. */
inline bool gpu_present(cudaError_t *why)
{
    int devices = 0;
    *why = cudaGetDeviceCount(&devices);
    return *why == cudaSuccess && devices > 0;
}

/* A device copy of n items at p; nullptr when p is null, n is 0 or CUDA
 * fails. [caller cudaFrees] */
template <typename T> T *upload(const T *p, size_t n)
{
    T *d = nullptr;
    if (!p || n == 0 || cudaMalloc(&d, n * sizeof *p) != cudaSuccess)
        return nullptr;
    if (cudaMemcpy(d, p, n * sizeof *p, cudaMemcpyHostToDevice) != cudaSuccess) {
        cudaFree(d);
        return nullptr;
    }
    return d;
}

/* The closing lines (the skip of the device code without a GPU, the
 * counts) and the exit status. */
inline int finish(bool gpu, cudaError_t why)
{
    if (!gpu)
        std::printf("skip  the device code on a GPU: none here (cudaGetDeviceCount: %s); compiled for sm_90, not run\n",
                    why == cudaSuccess ? "0 devices" : cudaGetErrorString(why));
    std::printf("%d passed, %d failed\n", passed, failed);
    return failed != 0;
}

#endif
