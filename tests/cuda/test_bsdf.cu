/* kernel/scene/bsdf_lobes.h compiled by nvcc (as the CUDA backend
 * compiles it): for every lobe type with random parameters, one- to
 * three-lobe mixtures and random directions on both sides, eval, pdf,
 * flags and sample of nvcc's host code equal the kernel's rtk_bsdf_eval /
 * rtk_bsdf_pdf / rtk_bsdf_flags / rtk_bsdf_sample bit for bit. The
 * device code is compiled for sm_90 too; on a GPU it runs the same cases
 * and its results are compared with the host's as shading compares
 * (CUDA's sinf, powf, ... are not glibc's, so not bit for bit): the
 * same sample successes and flags, f and pdf within 1e-3 relative.
 * Without a GPU that part is skipped, saying so. */
#include "scene/bsdf_lobes.h"

#include "cuda_test.h"

#include <cuda_runtime.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

namespace {

struct bsdf_case {
    rtk_bsdf b;
    rtk_vec3 wo, wi;
    float u_lobe;
    rtk_vec2 u;
};

struct bsdf_out {
    rtk_rgb f;
    float pdf;
    unsigned flags;
    int sampled;
    rtk_bsdf_sample_out s;
};

RTK_HD void run_shared(const bsdf_case *c, bsdf_out *o)
{
    o->f = rtk_lobes_eval(&c->b, c->wo, c->wi);
    o->pdf = rtk_lobes_pdf(&c->b, c->wo, c->wi);
    o->flags = rtk_lobes_flags(&c->b);
    o->sampled = rtk_lobes_sample(&c->b, c->wo, c->u_lobe, c->u, &o->s);
}

void run_kernel(const bsdf_case *c, bsdf_out *o)
{
    o->f = rtk_bsdf_eval(&c->b, c->wo, c->wi);
    o->pdf = rtk_bsdf_pdf(&c->b, c->wo, c->wi);
    o->flags = rtk_bsdf_flags(&c->b);
    o->sampled = rtk_bsdf_sample(&c->b, c->wo, c->u_lobe, c->u, &o->s);
}

__global__ void bsdf_kernel(const bsdf_case *in, bsdf_out *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        run_shared(&in[i], &out[i]);
}

rtk_vec3 random_dir(rng *g)
{
    for (;;) {
        rtk_vec3 v = rtk_vec3_make(g->next(-1, 1), g->next(-1, 1), g->next(-1, 1));
        float l = rtk_vec3_length(v);
        if (l > 0.1f && l <= 1.0f)
            return rtk_vec3_scale(v, 1.0f / l);
    }
}

rtk_rgb random_rgb(rng *g)
{
    return rtk_rgb_make(g->next(0, 1), g->next(0, 1), g->next(0, 1));
}

/* Lobe type k (0..6) with random parameters. */
rtk_lobe random_lobe(int k, rng *g)
{
    float alpha = g->next(0, 1) < 0.1f ? 0.0f : g->next(0.001f, 1.0f), ior = g->next(1.0f, 2.5f);
    if (g->next(0, 1) < 0.3f)
        ior = 1.0f / ior;
    switch (k) {
    case 0:
        return rtk_lobe_lambert(random_rgb(g));
    case 1:
        return rtk_lobe_oren_nayar(random_rgb(g), g->next(0, 1));
    case 2:
        return rtk_lobe_ggx_schlick(random_rgb(g), alpha);
    case 3:
        return rtk_lobe_ggx_conductor(rtk_rgb_make(g->next(0.1f, 3), g->next(0.1f, 3), g->next(0.1f, 3)),
                                      rtk_rgb_make(g->next(0, 5), g->next(0, 5), g->next(0, 5)), alpha);
    case 4:
        return rtk_lobe_dielectric(ior, random_rgb(g));
    case 5:
        return rtk_lobe_rough_dielectric(ior, alpha, random_rgb(g));
    default:
        return rtk_lobe_plastic(random_rgb(g), rtk_rgb_make(g->next(0, 1), g->next(0, 1), g->next(0, 1)), alpha);
    }
}

bool bits_equal(const bsdf_out &a, const bsdf_out &b)
{
    if (std::memcmp(&a.f, &b.f, sizeof a.f) || std::memcmp(&a.pdf, &b.pdf, sizeof a.pdf) || a.flags != b.flags ||
        a.sampled != b.sampled)
        return false;
    return !a.sampled || std::memcmp(&a.s, &b.s, sizeof a.s) == 0;
}

/* |a - b| relative to the larger, 0 when equal. */
double rel_diff(float a, float b)
{
    if (a == b)
        return 0.0;
    double m = std::fmax(std::fabs((double)a), std::fabs((double)b));
    return std::isfinite(m) && m > 0.0 ? std::fabs((double)a - (double)b) / m : INFINITY;
}

} // namespace

int main()
{
    enum { N = 100000 };
    static const char *const names[7] = {"lambert", "oren-nayar", "ggx schlick", "ggx conductor", "dielectric",
                                         "rough dielectric", "plastic"};
    cudaError_t e;
    const bool gpu = gpu_present(&e);
    rng g = {0x853c49e6748fea9bull};
    for (int k = 0; k <= 7; k++) {
        std::vector<bsdf_case> cases(N);
        for (int i = 0; i < N; i++) {
            bsdf_case *c = &cases[i];
            if (k < 7) {
                c->b = rtk_bsdf_of(random_lobe(k, &g));
            } else { /* mixtures of 1-3 random lobes with random weights */
                c->b = rtk_bsdf_of(random_lobe(i % 7, &g));
                c->b.weight[0] = random_rgb(&g);
                for (int j = 1 + i % 3; j > 1; j--)
                    rtk_bsdf_add(&c->b, random_rgb(&g), random_lobe((int)g.next(0, 6.99f), &g));
            }
            c->wo = random_dir(&g);
            c->wi = random_dir(&g);
            c->u_lobe = g.next(0, 1);
            c->u.x = g.next(0, 1);
            c->u.y = g.next(0, 1);
        }
        std::vector<bsdf_out> host(N), kernel(N), device(N);
        int bad = 0, sampled = 0;
        for (int i = 0; i < N; i++) {
            std::memset(&host[i], 0, sizeof host[i]);
            std::memset(&kernel[i], 0, sizeof kernel[i]);
            run_shared(&cases[i], &host[i]);
            run_kernel(&cases[i], &kernel[i]);
            bad += !bits_equal(host[i], kernel[i]);
            sampled += host[i].sampled;
        }
        const char *name = k < 7 ? names[k] : "mixtures of 1-3 lobes";
        char what[256];
        std::snprintf(what, sizeof what, "%s: nvcc's host code = the kernel's rtk_bsdf_eval/pdf/flags/sample, bit for "
                      "bit (%d cases, %d sampled): %d differ", name, N, sampled, bad);
        check(bad == 0 && sampled > 0, what);
        if (!gpu)
            continue;
        bsdf_case *din = nullptr;
        bsdf_out *dout = nullptr;
        bool ran = cudaMalloc(&din, N * sizeof *din) == cudaSuccess &&
                   cudaMalloc(&dout, N * sizeof *dout) == cudaSuccess &&
                   cudaMemcpy(din, cases.data(), N * sizeof *din, cudaMemcpyHostToDevice) == cudaSuccess;
        if (ran) {
            bsdf_kernel<<<(N + 127) / 128, 128>>>(din, dout, N);
            ran = cudaGetLastError() == cudaSuccess &&
                  cudaMemcpy(device.data(), dout, N * sizeof *dout, cudaMemcpyDeviceToHost) == cudaSuccess;
        }
        cudaFree(din);
        cudaFree(dout);
        bad = 0;
        double worst = 0.0;
        for (int i = 0; ran && i < N; i++) {
            bad += device[i].flags != host[i].flags;
            const bsdf_out &d = device[i], &h = host[i];
            const float dv[4] = {d.f.r, d.f.g, d.f.b, d.pdf}, hv[4] = {h.f.r, h.f.g, h.f.b, h.pdf};
            for (int c = 0; c < 4; c++)
                worst = std::fmax(worst, rel_diff(dv[c], hv[c]));
        }
        std::snprintf(what, sizeof what, "%s: the GPU's lobe flags = the host's (%d cases): %s%d differ; largest "
                      "relative difference of f and pdf %.3g (printed, not judged)", name, N,
                      ran ? "" : "CUDA failed; ", bad, worst);
        check(ran && bad == 0, what);
    }
    return finish(gpu, e);
}
