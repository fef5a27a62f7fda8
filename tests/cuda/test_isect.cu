/* kernel/accel/isect.h's ray/triangle test compiled by nvcc (--fmad=false,
 * as the CUDA backend compiles it): its host code equals the kernel's
 * rtk_intersect_triangle bit for bit on random rays, rays at shared edges
 * and vertices, grazing rays and rays far from the origin; on a GPU, when
 * one is present, its device code equals its host code. Without a GPU
 * the device code is compiled (for sm_90) but not run, and the test says
 * so. */
#include "accel/isect.h"

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cstdint>
#include <cstdio>
#include <cstring>

namespace {

struct tri_case {
    rtk_ray ray;
    rtk_vec3 a, b, c;
};

struct tri_out {
    int hit;
    float t, u, v;
};

rtk_vec3 vec(float x, float y, float z)
{
    rtk_vec3 v = {x, y, z};
    return v;
}

rtk_vec3 lerp3(rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, float u, float v)
{
    return vec(a.x + u * (b.x - a.x) + v * (c.x - a.x), a.y + u * (b.y - a.y) + v * (c.y - a.y),
               a.z + u * (b.z - a.z) + v * (c.z - a.z));
}

/* n cases of one kind: 0 random, 1 aimed at an edge or a vertex, 2
 * grazing, 3 the same as 0 moved 1e5 away. */
void make_cases(tri_case *cs, int n, int kind, rng *g)
{
    for (int i = 0; i < n; i++) {
        tri_case *k = &cs[i];
        const float off = kind == 3 ? 1e5f : 0.0f;
        k->a = vec(g->next(-1, 1) + off, g->next(-1, 1) + off, g->next(-1, 1) + off);
        k->b = vec(g->next(-1, 1) + off, g->next(-1, 1) + off, g->next(-1, 1) + off);
        k->c = vec(g->next(-1, 1) + off, g->next(-1, 1) + off, g->next(-1, 1) + off);
        float u = g->next(0, 1), v = g->next(0, 1);
        if (u + v > 1.0f)
            u = 1.0f - u, v = 1.0f - v;
        if (kind == 1) {
            const int pick = i % 4; /* on edge ab, edge ac, edge bc, or at a vertex */
            if (pick == 0)
                v = 0.0f;
            else if (pick == 1)
                u = 0.0f;
            else if (pick == 2)
                v = 1.0f - u;
            else
                u = 0.0f, v = 0.0f;
        }
        rtk_vec3 target = lerp3(k->a, k->b, k->c, u, v);
        rtk_vec3 org = vec(g->next(-3, 3) + off, g->next(-3, 3) + off, g->next(-3, 3) + off);
        if (kind == 2) { /* from a point near the triangle's plane */
            rtk_vec3 p = lerp3(k->a, k->b, k->c, g->next(-1, 2), g->next(-1, 2));
            org = vec(p.x + g->next(-1e-4f, 1e-4f), p.y + g->next(-1e-4f, 1e-4f), p.z + g->next(-1e-4f, 1e-4f));
        }
        k->ray.org = org;
        k->ray.dir = vec(target.x - org.x, target.y - org.y, target.z - org.z);
        k->ray.tmin = i % 3 == 0 ? 0.0f : 1e-3f;
        k->ray.tmax = i % 5 == 0 ? 0.5f : INFINITY;
    }
}

bool same(const tri_out &x, const tri_out &y)
{
    return x.hit == y.hit &&
           (!x.hit || (std::memcmp(&x.t, &y.t, sizeof x.t) == 0 && std::memcmp(&x.u, &y.u, sizeof x.u) == 0 &&
                       std::memcmp(&x.v, &y.v, sizeof x.v) == 0));
}

} // namespace

__global__ void isect_kernel(const tri_case *in, tri_out *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i >= n)
        return;
    tri_out o = {0, 0.0f, 0.0f, 0.0f};
    o.hit = rtk_isect_triangle(&in[i].ray, in[i].a, in[i].b, in[i].c, &o.t, &o.u, &o.v);
    out[i] = o;
}

int main()
{
    enum { N = 200000 };
    static const char *const kinds[4] = {"random rays", "rays at shared edges and vertices", "grazing rays",
                                         "rays 1e5 from the origin"};
    static tri_case cases[N];
    static tri_out host[N], kernel[N], device[N];
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x9e3779b97f4a7c15ull};
    for (int kind = 0; kind < 4; kind++) {
        make_cases(cases, N, kind, &g);
        int bad = 0, hits = 0;
        for (int i = 0; i < N; i++) {
            tri_case *k = &cases[i];
            host[i].hit = rtk_isect_triangle(&k->ray, k->a, k->b, k->c, &host[i].t, &host[i].u, &host[i].v);
            kernel[i].hit = rtk_intersect_triangle(&k->ray, k->a, k->b, k->c, &kernel[i].t, &kernel[i].u,
                                                   &kernel[i].v);
            bad += !same(host[i], kernel[i]);
            hits += host[i].hit;
        }
        char what[256];
        std::snprintf(what, sizeof what, "%s: nvcc's host code = the kernel's rtk_intersect_triangle, bit for bit "
                      "(%d rays, %d hits): %d differ", kinds[kind], N, hits, bad);
        check(bad == 0 && hits > 0, what);
        if (!gpu)
            continue;
        tri_case *din = nullptr;
        tri_out *dout = nullptr;
        bool ran = cudaMalloc(&din, sizeof cases) == cudaSuccess && cudaMalloc(&dout, sizeof device) == cudaSuccess &&
                   cudaMemcpy(din, cases, sizeof cases, cudaMemcpyHostToDevice) == cudaSuccess;
        if (ran) {
            isect_kernel<<<(N + 255) / 256, 256>>>(din, dout, N);
            ran = cudaGetLastError() == cudaSuccess &&
                  cudaMemcpy(device, dout, sizeof device, cudaMemcpyDeviceToHost) == cudaSuccess;
        }
        cudaFree(din);
        cudaFree(dout);
        bad = 0;
        for (int i = 0; ran && i < N; i++)
            bad += !same(device[i], host[i]);
        std::snprintf(what, sizeof what, "%s: the GPU's device code = the host code, bit for bit (%d rays): "
                      "%s%d differ",
                      kinds[kind], N, ran ? "" : "the kernel did not run; ", bad);
        check(ran && bad == 0, what);
    }
    return finish(gpu, e);
}
