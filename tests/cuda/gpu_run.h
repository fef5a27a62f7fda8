/* tests/cuda's programs run through the cuda plugin's own upload and launch
 * (plugins/accelerators/cuda/gpu.cu, linked into the test). */
#ifndef RTK_TESTS_CUDA_GPU_RUN_H
#define RTK_TESTS_CUDA_GPU_RUN_H

#include "../../plugins/accelerators/cuda/gpu.h"

#include <cstdint>
#include <cstdio>
#include <vector>

/* Program p over tree on GPU 0 (path as a wavefront when wavefront is
 * set), its rays counted in counts; false (saying why) when CUDA failed. */
inline bool run_on_gpu(const rtk_device_tree &tree, const rtk_program &p, int wavefront, rtk_rgb albedo,
                       const rtk_sample_gen &gen, const std::vector<rtk_ray> &rays,
                       const std::vector<rtk_sample_pos> &pos, std::vector<rtk_li_result> &out, uint64_t counts[2],
                       const rtk_ray_differential *diffs = nullptr)
{
    char name[128], why[512] = "";
    rtk_gpu *gpu = nullptr;
    rtk_gpu_lane *lane = nullptr;
    double seconds = 0.0, steps[3];
    counts[0] = counts[1] = 0;
    out.resize(rays.size());
    const uint32_t n = (uint32_t)rays.size();
    const bool ok = rtk_gpu_open(0, name, sizeof name, &gpu, why, sizeof why) == 0 &&
                    rtk_gpu_upload(gpu, &tree, &seconds, why, sizeof why) == 0 &&
                    rtk_gpu_lane_open(gpu, n, &lane, why, sizeof why) == 0 &&
                    rtk_gpu_shade(gpu, lane, &p, wavefront, albedo, &gen, rays.data(), diffs, pos.data(), n,
                                  out.data(), counts, steps, why, sizeof why) == 0;
    if (!ok)
        std::printf("      CUDA: %s\n", why);
    if (lane)
        rtk_gpu_lane_close(gpu, lane);
    if (gpu)
        rtk_gpu_close(gpu);
    return ok;
}

#endif
