/* The cuda plugin's GPU side: the trees in device memory (the kernel's
 * 32-byte binary nodes, leaf order, 36 bytes of corners a slot; for an
 * instanced scene each mesh's, the top level and the placements; for
 * device programs every tree's slots, normals, materials, vertex colours,
 * emitters, texture coordinates and textures, the instances' frames and
 * the lights) and one thread per ray, or per camera sample of a program,
 * running the kernel's own
 * traversal (device_tree.h, which tests/cuda checks against the kernel
 * bit for bit). Built with
 * --fmad=false: CUDA would otherwise contract a * b + c, which the kernel
 * never does, and hits would differ in the last bit. */
#include "gpu.h"

#include "accel/device_tree.h"

#include <cuda_runtime.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>

struct rtk_gpu {
    int ordinal;
    rtk_flat_scene scene;   /* device pointers */
    rtk_program_scene program_scene; /* the same, with what programs read */
    void **blocks;          /* every device allocation of the trees */
    size_t block_count, block_cap;
    uint64_t tree_bytes, lane_bytes;
};

struct rtk_gpu_lane {
    cudaStream_t stream;
    cudaEvent_t marks[4];
    uint32_t capacity;
    rtk_ray *rays, *host_rays;    /* device, pinned host */
    rtk_hit *hits, *host_hits;
    uint8_t *occluded, *host_occluded;
    /* Device programs' buffers, made at the lane's first program. */
    rtk_sample_pos *pos, *host_pos;
    rtk_li_result *out, *host_out;
    rtk_program_count *counts, *host_counts;
    /* Camera differentials, made at the first batch that carries them. */
    rtk_ray_differential *diffs, *host_diffs;
    /* A wavefront's: every sample's walk, the live walks' queue and the
     * next one, the queue of pending shadow rays, their lengths (device,
     * and the next queue's length on the host). Made at the first. */
    rtk_path_walk *walks;
    uint32_t *queue[2], *shadows;
    uint32_t *lengths, *host_length;
};

namespace {

/* 0 when call succeeded, else -1 with "what: CUDA's message" in why. */
int cuda_failed(cudaError_t err, const char *what, char *why, size_t cap)
{
    if (err == cudaSuccess)
        return 0;
    std::snprintf(why, cap, "%s: %s (%s)", what, cudaGetErrorString(err), cudaGetErrorName(err));
    return -1;
}

__global__ void closest_kernel(rtk_flat_scene scene, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count) {
        rtk_hit hit;
        rtk_flat_scene_closest(&scene, &rays[i], &hit);
        hits[i] = hit;
    }
}

__global__ void any_kernel(rtk_flat_scene scene, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count)
        occluded[i] = (uint8_t)rtk_flat_scene_any(&scene, &rays[i]);
}

/* One sample a thread. */
__global__ void program_kernel(rtk_program p, rtk_program_scene s, rtk_sample_gen g, const rtk_ray *rays,
                               const rtk_ray_differential *diffs, const rtk_sample_pos *pos, uint32_t count,
                               rtk_li_result *out, rtk_program_count *counts)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count)
        rtk_program_run(&p, &s, &g, &pos[i], &rays[i], diffs ? &diffs[i] : nullptr, &out[i], &counts[i]);
}

/* Path as a wavefront (rtk_program_path_wavefront's steps as kernels):
 * each sample's walk started; then, while walks go on, every live walk's
 * hit and shading (queueing its shadow ray and, when it goes on, itself
 * for the next round), then every queued shadow ray; then the radiances.
 * lengths[0] counts the next queue, lengths[1] the shadow rays. */
__global__ void walk_start_kernel(const rtk_ray *rays, const rtk_sample_pos *pos, uint32_t count, rtk_li_result *out,
                                  rtk_program_count *counts, rtk_path_walk *walks, uint32_t *queue)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count) {
        rtk_program_prefill(&out[i], &counts[i]);
        rtk_path_walk_start(&walks[i], &rays[i], pos[i]);
        queue[i] = i;
    }
}

__global__ void walk_extend_kernel(rtk_program p, rtk_program_scene s, rtk_sample_gen g,
                                   const rtk_ray_differential *diffs, const uint32_t *queue, uint32_t live,
                                   rtk_path_walk *walks, rtk_li_result *out, rtk_program_count *counts, uint32_t *next,
                                   uint32_t *shadows, uint32_t *lengths)
{
    const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
    if (k >= live)
        return;
    const uint32_t i = queue[k];
    rtk_path_walk w = walks[i];
    rtk_hit hit;
    const int found = rtk_program_trace(&s, &w.ray, &counts[i], &hit);
    rtk_path_walk_shade(&p, &s, &g, &w, found ? &hit : NULL, diffs ? &diffs[i] : nullptr, &out[i]);
    walks[i] = w;
    if (w.shadowed)
        shadows[atomicAdd(&lengths[1], 1u)] = i;
    if (w.more)
        next[atomicAdd(&lengths[0], 1u)] = i;
}

__global__ void walk_shadow_kernel(rtk_program_scene s, const uint32_t *shadows, const uint32_t *lengths,
                                   rtk_path_walk *walks, rtk_program_count *counts)
{
    const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
    if (k >= lengths[1])
        return;
    const uint32_t i = shadows[k];
    rtk_path_walk_shadow(&walks[i], rtk_program_occluded(&s, &walks[i].shadow, &counts[i]));
}

__global__ void walk_finish_kernel(const rtk_path_walk *walks, uint32_t count, rtk_li_result *out)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count)
        out[i].radiance = walks[i].L;
}

const unsigned block_threads = 128;

} // namespace

int rtk_gpu_open(int ordinal, char *name, size_t name_cap, rtk_gpu **out, char *why, size_t cap)
{
    int devices = 0;
    cudaError_t err = cudaGetDeviceCount(&devices);
    if (err != cudaSuccess || devices == 0) {
        std::snprintf(why, cap, "no CUDA device (cudaGetDeviceCount: %s)",
                      err == cudaSuccess ? "0 devices" : cudaGetErrorString(err));
        return -1;
    }
    if (ordinal >= devices) {
        std::snprintf(why, cap, "device = %d, but this machine has %d CUDA device%s (0 to %d)", ordinal, devices,
                      devices == 1 ? "" : "s", devices - 1);
        return -1;
    }
    cudaDeviceProp prop;
    if (cuda_failed(cudaSetDevice(ordinal), "cudaSetDevice", why, cap) ||
        cuda_failed(cudaGetDeviceProperties(&prop, ordinal), "cudaGetDeviceProperties", why, cap))
        return -1;
    if (prop.major < 9) {
        std::snprintf(why, cap, "device %d (%s) has compute capability %d.%d; this build's code is for 9.0 (Hopper) "
                      "and later", ordinal, prop.name, prop.major, prop.minor);
        return -1;
    }
    rtk_gpu *g = new (std::nothrow) rtk_gpu();
    if (!g) {
        std::snprintf(why, cap, "out of memory");
        return -1;
    }
    g->ordinal = ordinal;
    std::snprintf(name, name_cap, "%s", prop.name);
    *out = g;
    return 0;
}

/* A copy of bytes bytes at host in device memory (NULL for none), kept
 * in g's blocks; 0, or -1 with why. */
static int put(rtk_gpu *g, const void *host, size_t bytes, const void **out, const char *what, char *why, size_t cap)
{
    *out = nullptr;
    if (!host || bytes == 0)
        return 0;
    if (g->block_count == g->block_cap) {
        size_t n = g->block_cap ? 2 * g->block_cap : 64;
        void **grown = static_cast<void **>(std::realloc(g->blocks, sizeof *grown * n));
        if (!grown) {
            std::snprintf(why, cap, "out of memory");
            return -1;
        }
        g->blocks = grown, g->block_cap = n;
    }
    void *d = nullptr;
    char call[128];
    std::snprintf(call, sizeof call, "cudaMalloc (%s)", what);
    if (cuda_failed(cudaMalloc(&d, bytes), call, why, cap))
        return -1;
    g->blocks[g->block_count++] = d;
    g->tree_bytes += bytes;
    std::snprintf(call, sizeof call, "cudaMemcpy (%s)", what);
    if (cuda_failed(cudaMemcpy(d, host, bytes, cudaMemcpyHostToDevice), call, why, cap))
        return -1;
    *out = d;
    return 0;
}

/* One tree's arrays on the device. */
static int put_tree(rtk_gpu *g, const rtk_device_tree *t, rtk_flat_tree *out, char *why, size_t cap)
{
    const void *nodes, *ids, *corners;
    if (put(g, t->nodes, sizeof(rtk_bvh_node) * (size_t)t->node_count, &nodes, "nodes", why, cap) ||
        put(g, t->prim_ids, sizeof(uint32_t) * (size_t)t->slot_count, &ids, "leaf order", why, cap) ||
        put(g, t->corners, sizeof(float) * 9 * (size_t)t->slot_count, &corners, "triangles", why, cap))
        return -1;
    out->nodes = static_cast<const rtk_bvh_node *>(nodes);
    out->prim_ids = static_cast<const uint32_t *>(ids);
    out->corners = static_cast<const float *>(corners);
    return 0;
}

/* Typed put: count elements of host (none when NULL). */
template <typename T>
static int put_n(rtk_gpu *g, const T *host, size_t count, const T **out, const char *what, char *why, size_t cap)
{
    const void *d = nullptr;
    const int st = put(g, host, sizeof(T) * count, &d, what, why, cap);
    *out = static_cast<const T *>(d);
    return st;
}

/* The lights of tree (its emitters' table over slot_count triangles, the
 * choice between lights, the environment) and its punctual lights on the
 * device, for programs that sample them; *out stays NULL when it has none. */
static int put_lights(rtk_gpu *g, const rtk_device_tree *t, const rtk_lights **out,
                      const rtk_punctual_light **punctual, char *why, size_t cap)
{
    *out = nullptr;
    *punctual = nullptr;
    if (!t->lights)
        return 0;
    rtk_lights l = *t->lights;
    const size_t n = l.count;
    const uint32_t *prims, *insts, *alias, *light_of;
    const float *area, *pick, *alias_prob, *slot_pick, *slot_cdf;
    if (put_n(g, l.prims, n, &prims, "emitters", why, cap) || put_n(g, l.insts, n, &insts, "emitters", why, cap) ||
        put_n(g, l.area, n, &area, "emitter areas", why, cap) || put_n(g, l.pick, n, &pick, "emitter picks", why, cap) ||
        put_n(g, l.alias_prob, n, &alias_prob, "alias table", why, cap) ||
        put_n(g, l.alias, n, &alias, "alias table", why, cap) ||
        put_n(g, n ? l.light_of : nullptr, t->slot_count, &light_of, "emitters of triangles", why, cap) ||
        put_n(g, l.slot_pick, l.slot_count, &slot_pick, "light choice", why, cap) ||
        put_n(g, l.slot_count ? l.slot_cdf : nullptr, (size_t)l.slot_count + 1, &slot_cdf, "light choice", why, cap))
        return -1;
    l.prims = const_cast<uint32_t *>(prims), l.insts = const_cast<uint32_t *>(insts);
    l.alias = const_cast<uint32_t *>(alias), l.light_of = const_cast<uint32_t *>(light_of);
    l.area = const_cast<float *>(area), l.pick = const_cast<float *>(pick);
    l.alias_prob = const_cast<float *>(alias_prob), l.slot_pick = const_cast<float *>(slot_pick);
    l.slot_cdf = const_cast<float *>(slot_cdf);
    const uint32_t *inst_first;
    if (put_n(g, l.count ? l.inst_first : nullptr, t->instance_count, &inst_first, "emitters of instances", why, cap))
        return -1;
    l.inst_first = const_cast<uint32_t *>(inst_first);
    if (l.environment) {
        rtk_environment env = *l.environment;
        const size_t w = (size_t)env.width, h = (size_t)env.height;
        const float *rgb, *func, *row_cdf, *col_cdf;
        const rtk_environment *denv;
        if (put_n(g, w ? env.rgb : nullptr, 3 * w * h, &rgb, "environment", why, cap) ||
            put_n(g, w ? env.func : nullptr, w * h, &func, "environment", why, cap) ||
            put_n(g, w ? env.row_cdf : nullptr, h + 1, &row_cdf, "environment", why, cap) ||
            put_n(g, w ? env.col_cdf : nullptr, h * (w + 1), &col_cdf, "environment", why, cap))
            return -1;
        env.rgb = const_cast<float *>(rgb), env.func = const_cast<float *>(func);
        env.row_cdf = const_cast<float *>(row_cdf), env.col_cdf = const_cast<float *>(col_cdf);
        if (put_n(g, &env, 1, &denv, "environment", why, cap))
            return -1;
        l.environment = const_cast<rtk_environment *>(denv);
    }
    return put_n(g, &l, 1, out, "lights", why, cap) ||
           put_n(g, t->punctual, t->punctual_count, punctual, "punctual lights", why, cap);
}

/* The MIP levels of a texture on the device (n of them, at level), each
 * level's texels a block of its own: *out their table there, *base level
 * 0's texels there. */
static int put_levels(rtk_gpu *g, const rtk_texture_level *level, int n, const rtk_texture_level **out,
                      const float **base, char *why, size_t cap)
{
    rtk_texture_level *d = static_cast<rtk_texture_level *>(std::malloc(sizeof *d * (size_t)n));
    if (!d) {
        std::snprintf(why, cap, "out of memory");
        return -1;
    }
    int st = 0;
    for (int k = 0; k < n && !st; k++) {
        const float *texels = nullptr;
        d[k] = level[k];
        st = put_n(g, static_cast<const float *>(level[k].rgba), 4 * (size_t)level[k].width * (size_t)level[k].height,
                   &texels, "MIP level", why, cap);
        d[k].rgba = const_cast<float *>(texels);
    }
    *base = d[0].rgba;
    st = st || put_n(g, static_cast<const rtk_texture_level *>(d), (size_t)n, out, "MIP levels", why, cap);
    std::free(d);
    return st;
}

/* The textures of tree t on the device, their texels each a block of
 * its own (a trilinear one's level 0 is its first MIP level): *out NULL
 * when t reads none, *levels NULL when none has MIP levels. */
static int put_textures(rtk_gpu *g, const rtk_device_tree *t, const rtk_device_texture **out,
                        const rtk_texture_level *const **levels, char *why, size_t cap)
{
    *out = nullptr;
    *levels = nullptr;
    if (!t->textures || !t->texture_count)
        return 0;
    const size_t n = t->texture_count;
    rtk_device_texture *d = static_cast<rtk_device_texture *>(std::malloc(sizeof *d * n));
    const rtk_texture_level **mips = static_cast<const rtk_texture_level **>(std::calloc(n, sizeof *mips));
    if (!d || !mips) {
        std::free(d), std::free(mips);
        std::snprintf(why, cap, "out of memory");
        return -1;
    }
    int st = 0, any = 0;
    for (size_t i = 0; i < n && !st; i++) {
        d[i] = t->textures[i];
        const rtk_texture_level *mip = t->texture_levels ? t->texture_levels[i] : nullptr;
        if (mip && d[i].rgba && d[i].levels >= 2) {
            st = put_levels(g, mip, d[i].levels, &mips[i], &d[i].rgba, why, cap);
            any = 1;
        } else {
            d[i].levels = 0;
            const size_t texels = d[i].rgba ? 4 * (size_t)d[i].width * (size_t)d[i].height : 0;
            st = put_n(g, d[i].rgba, texels, &d[i].rgba, "texture", why, cap);
        }
    }
    st = st || put_n(g, static_cast<const rtk_device_texture *>(d), n, out, "textures", why, cap) ||
         (any && put_n(g, static_cast<const rtk_texture_level *const *>(mips), n, levels, "texture levels", why, cap));
    std::free(d), std::free(mips);
    return st;
}

/* What programs read of tree t, whose corners are on the device at
 * corners: each triangle's slot, normals, materials, vertex colours,
 * emitters, texture coordinates and textures, on the device. */
static int put_program_mesh(rtk_gpu *g, const rtk_device_tree *t, const float *corners, rtk_program_mesh *out,
                            char *why, size_t cap)
{
    *out = rtk_program_mesh();
    const size_t n = t->slot_count;
    if (!n)
        return 0;
    uint32_t *slot_of = static_cast<uint32_t *>(std::malloc(sizeof *slot_of * n));
    if (!slot_of) {
        std::snprintf(why, cap, "out of memory");
        return -1;
    }
    rtk_program_slots(t, slot_of);
    rtk_program_mesh m = rtk_program_mesh_of(t, corners, nullptr);
    const int st = put_n(g, slot_of, n, &m.slot_of, "triangle slots", why, cap) ||
                   put_n(g, t->normals, 9 * n, &m.normals, "normals", why, cap) ||
                   put_n(g, t->tri_materials, n, &m.tri_materials, "triangle materials", why, cap) ||
                   put_n(g, t->materials, t->material_count, &m.materials, "materials", why, cap) ||
                   put_n(g, t->colors, 12 * n, &m.colors, "vertex colours", why, cap) ||
                   put_n(g, m.light_of, n, &m.light_of, "emitters of triangles", why, cap) ||
                   put_n(g, m.uvs, 6 * n, &m.uvs, "texture coordinates", why, cap) ||
                   put_n(g, m.uvs1, 6 * n, &m.uvs1, "texture coordinates", why, cap) ||
                   put_textures(g, t, &m.textures, &m.levels, why, cap);
    std::free(slot_of);
    if (!st)
        *out = m;
    return st;
}

static void free_trees(rtk_gpu *g)
{
    for (size_t i = 0; i < g->block_count; i++)
        cudaFree(g->blocks[i]);
    std::free(g->blocks);
    g->blocks = nullptr;
    g->block_count = g->block_cap = 0;
    g->tree_bytes = 0;
    g->scene = rtk_flat_scene();
    g->program_scene = rtk_program_scene();
}

int rtk_gpu_upload(rtk_gpu *g, const rtk_device_tree *tree, double *seconds, char *why, size_t cap)
{
    cudaEvent_t start, stop;
    if (cuda_failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) ||
        cuda_failed(cudaEventCreate(&start), "cudaEventCreate", why, cap))
        return -1;
    if (cuda_failed(cudaEventCreate(&stop), "cudaEventCreate", why, cap)) {
        cudaEventDestroy(start);
        return -1;
    }
    rtk_flat_scene scene = rtk_flat_scene();
    rtk_flat_tree *meshes = nullptr;
    int st = cuda_failed(cudaEventRecord(start), "cudaEventRecord", why, cap) || put_tree(g, tree, &scene.own, why, cap);
    if (!st && tree->mesh_count) {
        meshes = static_cast<rtk_flat_tree *>(std::calloc(tree->mesh_count, sizeof *meshes));
        if (!meshes)
            st = -1, std::snprintf(why, cap, "out of memory");
        for (uint32_t i = 0; i < tree->mesh_count && !st; i++)
            st = put_tree(g, &tree->meshes[i], &meshes[i], why, cap);
    }
    const void *mesh_table = nullptr, *tlas = nullptr, *order = nullptr, *instances = nullptr;
    if (!st)
        st = put(g, meshes, sizeof *meshes * (size_t)tree->mesh_count, &mesh_table, "mesh table", why, cap) ||
             put(g, tree->tlas_nodes, sizeof(rtk_bvh_node) * (size_t)tree->tlas_node_count, &tlas, "top level", why,
                 cap) ||
             put(g, tree->tlas_order, sizeof(uint32_t) * (size_t)tree->instance_count, &order, "top-level order", why,
                 cap) ||
             put(g, tree->instances, sizeof(rtk_device_instance) * (size_t)tree->instance_count, &instances,
                 "instances", why, cap);
    /* What device programs read: every tree's triangles, the frames, the lights. */
    rtk_program_scene ps = rtk_program_scene();
    rtk_program_mesh *program_meshes = nullptr;
    if (!st && tree->mesh_count &&
        !(program_meshes = static_cast<rtk_program_mesh *>(std::calloc(tree->mesh_count, sizeof *program_meshes))))
        st = -1, std::snprintf(why, cap, "out of memory");
    if (!st)
        st = put_program_mesh(g, tree, scene.own.corners, &ps.own, why, cap);
    for (uint32_t i = 0; i < tree->mesh_count && !st; i++)
        st = put_program_mesh(g, &tree->meshes[i], meshes[i].corners, &program_meshes[i], why, cap);
    if (!st)
        st = put_n(g, program_meshes, tree->mesh_count, &ps.meshes, "mesh table for programs", why, cap) ||
             put_n(g, tree->frames, tree->frames ? tree->instance_count : 0, &ps.frames, "instance frames", why,
                   cap) ||
             put_lights(g, tree, &ps.lights, &ps.punctual, why, cap);
    std::free(program_meshes);
    std::free(meshes);
    if (!st)
        st = cuda_failed(cudaEventRecord(stop), "cudaEventRecord", why, cap) ||
             cuda_failed(cudaEventSynchronize(stop), "cudaEventSynchronize", why, cap);
    float ms = 0.0f;
    if (!st)
        st = cuda_failed(cudaEventElapsedTime(&ms, start, stop), "cudaEventElapsedTime", why, cap) ? -1 : 0;
    cudaEventDestroy(start);
    cudaEventDestroy(stop);
    if (st) {
        free_trees(g);
        return -1;
    }
    scene.meshes = static_cast<const rtk_flat_tree *>(mesh_table);
    scene.top.own = tree->node_count > 0;
    scene.top.tlas = static_cast<const rtk_bvh_node *>(tlas);
    scene.top.tlas_node_count = tree->tlas_node_count;
    scene.top.order = static_cast<const uint32_t *>(order);
    scene.top.instances = static_cast<const rtk_device_instance *>(instances);
    g->scene = scene;
    ps.flat = scene;
    ps.punctual_count = tree->punctual_count;
    g->program_scene = ps;
    *seconds = 1e-3 * (double)ms;
    return 0;
}

uint64_t rtk_gpu_bytes(const rtk_gpu *g)
{
    return g->tree_bytes + g->lane_bytes;
}

void rtk_gpu_close(rtk_gpu *g)
{
    if (!g)
        return;
    cudaSetDevice(g->ordinal);
    free_trees(g);
    delete g;
}

/* The lane's last upload, run and download (its four events), in seconds. */
static int lane_seconds(const rtk_gpu_lane *l, double seconds[3], char *why, size_t cap)
{
    for (int k = 0; k < 3; k++) {
        float ms = 0.0f;
        if (cuda_failed(cudaEventElapsedTime(&ms, l->marks[k], l->marks[k + 1]), "cudaEventElapsedTime", why, cap))
            return -1;
        seconds[k] = 1e-3 * (double)ms;
    }
    return 0;
}

/* Bytes of device memory (and as many of pinned host memory) a lane of
 * capacity rays holds. */
static uint64_t lane_bytes(uint32_t capacity)
{
    return (uint64_t)capacity * (sizeof(rtk_ray) + sizeof(rtk_hit) + 1);
}

/* The same for a lane's program buffers. */
static uint64_t program_bytes(uint32_t capacity)
{
    return (uint64_t)capacity * (sizeof(rtk_sample_pos) + sizeof(rtk_li_result) + sizeof(rtk_program_count));
}

/* Device memory a lane's wavefront buffers take. */
static uint64_t wavefront_bytes(uint32_t capacity)
{
    return (uint64_t)capacity * (sizeof(rtk_path_walk) + 3 * sizeof(uint32_t)) + 2 * sizeof(uint32_t);
}

void rtk_gpu_lane_close(rtk_gpu *g, rtk_gpu_lane *l)
{
    if (!l)
        return;
    cudaSetDevice(g->ordinal);
    if (l->stream)
        cudaStreamDestroy(l->stream);
    for (cudaEvent_t e : l->marks)
        if (e)
            cudaEventDestroy(e);
    cudaFree(l->rays), cudaFree(l->hits), cudaFree(l->occluded);
    cudaFreeHost(l->host_rays), cudaFreeHost(l->host_hits), cudaFreeHost(l->host_occluded);
    cudaFree(l->pos), cudaFree(l->out), cudaFree(l->counts);
    cudaFreeHost(l->host_pos), cudaFreeHost(l->host_out), cudaFreeHost(l->host_counts);
    cudaFree(l->walks), cudaFree(l->queue[0]), cudaFree(l->queue[1]), cudaFree(l->shadows), cudaFree(l->lengths);
    cudaFreeHost(l->host_length);
    cudaFree(l->diffs), cudaFreeHost(l->host_diffs);
    if (l->capacity)
        g->lane_bytes -= lane_bytes(l->capacity);
    if (l->counts)
        g->lane_bytes -= program_bytes(l->capacity);
    if (l->host_length)
        g->lane_bytes -= wavefront_bytes(l->capacity);
    if (l->host_diffs)
        g->lane_bytes -= sizeof(rtk_ray_differential) * (uint64_t)l->capacity;
    delete l;
}

int rtk_gpu_lane_open(rtk_gpu *g, uint32_t capacity, rtk_gpu_lane **out, char *why, size_t cap)
{
    rtk_gpu_lane *l = new (std::nothrow) rtk_gpu_lane();
    if (!l) {
        std::snprintf(why, cap, "out of memory");
        return -1;
    }
    int st = cuda_failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) ||
             cuda_failed(cudaStreamCreateWithFlags(&l->stream, cudaStreamNonBlocking), "cudaStreamCreate", why, cap);
    for (int k = 0; k < 4 && !st; k++)
        st = cuda_failed(cudaEventCreate(&l->marks[k]), "cudaEventCreate", why, cap);
    if (!st)
        st = cuda_failed(cudaMalloc(&l->rays, sizeof(rtk_ray) * (size_t)capacity), "cudaMalloc (rays)", why, cap) ||
             cuda_failed(cudaMalloc(&l->hits, sizeof(rtk_hit) * (size_t)capacity), "cudaMalloc (hits)", why, cap) ||
             cuda_failed(cudaMalloc(&l->occluded, capacity), "cudaMalloc (occlusion)", why, cap) ||
             cuda_failed(cudaMallocHost(&l->host_rays, sizeof(rtk_ray) * (size_t)capacity), "cudaMallocHost (rays)", why,
                    cap) ||
             cuda_failed(cudaMallocHost(&l->host_hits, sizeof(rtk_hit) * (size_t)capacity), "cudaMallocHost (hits)", why,
                    cap) ||
             cuda_failed(cudaMallocHost(&l->host_occluded, capacity), "cudaMallocHost (occlusion)", why, cap);
    if (st) {
        rtk_gpu_lane_close(g, l);
        return -1;
    }
    l->capacity = capacity;
    g->lane_bytes += lane_bytes(capacity);
    *out = l;
    return 0;
}

int rtk_gpu_trace(rtk_gpu *g, rtk_gpu_lane *l, const rtk_ray *rays, uint32_t count, rtk_hit *hits, uint8_t *occluded,
                  double seconds[3], char *why, size_t cap)
{
    if (count == 0)
        return 0;
    if (count > l->capacity) {
        std::snprintf(why, cap, "a batch of %u rays on a lane of %u", count, l->capacity);
        return -1;
    }
    std::memcpy(l->host_rays, rays, sizeof(rtk_ray) * (size_t)count);
    const unsigned blocks = (count + block_threads - 1) / block_threads;
    int st = cuda_failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) ||
             cuda_failed(cudaEventRecord(l->marks[0], l->stream), "cudaEventRecord", why, cap) ||
             cuda_failed(cudaMemcpyAsync(l->rays, l->host_rays, sizeof(rtk_ray) * (size_t)count, cudaMemcpyHostToDevice,
                                    l->stream),
                    "cudaMemcpyAsync (rays)", why, cap) ||
             cuda_failed(cudaEventRecord(l->marks[1], l->stream), "cudaEventRecord", why, cap);
    if (st)
        return -1;
    if (hits)
        closest_kernel<<<blocks, block_threads, 0, l->stream>>>(g->scene, l->rays, count, l->hits);
    else
        any_kernel<<<blocks, block_threads, 0, l->stream>>>(g->scene, l->rays, count, l->occluded);
    st = cuda_failed(cudaGetLastError(), hits ? "closest_kernel launch" : "any_kernel launch", why, cap) ||
         cuda_failed(cudaEventRecord(l->marks[2], l->stream), "cudaEventRecord", why, cap) ||
         cuda_failed(hits ? cudaMemcpyAsync(l->host_hits, l->hits, sizeof(rtk_hit) * (size_t)count, cudaMemcpyDeviceToHost,
                                       l->stream)
                     : cudaMemcpyAsync(l->host_occluded, l->occluded, count, cudaMemcpyDeviceToHost, l->stream),
                "cudaMemcpyAsync (results)", why, cap) ||
         cuda_failed(cudaEventRecord(l->marks[3], l->stream), "cudaEventRecord", why, cap) ||
         cuda_failed(cudaStreamSynchronize(l->stream), hits ? "closest_kernel" : "any_kernel", why, cap);
    if (st)
        return -1;
    if (lane_seconds(l, seconds, why, cap))
        return -1;
    if (hits)
        std::memcpy(hits, l->host_hits, sizeof(rtk_hit) * (size_t)count);
    else
        std::memcpy(occluded, l->host_occluded, count);
    return 0;
}

/* Frees lane l's program buffers, made or half-made, and forgets them. */
static void drop_program_buffers(rtk_gpu_lane *l)
{
    cudaFree(l->pos), cudaFree(l->out), cudaFree(l->counts);
    cudaFreeHost(l->host_pos), cudaFreeHost(l->host_out), cudaFreeHost(l->host_counts);
    l->pos = l->host_pos = nullptr;
    l->out = l->host_out = nullptr;
    l->counts = l->host_counts = nullptr;
}

/* Makes lane l's program buffers if it has none yet. */
static int program_buffers(rtk_gpu *g, rtk_gpu_lane *l, char *why, size_t cap)
{
    if (l->counts)
        return 0;
    const size_t n = l->capacity;
    int st = cuda_failed(cudaMalloc(&l->pos, sizeof(rtk_sample_pos) * n), "cudaMalloc (sample streams)", why, cap) ||
             cuda_failed(cudaMalloc(&l->out, sizeof(rtk_li_result) * n), "cudaMalloc (results)", why, cap) ||
             cuda_failed(cudaMallocHost(&l->host_pos, sizeof(rtk_sample_pos) * n), "cudaMallocHost (sample streams)", why,
                    cap) ||
             cuda_failed(cudaMallocHost(&l->host_out, sizeof(rtk_li_result) * n), "cudaMallocHost (results)", why, cap) ||
             cuda_failed(cudaMallocHost(&l->host_counts, sizeof(rtk_program_count) * n), "cudaMallocHost (ray counts)",
                    why, cap) ||
             cuda_failed(cudaMalloc(&l->counts, sizeof(rtk_program_count) * n), "cudaMalloc (ray counts)", why, cap);
    if (st) {
        drop_program_buffers(l); /* a later try starts afresh */
        return -1;
    }
    g->lane_bytes += program_bytes(l->capacity);
    return 0;
}

/* Makes lane l's buffers of camera differentials if it has none yet. */
static int diff_buffers(rtk_gpu *g, rtk_gpu_lane *l, char *why, size_t cap)
{
    if (l->host_diffs)
        return 0;
    const size_t bytes = sizeof(rtk_ray_differential) * (size_t)l->capacity;
    if (cuda_failed(cudaMalloc(&l->diffs, bytes), "cudaMalloc (camera differentials)", why, cap) ||
        cuda_failed(cudaMallocHost(&l->host_diffs, bytes), "cudaMallocHost (camera differentials)", why, cap)) {
        cudaFree(l->diffs), cudaFreeHost(l->host_diffs); /* a later try starts afresh */
        l->diffs = l->host_diffs = nullptr;
        return -1;
    }
    g->lane_bytes += bytes;
    return 0;
}

static int wavefront_buffers(rtk_gpu *g, rtk_gpu_lane *l, char *why, size_t cap)
{
    if (l->host_length)
        return 0;
    const size_t n = l->capacity;
    int st = cuda_failed(cudaMalloc(&l->walks, sizeof(rtk_path_walk) * n), "cudaMalloc (walks)", why, cap) ||
             cuda_failed(cudaMalloc(&l->queue[0], sizeof(uint32_t) * n), "cudaMalloc (queue)", why, cap) ||
             cuda_failed(cudaMalloc(&l->queue[1], sizeof(uint32_t) * n), "cudaMalloc (queue)", why, cap) ||
             cuda_failed(cudaMalloc(&l->shadows, sizeof(uint32_t) * n), "cudaMalloc (shadow queue)", why, cap) ||
             cuda_failed(cudaMalloc(&l->lengths, 2 * sizeof(uint32_t)), "cudaMalloc (queue lengths)", why, cap) ||
             cuda_failed(cudaMallocHost(&l->host_length, sizeof(uint32_t)), "cudaMallocHost (queue length)", why, cap);
    if (st) {
        cudaFree(l->walks), cudaFree(l->queue[0]), cudaFree(l->queue[1]), cudaFree(l->shadows), cudaFree(l->lengths);
        cudaFreeHost(l->host_length); /* a later try starts afresh */
        l->walks = nullptr;
        l->queue[0] = l->queue[1] = l->shadows = l->lengths = l->host_length = nullptr;
        return -1;
    }
    g->lane_bytes += wavefront_bytes(l->capacity);
    return 0;
}

/* Path's program over the count samples already on the lane (their
 * differentials at diffs, device memory, or NULL) as a wavefront: one
 * round of kernels a vertex, the next round's length read back after
 * each. */
static int run_wavefront(rtk_gpu *g, rtk_gpu_lane *l, const rtk_program *p, const rtk_program_scene &scene,
                         const rtk_sample_gen *gen, const rtk_ray_differential *diffs, uint32_t count, char *why,
                         size_t cap)
{
    if (wavefront_buffers(g, l, why, cap))
        return -1;
    const unsigned blocks = (count + block_threads - 1) / block_threads;
    walk_start_kernel<<<blocks, block_threads, 0, l->stream>>>(l->rays, l->pos, count, l->out, l->counts, l->walks,
                                                                l->queue[0]);
    if (cuda_failed(cudaGetLastError(), "walk_start_kernel launch", why, cap))
        return -1;
    uint32_t live = count;
    for (int round = 0; live > 0; round ^= 1) {
        const unsigned b = (live + block_threads - 1) / block_threads;
        if (cuda_failed(cudaMemsetAsync(l->lengths, 0, 2 * sizeof(uint32_t), l->stream), "cudaMemsetAsync", why, cap))
            return -1;
        walk_extend_kernel<<<b, block_threads, 0, l->stream>>>(*p, scene, *gen, diffs, l->queue[round], live, l->walks,
                                                                l->out, l->counts, l->queue[round ^ 1], l->shadows,
                                                                l->lengths);
        if (cuda_failed(cudaGetLastError(), "walk_extend_kernel launch", why, cap))
            return -1;
        walk_shadow_kernel<<<b, block_threads, 0, l->stream>>>(scene, l->shadows, l->lengths, l->walks, l->counts);
        if (cuda_failed(cudaGetLastError(), "walk_shadow_kernel launch", why, cap) ||
            cuda_failed(cudaMemcpyAsync(l->host_length, l->lengths, sizeof(uint32_t), cudaMemcpyDeviceToHost,
                                        l->stream),
                        "cudaMemcpyAsync (queue length)", why, cap) ||
            cuda_failed(cudaStreamSynchronize(l->stream), "walk kernels", why, cap))
            return -1;
        live = *l->host_length;
    }
    walk_finish_kernel<<<blocks, block_threads, 0, l->stream>>>(l->walks, count, l->out);
    return cuda_failed(cudaGetLastError(), "walk_finish_kernel launch", why, cap);
}

int rtk_gpu_shade(rtk_gpu *g, rtk_gpu_lane *l, const rtk_program *p, int wavefront, rtk_rgb albedo,
                  const rtk_sample_gen *gen, const rtk_ray *rays, const rtk_ray_differential *diffs,
                  const rtk_sample_pos *pos, uint32_t count, rtk_li_result *out, uint64_t counts[2],
                  double seconds[3], char *why, size_t cap)
{
    if (count == 0)
        return 0;
    if (count > l->capacity) {
        std::snprintf(why, cap, "a batch of %u samples on a lane of %u", count, l->capacity);
        return -1;
    }
    if (cuda_failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) || program_buffers(g, l, why, cap) ||
        (diffs && diff_buffers(g, l, why, cap)))
        return -1;
    std::memcpy(l->host_rays, rays, sizeof(rtk_ray) * (size_t)count);
    std::memcpy(l->host_pos, pos, sizeof(rtk_sample_pos) * (size_t)count);
    if (diffs)
        std::memcpy(l->host_diffs, diffs, sizeof(rtk_ray_differential) * (size_t)count);
    rtk_program_scene scene = g->program_scene;
    scene.albedo = albedo;
    const unsigned blocks = (count + block_threads - 1) / block_threads;
    int st = cuda_failed(cudaEventRecord(l->marks[0], l->stream), "cudaEventRecord", why, cap) ||
             cuda_failed(cudaMemcpyAsync(l->rays, l->host_rays, sizeof(rtk_ray) * (size_t)count, cudaMemcpyHostToDevice,
                                    l->stream),
                    "cudaMemcpyAsync (rays)", why, cap) ||
             cuda_failed(cudaMemcpyAsync(l->pos, l->host_pos, sizeof(rtk_sample_pos) * (size_t)count,
                                    cudaMemcpyHostToDevice, l->stream),
                    "cudaMemcpyAsync (sample streams)", why, cap) ||
             (diffs && cuda_failed(cudaMemcpyAsync(l->diffs, l->host_diffs, sizeof(rtk_ray_differential) * (size_t)count,
                                                   cudaMemcpyHostToDevice, l->stream),
                                   "cudaMemcpyAsync (camera differentials)", why, cap)) ||
             cuda_failed(cudaEventRecord(l->marks[1], l->stream), "cudaEventRecord", why, cap);
    if (st)
        return -1;
    const rtk_ray_differential *device_diffs = diffs ? l->diffs : nullptr;
    if (wavefront && p->kind == RTK_PROGRAM_PATH) {
        st = run_wavefront(g, l, p, scene, gen, device_diffs, count, why, cap);
    } else {
        program_kernel<<<blocks, block_threads, 0, l->stream>>>(*p, scene, *gen, l->rays, device_diffs, l->pos, count,
                                                                 l->out, l->counts);
        st = cuda_failed(cudaGetLastError(), "program_kernel launch", why, cap);
    }
    st = st || cuda_failed(cudaEventRecord(l->marks[2], l->stream), "cudaEventRecord", why, cap) ||
         cuda_failed(cudaMemcpyAsync(l->host_out, l->out, sizeof(rtk_li_result) * (size_t)count, cudaMemcpyDeviceToHost,
                                l->stream),
                "cudaMemcpyAsync (results)", why, cap) ||
         cuda_failed(cudaMemcpyAsync(l->host_counts, l->counts, sizeof(rtk_program_count) * (size_t)count,
                                cudaMemcpyDeviceToHost, l->stream),
                "cudaMemcpyAsync (ray counts)", why, cap) ||
         cuda_failed(cudaEventRecord(l->marks[3], l->stream), "cudaEventRecord", why, cap) ||
         cuda_failed(cudaStreamSynchronize(l->stream), "program_kernel", why, cap);
    if (st)
        return -1;
    if (lane_seconds(l, seconds, why, cap))
        return -1;
    std::memcpy(out, l->host_out, sizeof(rtk_li_result) * (size_t)count);
    for (uint32_t i = 0; i < count; i++)
        counts[0] += l->host_counts[i].traced, counts[1] += l->host_counts[i].invalid;
    return 0;
}
