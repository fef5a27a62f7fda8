/* cuda: a device accelerator (ABI 3.6) that traces ray batches on an
 * NVIDIA GPU. The tree comes from another accelerator (builder, through
 * the BVH cache like any build; an instanced scene's meshes and top level
 * too); the GPU runs the kernel's own traversal (kernel/accel/
 * device_tree.h, gpu.cu) one thread per ray, so its hits equal the CPU's
 * bit for bit. Batches go to the GPU in chunks of up to
 * `chunk` rays on a lane (stream and buffers) of the calling thread's own;
 * if the GPU fails mid-run, a warning names the CUDA error and the rest is
 * traced on the CPU with the same code.
 * It also runs integrators' device programs (plugins/integrators/
 * device_programs.h: ao, headlight, path), one GPU thread per camera sample
 * (path also as a wavefront: a round of kernels per vertex), which trace
 * and shade whole samples there; likewise on the CPU after a failure.
 *
 * Parameters:
 *   builder   string            sah     the accelerator that builds the tree
 *   chunk     int [1024, 2^20]  262144  rays (or program samples) per transfer and launch
 *   programs  bool              true    run device programs (false: trace batches only)
 *   wavefront bool              false   run path's program as a wavefront (false: one kernel)
 * It runs on CUDA's first device; CUDA_VISIBLE_DEVICES picks another.
 *
 * Example: accelerator = { plugin = "cuda"; builder = "lbvh"; }; */
#include "gpu.h"


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
    int programs, wavefront;
    rtk_gpu *gpu;
    char name[128];
    rtk_flat_scene host;  /* the kernel's arrays: the CPU fallback */
    rtk_flat_tree *host_meshes;
    rtk_program_scene host_program; /* the same for device programs */
    void *host_slots;
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
    c->programs = rtk_params_bool(params, "programs");
    c->wavefront = rtk_params_bool(params, "wavefront");
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
    if (rtk_program_scene_of(tree, &c->host, &c->host_slots, &c->host_program) != 0)
        return rtk_error(RTK_ERR_NOMEM, "cuda: out of memory");
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

/* What one call did on the GPU: upload, run and download seconds, rays
 * and launches there, program samples there, rays on the CPU. */
typedef struct lane_work {
    double seconds[3];
    uint64_t rays, launches, samples, cpu_rays;
} lane_work;

/* Adds w to the report (a program's run time as shading, else as
 * tracing), warns once if the GPU failed (why), and gives the lane back. */
static void finish_work(cuda *c, rtk_gpu_lane *lane, const lane_work *w, int program, const char *why)
{
    pthread_mutex_lock(&c->lock);
    const int first_failure = why[0] && !c->failed;
    if (why[0])
        c->failed = 1;
    c->sums.upload_seconds += w->seconds[0];
    *(program ? &c->sums.shade_seconds : &c->sums.trace_seconds) += w->seconds[1];
    c->sums.download_seconds += w->seconds[2];
    c->sums.rays += w->rays;
    c->sums.batches += w->launches;
    c->sums.samples += w->samples;
    c->sums.cpu_rays += w->cpu_rays;
    pthread_mutex_unlock(&c->lock);
    if (first_failure)
        rtk_log(RTK_LOG_WARN, "cuda: %s failed: %s; %s the rest on the CPU", c->name, why,
                program ? "shading" : "tracing");
    if (lane)
        give_lane(c, lane);
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
    const lane_work w = {{sums[0], sums[1], sums[2]}, done, chunks, 0, count - done};
    finish_work(c, lane, &w, 0, why);
}

static void cuda_closest_batch(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    trace(state, rays, count, hits, NULL);
}

static void cuda_any_batch(const void *state, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    trace(state, rays, count, NULL, occluded);
}

/* The batch's samples through the program, on the GPU chunk by chunk
 * while it works, the rest on the CPU. */
static rtk_status cuda_shade(const void *state, rtk_shade_batch *b)
{
    cuda *c = (cuda *)state;
    const rtk_program p = rtk_program_of(b->program);
    if (!c->programs)
        return rtk_error(RTK_ERR_UNSUPPORTED, "cuda: programs = false");
    if (p.kind == RTK_PROGRAM_NONE)
        return rtk_error(RTK_ERR_UNSUPPORTED, "cuda: no device program '%.32s' with these parameters",
                         b->program->name);
    if (b->count == 0)
        return RTK_OK;
    rtk_gpu_lane *lane = take_lane(c);
    double seconds[3], sums[3] = {0.0, 0.0, 0.0};
    uint64_t counts[2] = {0, 0};
    uint32_t done = 0, chunks = 0;
    char why[512] = "";
    while (lane && done < b->count) {
        const uint32_t n = b->count - done < c->chunk ? b->count - done : c->chunk;
        if (rtk_gpu_shade(c->gpu, lane, &p, c->wavefront, b->albedo, b->gen, b->rays + done,
                          b->diffs ? b->diffs + done : NULL, b->pos + done, n, b->out + done, counts, seconds, why,
                          sizeof why) != 0)
            break;
        for (int k = 0; k < 3; k++)
            sums[k] += seconds[k];
        done += n;
        chunks++;
    }
    const uint64_t gpu_rays = counts[0];
    rtk_program_scene host = c->host_program;
    host.albedo = b->albedo;
    for (uint32_t i = done; i < b->count; i++) {
        rtk_program_count n;
        rtk_program_run(&p, &host, b->gen, &b->pos[i], &b->rays[i], b->diffs ? &b->diffs[i] : NULL, &b->out[i], &n);
        counts[0] += n.traced, counts[1] += n.invalid;
    }
    b->rays_traced = counts[0];
    b->invalid_rays = counts[1];
    const lane_work w = {{sums[0], sums[1], sums[2]}, gpu_rays, chunks, done, counts[0] - gpu_rays};
    finish_work(c, lane, &w, 1, why);
    return RTK_OK;
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
    free(c->host_slots);
    rtk_gpu_close(c->gpu);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

static const rtk_param_desc cuda_params[] = {
    {.name = "builder", .type = RTK_PARAM_STRING, .def_string = "sah",
     .doc = "the accelerator that builds the tree the GPU traces (median, sah or lbvh, with its defaults)"},
    {.name = "chunk", .type = RTK_PARAM_INT, .def = 262144, .min = 1024, .max = 1048576,
     .doc = "rays per transfer and launch; each tracing thread holds buffers for this many on the GPU and pinned "
            "in host memory (53 bytes a ray; 104 more a sample once it runs a program)"},
    {.name = "programs", .type = RTK_PARAM_BOOL, .def = 1,
     .doc = "run integrators' device programs, which trace and shade whole samples on the GPU (false: trace "
            "their batches only)"},
    {.name = "wavefront", .type = RTK_PARAM_BOOL, .def = 0,
     .doc = "run path's program as a wavefront, a round of kernels per path vertex over the paths still going "
            "(about 200 more bytes a sample on the GPU; false: one kernel runs each sample's whole path)"},
};

static const rtk_accelerator_fns cuda_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = cuda_create,
    .destroy = cuda_destroy,
    .closest_batch = cuda_closest_batch,
    .any_batch = cuda_any_batch,
    .attach = cuda_attach,
    .report = cuda_report,
    .shade = cuda_shade,
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
