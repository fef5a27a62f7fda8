/* cuda: a device accelerator (ABI 3.5) that traces ray batches on an
 * NVIDIA GPU. The tree comes from another accelerator (builder, through
 * the BVH cache like any build; an instanced scene's meshes and top level
 * too); the GPU runs the kernel's own traversal (kernel/accel/
 * device_tree.h, gpu.cu) one thread per ray, so its hits equal the CPU's
 * bit for bit. Batches go to the GPU in chunks of up to
 * `chunk` rays on a lane (stream and buffers) of the calling thread's own;
 * if the GPU fails mid-run, a warning names the CUDA error and the rest is
 * traced on the CPU with the same code.
 *
 * Parameters:
 *   builder  string            sah     the accelerator that builds the tree
 *   chunk    int [1024, 2^20]  262144  rays per transfer and launch
 * It runs on CUDA's first device; CUDA_VISIBLE_DEVICES picks another.
 *
 * Example: accelerator = { plugin = "cuda"; builder = "lbvh"; }; */
#include "gpu.h"

#include "accel/device_tree.h"

#include <rtk/rtk.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The lanes no thread is using; a tracing thread takes one or opens one. */
typedef struct lane_pool {
    rtk_gpu_lane **free;
    uint32_t count, cap;
} lane_pool;

typedef struct cuda {
    uint32_t chunk;
    rtk_gpu *gpu;
    char name[128];
    rtk_flat_scene host;  /* the kernel's arrays: the CPU fallback */
    rtk_flat_tree *host_meshes;
    pthread_mutex_t lock; /* pool, report, gpu's byte count, failed */
    lane_pool pool;
    int failed;           /* the GPU failed: every later ray on the CPU */
    rtk_device_report sums;
} cuda;

static rtk_status cuda_create(const rtk_params *params, void **state)
{
    cuda *c = calloc(1, sizeof *c);
    if (!c)
        return rtk_error(RTK_ERR_NOMEM, "cuda: out of memory");
    c->chunk = (uint32_t)rtk_params_int(params, "chunk");
    pthread_mutex_init(&c->lock, NULL);
    char why[512];
    if (rtk_gpu_open(0, c->name, sizeof c->name, &c->gpu, why, sizeof why) != 0) {
        pthread_mutex_destroy(&c->lock);
        free(c);
        return rtk_error(RTK_ERR_UNSUPPORTED, "cuda: %s; run on a machine with an NVIDIA GPU (compute capability 9.0 "
                         "or later) and its driver, or pick sah or lbvh", why);
    }
    *state = c;
    return RTK_OK;
}

static rtk_status cuda_attach(void *state, const rtk_device_tree *tree)
{
    cuda *c = state;
    char why[512];
    double seconds = 0.0;
    if (rtk_gpu_upload(c->gpu, tree, &seconds, why, sizeof why) != 0)
        return rtk_error(RTK_ERR_NOMEM, "cuda: uploading the tree (%u nodes, %u triangles) to %s: %s",
                         tree->node_count, tree->slot_count, c->name, why);
    c->host_meshes = calloc(tree->mesh_count ? tree->mesh_count : 1, sizeof *c->host_meshes);
    if (!c->host_meshes)
        return rtk_error(RTK_ERR_NOMEM, "cuda: out of memory");
    rtk_flat_scene_of(tree, c->host_meshes, &c->host);
    c->sums.upload_seconds = seconds;
    return RTK_OK;
}

/* A lane for the calling thread, NULL when the GPU is out (failed, or no
 * lane could be opened: warned once). */
static rtk_gpu_lane *take_lane(cuda *c)
{
    rtk_gpu_lane *lane = NULL;
    char why[512] = "";
    pthread_mutex_lock(&c->lock);
    if (!c->failed) {
        if (c->pool.count > 0) {
            lane = c->pool.free[--c->pool.count];
        } else if (rtk_gpu_lane_open(c->gpu, c->chunk, &lane, why, sizeof why) != 0) {
            c->failed = 1;
            lane = NULL;
        }
    }
    pthread_mutex_unlock(&c->lock);
    if (why[0])
        rtk_log(RTK_LOG_WARN, "cuda: %s: %s; tracing the rest on the CPU", c->name, why);
    return lane;
}

static void give_lane(cuda *c, rtk_gpu_lane *lane)
{
    pthread_mutex_lock(&c->lock);
    if (c->pool.count == c->pool.cap) {
        uint32_t cap = c->pool.cap ? 2 * c->pool.cap : 16;
        rtk_gpu_lane **grown = realloc(c->pool.free, sizeof *grown * cap);
        if (grown)
            c->pool.free = grown, c->pool.cap = cap;
    }
    if (c->pool.count < c->pool.cap)
        c->pool.free[c->pool.count++] = lane;
    else
        rtk_gpu_lane_close(c->gpu, lane);
    pthread_mutex_unlock(&c->lock);
}

/* The batch, on the GPU chunk by chunk while it works, the rest on the
 * CPU: closest hits into hits, or occlusion into occluded. */
static void trace(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits, uint8_t *occluded)
{
    cuda *c = (cuda *)state;
    if (count == 0)
        return; /* an empty batch opens no lane */
    rtk_gpu_lane *lane = take_lane(c);
    double seconds[3], sums[3] = {0.0, 0.0, 0.0};
    uint32_t done = 0, chunks = 0;
    char why[512] = "";
    while (lane && done < count) {
        const uint32_t n = count - done < c->chunk ? count - done : c->chunk;
        if (rtk_gpu_trace(c->gpu, lane, rays + done, n, hits ? hits + done : NULL, hits ? NULL : occluded + done,
                          seconds, why, sizeof why) != 0)
            break;
        for (int k = 0; k < 3; k++)
            sums[k] += seconds[k];
        done += n;
        chunks++;
    }
    for (uint32_t i = done; i < count; i++) {
        if (hits)
            rtk_flat_scene_closest(&c->host, &rays[i], &hits[i]);
        else
            occluded[i] = (uint8_t)rtk_flat_scene_any(&c->host, &rays[i]);
    }
    pthread_mutex_lock(&c->lock);
    const int first_failure = why[0] && !c->failed;
    if (why[0])
        c->failed = 1;
    c->sums.upload_seconds += sums[0];
    c->sums.trace_seconds += sums[1];
    c->sums.download_seconds += sums[2];
    c->sums.rays += done;
    c->sums.batches += chunks;
    c->sums.cpu_rays += count - done;
    pthread_mutex_unlock(&c->lock);
    if (first_failure)
        rtk_log(RTK_LOG_WARN, "cuda: %s failed: %s; tracing the rest on the CPU", c->name, why);
    if (lane)
        give_lane(c, lane);
}

static void cuda_closest_batch(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    trace(state, rays, count, hits, NULL);
}

static void cuda_any_batch(const void *state, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    trace(state, rays, count, NULL, occluded);
}

static void cuda_report(const void *state, rtk_device_report *out)
{
    cuda *c = (cuda *)state;
    pthread_mutex_lock(&c->lock);
    const uint32_t size = out->size;
    *out = c->sums;
    out->size = size;
    snprintf(out->device, sizeof out->device, "%s", c->name);
    out->device_bytes = rtk_gpu_bytes(c->gpu);
    pthread_mutex_unlock(&c->lock);
}

static void cuda_destroy(void *state)
{
    cuda *c = state;
    for (uint32_t i = 0; i < c->pool.count; i++)
        rtk_gpu_lane_close(c->gpu, c->pool.free[i]);
    free(c->pool.free);
    free(c->host_meshes);
    rtk_gpu_close(c->gpu);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

static const rtk_param_desc cuda_params[] = {
    {.name = "builder", .type = RTK_PARAM_STRING, .def_string = "sah",
     .doc = "the accelerator that builds the tree the GPU traces (median, sah or lbvh, with its defaults)"},
    {.name = "chunk", .type = RTK_PARAM_INT, .def = 262144, .min = 1024, .max = 1048576,
     .doc = "rays per transfer and launch; each tracing thread holds buffers for this many on the GPU and pinned "
            "in host memory (53 bytes a ray)"},
};

static const rtk_accelerator_fns cuda_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = cuda_create,
    .destroy = cuda_destroy,
    .closest_batch = cuda_closest_batch,
    .any_batch = cuda_any_batch,
    .attach = cuda_attach,
    .report = cuda_report,
};

static const rtk_plugin cuda_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_ACCELERATOR,
    .name = "cuda",
    .version = "1.0",
    .summary = "ray batches traced on an NVIDIA GPU (CUDA) over the tree a builder made",
    .params = cuda_params,
    .param_count = RTK_COUNTOF(cuda_params),
    .functions = &cuda_fns,
};

RTK_PLUGIN_ENTRY(cuda_plugin)
