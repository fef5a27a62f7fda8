/* What the tests/cuda programs share: the ok/FAIL lines and their count,
 * a repeatable random spread, copies to the device, and the GPU probe
 * with its closing lines. */
#ifndef RTK_TESTS_CUDA_TEST_H
#define RTK_TESTS_CUDA_TEST_H

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>

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
