/* The cuda plugin's GPU side: the tree in device memory (the kernel's
 * 32-byte binary nodes, leaf order, 36 bytes of corners a slot) and one
 * thread per ray running the kernel's own traversal (device_tree.h, which
 * tests/cuda checks against the kernel bit for bit). Built with
 * --fmad=false: CUDA would otherwise contract a * b + c, which the kernel
 * never does, and hits would differ in the last bit. */
#include "gpu.h"

#include "accel/device_tree.h"

#include <cuda_runtime.h>

#include <cstdio>
#include <cstring>
#include <new>

struct rtk_gpu {
    int ordinal;
    rtk_flat_tree tree; /* device pointers */
    uint64_t tree_bytes, lane_bytes;
};

struct rtk_gpu_lane {
    cudaStream_t stream;
    cudaEvent_t marks[4];
    uint32_t capacity;
    rtk_ray *rays, *host_rays;    /* device, pinned host */
    rtk_hit *hits, *host_hits;
    uint8_t *occluded, *host_occluded;
};

namespace {

/* 0 when call succeeded, else -1 with "what: CUDA's message" in why. */
int failed(cudaError_t err, const char *what, char *why, size_t cap)
{
    if (err == cudaSuccess)
        return 0;
    std::snprintf(why, cap, "%s: %s (%s)", what, cudaGetErrorString(err), cudaGetErrorName(err));
    return -1;
}

__global__ void closest_kernel(rtk_flat_tree tree, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count) {
        rtk_hit hit;
        rtk_flat_closest(&tree, &rays[i], &hit);
        hits[i] = hit;
    }
}

__global__ void any_kernel(rtk_flat_tree tree, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < count)
        occluded[i] = (uint8_t)rtk_flat_any(&tree, &rays[i]);
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
    if (failed(cudaSetDevice(ordinal), "cudaSetDevice", why, cap) ||
        failed(cudaGetDeviceProperties(&prop, ordinal), "cudaGetDeviceProperties", why, cap))
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

int rtk_gpu_upload(rtk_gpu *g, const rtk_device_tree *tree, double *seconds, char *why, size_t cap)
{
    const size_t node_bytes = sizeof(rtk_bvh_node) * (size_t)tree->node_count;
    const size_t id_bytes = sizeof(uint32_t) * (size_t)tree->slot_count;
    const size_t corner_bytes = sizeof(float) * 9 * (size_t)tree->slot_count;
    void *nodes = nullptr, *ids = nullptr, *corners = nullptr;
    cudaEvent_t start, stop;
    if (failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) ||
        failed(cudaEventCreate(&start), "cudaEventCreate", why, cap))
        return -1;
    if (failed(cudaEventCreate(&stop), "cudaEventCreate", why, cap)) {
        cudaEventDestroy(start);
        return -1;
    }
    int st = failed(cudaEventRecord(start), "cudaEventRecord", why, cap);
    if (!st)
        st = failed(cudaMalloc(&nodes, node_bytes), "cudaMalloc (the tree's nodes)", why, cap) ||
             failed(cudaMalloc(&ids, id_bytes), "cudaMalloc (the leaf order)", why, cap) ||
             failed(cudaMalloc(&corners, corner_bytes), "cudaMalloc (the triangles)", why, cap) ||
             failed(cudaMemcpy(nodes, tree->nodes, node_bytes, cudaMemcpyHostToDevice), "cudaMemcpy (nodes)", why,
                    cap) ||
             failed(cudaMemcpy(ids, tree->prim_ids, id_bytes, cudaMemcpyHostToDevice), "cudaMemcpy (leaf order)",
                    why, cap) ||
             failed(cudaMemcpy(corners, tree->corners, corner_bytes, cudaMemcpyHostToDevice),
                    "cudaMemcpy (triangles)", why, cap) ||
             failed(cudaEventRecord(stop), "cudaEventRecord", why, cap) ||
             failed(cudaEventSynchronize(stop), "cudaEventSynchronize", why, cap);
    float ms = 0.0f;
    if (!st)
        st = failed(cudaEventElapsedTime(&ms, start, stop), "cudaEventElapsedTime", why, cap) ? -1 : 0;
    cudaEventDestroy(start);
    cudaEventDestroy(stop);
    if (st) {
        cudaFree(nodes), cudaFree(ids), cudaFree(corners);
        return -1;
    }
    g->tree.nodes = static_cast<const rtk_bvh_node *>(nodes);
    g->tree.prim_ids = static_cast<const uint32_t *>(ids);
    g->tree.corners = static_cast<const float *>(corners);
    g->tree_bytes = node_bytes + id_bytes + corner_bytes;
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
    cudaFree(const_cast<rtk_bvh_node *>(g->tree.nodes));
    cudaFree(const_cast<uint32_t *>(g->tree.prim_ids));
    cudaFree(const_cast<float *>(g->tree.corners));
    delete g;
}

/* Bytes of device memory (and as many of pinned host memory) a lane of
 * capacity rays holds. */
static uint64_t lane_bytes(uint32_t capacity)
{
    return (uint64_t)capacity * (sizeof(rtk_ray) + sizeof(rtk_hit) + 1);
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
    if (l->capacity)
        g->lane_bytes -= lane_bytes(l->capacity);
    delete l;
}

int rtk_gpu_lane_open(rtk_gpu *g, uint32_t capacity, rtk_gpu_lane **out, char *why, size_t cap)
{
    rtk_gpu_lane *l = new (std::nothrow) rtk_gpu_lane();
    if (!l) {
        std::snprintf(why, cap, "out of memory");
        return -1;
    }
    int st = failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) ||
             failed(cudaStreamCreateWithFlags(&l->stream, cudaStreamNonBlocking), "cudaStreamCreate", why, cap);
    for (int k = 0; k < 4 && !st; k++)
        st = failed(cudaEventCreate(&l->marks[k]), "cudaEventCreate", why, cap);
    if (!st)
        st = failed(cudaMalloc(&l->rays, sizeof(rtk_ray) * (size_t)capacity), "cudaMalloc (rays)", why, cap) ||
             failed(cudaMalloc(&l->hits, sizeof(rtk_hit) * (size_t)capacity), "cudaMalloc (hits)", why, cap) ||
             failed(cudaMalloc(&l->occluded, capacity), "cudaMalloc (occlusion)", why, cap) ||
             failed(cudaMallocHost(&l->host_rays, sizeof(rtk_ray) * (size_t)capacity), "cudaMallocHost (rays)", why,
                    cap) ||
             failed(cudaMallocHost(&l->host_hits, sizeof(rtk_hit) * (size_t)capacity), "cudaMallocHost (hits)", why,
                    cap) ||
             failed(cudaMallocHost(&l->host_occluded, capacity), "cudaMallocHost (occlusion)", why, cap);
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
    int st = failed(cudaSetDevice(g->ordinal), "cudaSetDevice", why, cap) ||
             failed(cudaEventRecord(l->marks[0], l->stream), "cudaEventRecord", why, cap) ||
             failed(cudaMemcpyAsync(l->rays, l->host_rays, sizeof(rtk_ray) * (size_t)count, cudaMemcpyHostToDevice,
                                    l->stream),
                    "cudaMemcpyAsync (rays)", why, cap) ||
             failed(cudaEventRecord(l->marks[1], l->stream), "cudaEventRecord", why, cap);
    if (st)
        return -1;
    if (hits)
        closest_kernel<<<blocks, block_threads, 0, l->stream>>>(g->tree, l->rays, count, l->hits);
    else
        any_kernel<<<blocks, block_threads, 0, l->stream>>>(g->tree, l->rays, count, l->occluded);
    st = failed(cudaGetLastError(), hits ? "closest_kernel launch" : "any_kernel launch", why, cap) ||
         failed(cudaEventRecord(l->marks[2], l->stream), "cudaEventRecord", why, cap) ||
         failed(hits ? cudaMemcpyAsync(l->host_hits, l->hits, sizeof(rtk_hit) * (size_t)count, cudaMemcpyDeviceToHost,
                                       l->stream)
                     : cudaMemcpyAsync(l->host_occluded, l->occluded, count, cudaMemcpyDeviceToHost, l->stream),
                "cudaMemcpyAsync (results)", why, cap) ||
         failed(cudaEventRecord(l->marks[3], l->stream), "cudaEventRecord", why, cap) ||
         failed(cudaStreamSynchronize(l->stream), hits ? "closest_kernel" : "any_kernel", why, cap);
    if (st)
        return -1;
    for (int k = 0; k < 3; k++) {
        float ms = 0.0f;
        if (failed(cudaEventElapsedTime(&ms, l->marks[k], l->marks[k + 1]), "cudaEventElapsedTime", why, cap))
            return -1;
        seconds[k] = 1e-3 * (double)ms;
    }
    if (hits)
        std::memcpy(hits, l->host_hits, sizeof(rtk_hit) * (size_t)count);
    else
        std::memcpy(occluded, l->host_occluded, count);
    return 0;
}
