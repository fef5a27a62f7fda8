/* kernel/accel/device_tree.h's traversals (slab.h's, two_level.h's) compiled by nvcc
 * (--fmad=false, as the cuda plugin compiles them) over a tree the kernel
 * built with a builder plugin, the triangles in leaf order as a flat
 * array (the GPU's layout): their closest and any hits equal the kernel's
 * binary traversal (rtk_bvh_closest / rtk_bvh_any with RTK_SIMD_BINARY)
 * bit for bit; on a GPU, when one is present, the device code's equal the
 * host code's. Without a GPU the device code is compiled (for sm_90) but
 * not run, and the test says so.
 *
 *   test_traverse_cuda BUILDER.so SOURCE_ROOT */
#include "accel/accel.h"
#include "accel/bvh_wide.h"
#include "accel/device_tree.h"
#include "scene/scene.h"

#include <rtk/host.h>

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

struct trace_out {
    rtk_hit hit;
    int closest, any;
};

/* What the cuda plugin runs per ray (device_tree.h). */
RTK_HD void trace_flat(const rtk_flat_tree *f, const rtk_ray *ray, trace_out *o)
{
    rtk_flat_closest(f, ray, &o->hit);
    o->closest = o->hit.prim != RTK_INVALID_ID;
    o->any = rtk_flat_any(f, ray);
}

bool same(const trace_out &x, const trace_out &y)
{
    return x.closest == y.closest && x.any == y.any && x.hit.prim == y.hit.prim &&
           (!x.closest || (std::memcmp(&x.hit.t, &y.hit.t, sizeof x.hit.t) == 0 &&
                           std::memcmp(&x.hit.u, &y.hit.u, sizeof x.hit.u) == 0 &&
                           std::memcmp(&x.hit.v, &y.hit.v, sizeof x.hit.v) == 0));
}

void add_tri(rtk_scene *s, const double *a, const double *b, const double *c)
{
    uint32_t i0, i1, i2;
    rtk_scene_add_vertex(s, a[0], a[1], a[2], &i0);
    rtk_scene_add_vertex(s, b[0], b[1], b[2], &i1);
    rtk_scene_add_vertex(s, c[0], c[1], c[2], &i2);
    rtk_scene_add_triangle(s, i0, i1, i2, nullptr, nullptr, RTK_INVALID_ID);
}

/* The scene's box from its vertices, as a loader sets it. */
rtk_scene *with_bounds(rtk_scene *s)
{
    rtk_bounds b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    for (uint32_t v = 0; v < s->vertex_count; v++) {
        const float *p = s->positions + 3 * (size_t)v;
        b.lower = {std::fmin(b.lower.x, p[0]), std::fmin(b.lower.y, p[1]), std::fmin(b.lower.z, p[2])};
        b.upper = {std::fmax(b.upper.x, p[0]), std::fmax(b.upper.y, p[1]), std::fmax(b.upper.z, p[2])};
    }
    s->bounds = b;
    return s;
}

/* A closed sphere of 4,096 triangles centred at (off, off, off). */
rtk_scene *sphere(double off)
{
    rtk_scene *s = rtk_scene_new("sphere", 0);
    const int nu = 64, nv = 32;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double p[4][3];
            for (int k = 0; k < 4; k++) {
                int ii = i + (k == 1 || k == 2), jj = j + (k >= 2);
                double th = M_PI * jj / nv, ph = 2.0 * M_PI * (ii % nu) / nu;
                p[k][0] = off + std::sin(th) * std::cos(ph), p[k][1] = off + std::cos(th);
                p[k][2] = off + std::sin(th) * std::sin(ph);
            }
            add_tri(s, p[0], p[1], p[2]);
            add_tri(s, p[0], p[2], p[3]);
        }
    return with_bounds(s);
}

/* 3,000 random triangles in [-1, 1]^3, each within 0.1 of its centre. */
rtk_scene *soup(rng *g)
{
    rtk_scene *s = rtk_scene_new("soup", 0);
    for (int i = 0; i < 3000; i++) {
        double c[3] = {g->next(-1, 1), g->next(-1, 1), g->next(-1, 1)}, p[3][3];
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                p[k][a] = c[a] + g->next(-0.1f, 0.1f);
        add_tri(s, p[0], p[1], p[2]);
    }
    return with_bounds(s);
}

/* Rays from a sphere around the scene's box through points inside it;
 * every third from a point inside, every fifth ending halfway. */
std::vector<rtk_ray> make_rays(const rtk_scene *s, int n, rng *g)
{
    rtk_bounds b = s->bounds;
    float lo[3] = {b.lower.x, b.lower.y, b.lower.z}, hi[3] = {b.upper.x, b.upper.y, b.upper.z};
    float c[3], r = 0.0f;
    for (int a = 0; a < 3; a++) {
        c[a] = 0.5f * (lo[a] + hi[a]);
        r = std::fmax(r, hi[a] - lo[a]);
    }
    std::vector<rtk_ray> rays(n);
    for (int i = 0; i < n; i++) {
        float o[3], t[3];
        for (int a = 0; a < 3; a++) {
            t[a] = g->next(lo[a], hi[a]);
            o[a] = i % 3 == 0 ? g->next(lo[a], hi[a]) : c[a] + r * g->next(-1.5f, 1.5f);
        }
        rtk_ray *ray = &rays[i];
        ray->org = {o[0], o[1], o[2]};
        ray->dir = {t[0] - o[0], t[1] - o[1], t[2] - o[2]};
        ray->tmin = i % 7 == 0 ? 1e-3f : 0.0f;
        ray->tmax = i % 5 == 0 ? 0.5f : INFINITY;
    }
    return rays;
}

__global__ void trace_kernel(rtk_flat_tree f, const rtk_ray *rays, trace_out *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        trace_flat(&f, &rays[i], &out[i]);
}

/* The device code's answers for rays on tree f (host pointers); false
 * when CUDA fails. */
bool trace_on_gpu(const rtk_flat_tree &f, size_t nodes, size_t slots, const std::vector<rtk_ray> &rays,
                  std::vector<trace_out> &out)
{
    rtk_flat_tree d = {upload(f.nodes, nodes), upload(f.prim_ids, slots), upload(f.corners, 9 * slots)};
    rtk_ray *dr = upload(rays.data(), rays.size());
    trace_out *dout = nullptr;
    bool ok = d.nodes && d.prim_ids && d.corners && dr &&
              cudaMalloc(&dout, rays.size() * sizeof *dout) == cudaSuccess;
    if (ok) {
        int n = (int)rays.size();
        trace_kernel<<<(n + 127) / 128, 128>>>(d, dr, dout, n);
        ok = cudaGetLastError() == cudaSuccess &&
             cudaMemcpy(out.data(), dout, rays.size() * sizeof *dout, cudaMemcpyDeviceToHost) == cudaSuccess;
    }
    cudaFree(const_cast<rtk_bvh_node *>(d.nodes));
    cudaFree(const_cast<uint32_t *>(d.prim_ids));
    cudaFree(const_cast<float *>(d.corners));
    cudaFree(dr);
    cudaFree(dout);
    return ok;
}

void compare(rtk_scene *s, const char *name, const rtk_plugin *builder, bool gpu, rng *g)
{
    char what[512];
    rtk_params *params = rtk_params_defaults(builder);
    rtk_status st = rtk_bvh_build(s, builder, params, 1);
    rtk_params_destroy(params);
    std::snprintf(what, sizeof what, "%s: %s builds (%s)", name, builder->name,
                  st == RTK_OK ? "ok" : rtk_error_message());
    check(st == RTK_OK && s->node_count > 0, what);
    if (st != RTK_OK || s->node_count == 0)
        return;
    if (s->wide)
        s->wide->path = RTK_SIMD_BINARY; /* the kernel's rtk_bvh_closest / any take the binary tree */
    const size_t slots = s->triangle_count;
    std::vector<float> corners(9 * slots);
    for (size_t k = 0; k < slots; k++)
        rtk_slot_corners(s, (uint32_t)k, &corners[9 * k]);
    rtk_flat_tree f = {s->nodes, s->prim_ids, corners.data()};
    const int n = 20000;
    std::vector<rtk_ray> rays = make_rays(s, n, g);
    std::vector<trace_out> kernel(n), host(n), device(n);
    int bad = 0, hits = 0, occluded = 0;
    for (int i = 0; i < n; i++) {
        trace_out *k = &kernel[i];
        k->closest = rtk_bvh_closest(s, &rays[i], &k->hit);
        if (!k->closest)
            k->hit.prim = RTK_INVALID_ID;
        k->any = rtk_bvh_any(s, &rays[i]);
        trace_flat(&f, &rays[i], &host[i]);
        bad += !same(host[i], *k);
        hits += k->closest;
        occluded += k->any;
    }
    std::snprintf(what, sizeof what, "%s / %s: nvcc's host code = the kernel's binary traversal, bit for bit, "
                  "closest and any (%d rays, %d hits, %d occluded): %d differ", name, builder->name, n, hits,
                  occluded, bad);
    check(bad == 0 && hits > 0 && hits < n, what);
    if (!gpu)
        return;
    bool ran = trace_on_gpu(f, s->node_count, slots, rays, device);
    bad = 0;
    for (int i = 0; ran && i < n; i++)
        bad += !same(device[i], host[i]);
    std::snprintf(what, sizeof what, "%s / %s: the GPU's device code = the host code, bit for bit (%d rays): %s%d "
                  "differ", name, builder->name, n, ran ? "" : "CUDA failed; ", bad);
    check(ran && bad == 0, what);
}

/* A soup of 600 triangles placed 40 times (rotated, scaled unevenly, some
 * mirrored) beside 100 triangles of the scene's own. */
rtk_scene *instanced(rng *g)
{
    rtk_scene *s = rtk_scene_new("instanced", 0);
    uint32_t mi = 0;
    rtk_scene_add_mesh(s, "placed soup", &mi);
    for (int i = 0; i < 700; i++) {
        double c[3] = {g->next(-1, 1), g->next(-1, 1), g->next(-1, 1)}, p[3][3];
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                p[k][a] = c[a] + g->next(-0.2f, 0.2f);
        add_tri(i < 600 ? s->meshes[mi] : s, p[0], p[1], p[2]);
    }
    for (int i = 0; i < 40; i++) {
        double a = g->next(-3.1f, 3.1f), sc = g->next(0.3f, 2.0f), m[12] = {0};
        double c = std::cos(a), sn = std::sin(a);
        /* A turn about y, scaled per axis (x mirrored every fourth), then moved. */
        m[0] = c * sc * (i % 4 == 3 ? -1.0 : 1.0), m[2] = sn * sc, m[5] = sc * g->next(0.5f, 1.5f);
        m[8] = -sn * sc * (i % 4 == 3 ? -1.0 : 1.0), m[10] = c * sc;
        m[3] = g->next(-6, 6), m[7] = g->next(-6, 6), m[11] = g->next(-6, 6);
        rtk_scene_add_instance(s, mi, m, "test");
    }
    with_bounds(s);
    rtk_scene_finish(s);
    return s;
}

/* The instanced scene: device_tree.h's two-level traversal over flat
 * trees (as the cuda plugin runs it; on a GPU, `rtk conform cuda` checks
 * its device code) against the kernel's rtk_bvh_closest / rtk_bvh_any. */
void compare_instanced(rtk_scene *s, const rtk_plugin *builder, rng *g)
{
    char what[512];
    rtk_params *params = rtk_params_defaults(builder);
    rtk_status st = rtk_instances_build(s, builder, params, 1, nullptr, nullptr);
    rtk_params_destroy(params);
    std::snprintf(what, sizeof what, "instanced scene: %s builds both levels (%s)", builder->name,
                  st == RTK_OK ? "ok" : rtk_error_message());
    check(st == RTK_OK && s->tlas_node_count > 0, what);
    if (st != RTK_OK || s->tlas_node_count == 0)
        return;
    std::vector<std::vector<float>> corners(s->mesh_count + 1);
    std::vector<rtk_flat_tree> meshes(s->mesh_count);
    for (uint32_t m = 0; m <= s->mesh_count; m++) {
        const rtk_scene *t = m == 0 ? s : s->meshes[m - 1];
        corners[m].resize(9 * (size_t)t->triangle_count);
        for (uint32_t k = 0; k < t->triangle_count; k++)
            rtk_slot_corners(t, k, &corners[m][9 * (size_t)k]);
        if (m > 0)
            meshes[m - 1] = {t->nodes, t->prim_ids, corners[m].data()};
    }
    rtk_flat_scene f;
    f.own = {s->nodes, s->prim_ids, corners[0].data()};
    f.meshes = meshes.data();
    f.top = {s->node_count > 0, s->tlas_nodes, s->tlas_node_count, s->tlas_order, s->placements};
    const int n = 20000;
    std::vector<rtk_ray> rays = make_rays(s, n, g);
    int bad = 0, hits = 0, placed = 0, occluded = 0;
    for (int i = 0; i < n; i++) {
        trace_out k, h;
        k.closest = rtk_bvh_closest(s, &rays[i], &k.hit);
        if (!k.closest)
            k.hit.prim = k.hit.inst = RTK_INVALID_ID;
        k.any = rtk_bvh_any(s, &rays[i]);
        rtk_flat_scene_closest(&f, &rays[i], &h.hit);
        h.closest = h.hit.prim != RTK_INVALID_ID;
        h.any = rtk_flat_scene_any(&f, &rays[i]);
        bad += !same(h, k) || h.hit.inst != k.hit.inst;
        hits += k.closest;
        placed += k.closest && k.hit.inst != RTK_INVALID_ID;
        occluded += k.any;
    }
    std::snprintf(what, sizeof what, "instanced scene (600 triangles placed 40 times, 100 own) / %s: nvcc's host "
                  "code = the kernel's two-level traversal, bit for bit, closest (instance too) and any (%d rays, %d "
                  "hits, %d on instances, %d occluded): %d differ", builder->name, n, hits, placed, occluded, bad);
    check(bad == 0 && placed > 0 && placed < hits && hits < n, what);
}

} // namespace

int main(int argc, char **argv)
{
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s BUILDER.so SOURCE_ROOT\n", argv[0]);
        return 2;
    }
    rtk_log_set_level(RTK_LOG_WARN);
    const rtk_plugin *builder = nullptr;
    if (rtk_plugin_open(argv[1], RTK_KIND_ACCELERATOR, &builder) != RTK_OK) {
        std::printf("FAIL  %s: %s\n", argv[1], rtk_error_message());
        return 1;
    }
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x2545f4914f6cdd1dull};
    struct {
        const char *name;
        rtk_scene *s;
    } scenes[] = {{"closed sphere", sphere(0.0)}, {"closed sphere at (1e5, 1e5, 1e5)", sphere(1e5)},
                  {"3000 random triangles", soup(&g)}};
    for (auto &k : scenes) {
        compare(k.s, k.name, builder, gpu, &g);
        rtk_scene_free(k.s);
    }
    rtk_scene *placed = instanced(&g);
    compare_instanced(placed, builder, &g);
    rtk_scene_free(placed);
    std::string bunny = std::string(argv[2]) + "/../shared/data/meshes/bunny.obj";
    rtk_scene *s = nullptr;
    if (rtk_scene_load(bunny.c_str(), 0, &s) == RTK_OK) {
        compare(s, "bunny", builder, gpu, &g);
        rtk_scene_free(s);
    } else {
        std::printf("skip  bunny: %s is not there (../shared/data absent)\n", bunny.c_str());
    }
    return finish(gpu, e);
}
