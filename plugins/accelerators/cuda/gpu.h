/* The cuda plugin's GPU side (gpu.cu) behind plain C, so that cuda.c, the
 * plugin itself, stays C: one device holding a tree, and lanes (a CUDA
 * stream with its ray and result buffers, one per tracing thread at a
 * time). Functions return 0 on success, else write why (the CUDA call and
 * its error) into why[cap] and return -1. */
#ifndef RTK_CUDA_GPU_H
#define RTK_CUDA_GPU_H

#include "../../integrators/device_programs.h"

#include <rtk/accelerator.h>

#include <stddef.h>
#include <stdint.h>

RTK_EXTERN_C_BEGIN

typedef struct rtk_gpu rtk_gpu;
typedef struct rtk_gpu_lane rtk_gpu_lane;

/* Opens device ordinal (0 = the first), naming it in name[name_cap]. */
int rtk_gpu_open(int ordinal, char *name, size_t name_cap, rtk_gpu **out, char *why, size_t cap);
/* Copies tree's nodes, leaf order and corners to the device (once), an
 * instanced scene's meshes, top level and placements, and what device
 * programs read (each triangle's slot, the normals, materials, vertex
 * colours and lights). */
int rtk_gpu_upload(rtk_gpu *gpu, const rtk_device_tree *tree, double *seconds, char *why, size_t cap);
/* Device memory the tree and the lanes hold, in bytes. */
uint64_t rtk_gpu_bytes(const rtk_gpu *gpu);
/* Frees the tree; the lanes must be closed first. */
void rtk_gpu_close(rtk_gpu *gpu);

/* A lane for batches of up to capacity rays. */
int rtk_gpu_lane_open(rtk_gpu *gpu, uint32_t capacity, rtk_gpu_lane **out, char *why, size_t cap);
void rtk_gpu_lane_close(rtk_gpu *gpu, rtk_gpu_lane *lane);
/* Traces count <= capacity rays on lane: closest hits into hits (as
 * device_tree.h's rtk_flat_scene_closest) when hits is not NULL, else
 * occlusion into occluded (0 or 1). seconds gets the upload of the rays,
 * the traversal and the download of the results (CUDA events). */
int rtk_gpu_trace(rtk_gpu *gpu, rtk_gpu_lane *lane, const rtk_ray *rays, uint32_t count, rtk_hit *hits,
                  uint8_t *occluded, double seconds[3], char *why, size_t cap);

/* Runs program p on count <= capacity camera samples on lane
 * (plugins/integrators/device_programs.h): one GPU thread a sample (a
 * megakernel), or for path with wavefront set one round of kernels a
 * vertex over the walks still going (rtk_program_path_wavefront's
 * steps), diffs the camera rays' differentials (NULL: none); results
 * into out (filled as the kernel pre-fills them, then by the program),
 * the rays it traced and the invalid ones added to counts[0] and
 * counts[1]. seconds as for rtk_gpu_trace. */
int rtk_gpu_shade(rtk_gpu *gpu, rtk_gpu_lane *lane, const rtk_program *p, int wavefront, rtk_rgb albedo,
                  const rtk_sample_gen *gen, const rtk_ray *rays, const rtk_ray_differential *diffs,
                  const rtk_sample_pos *pos, uint32_t count, rtk_li_result *out, uint64_t counts[2],
                  double seconds[3], char *why, size_t cap);

RTK_EXTERN_C_END

#endif
