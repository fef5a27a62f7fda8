/* The kernel's sample generators (kernel/render/sampler.c), deterministic and
 * without clocks:
 *  - independent draws exactly today's PCG32 streams;
 *  - stratified puts one sample in each stratum of every 1D draw (spp
 *    strata) and 2D draw (the nx x ny grid, and spp strata along x and y),
 *    square and non-square spp, and again in each later round of spp;
 *  - the first 2^m sobol samples of a pixel, and any aligned run of 2^m,
 *    fill every elementary interval of volume 2^-m (all 2^a x 2^b shapes,
 *    m <= 10) in each 2D draw, dimensions (0,1), (2,3) and (5,6), and every
 *    2^-m interval in a 1D draw; the unscrambled generator starts at 0;
 *  - no value reaches 1.0: the float conversions at their extreme inputs,
 *    and every generator over many pixels and seeds;
 *  - sample indices past 2^32 give other points than those below;
 *  - a render through rtk_render_film is bit-identical on 1 and 2
 *    threads with every generator;
 *  - the config accepts the three types and rtk_render warns once, naming
 *    the config, when sobol gets a spp that is not a power of two;
 *  - convergence on an integral with a closed form (see test_convergence);
 *  - rtk_sample_seek: after samples spent different numbers of draws (as
 *    paths ended by Russian roulette do), a seek to one dimension gives the
 *    same values as reaching it draw by draw, so stratified and sobol draws
 *    there keep their strata and nets; independent draws after a seek
 *    depend on the dimension only. */
#include "render/render.h"
#include "config/config.h"
#include "image/image.h"

#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int passed, failed;

static void check(int ok, const char *fmt, ...) RTK_PRINTF(2, 3);

static void check(int ok, const char *fmt, ...)
{
    printf("%s  ", ok ? "ok  " : "FAIL");
    va_list ap;
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    putchar('\n');
    ok ? passed++ : failed++;
}

static const char *const names[] = {"independent", "stratified", "sobol"};

static const uint64_t seeds[] = {0u, 7u, 0x8000000000000000ULL, UINT64_MAX};
static const uint64_t pixels[] = {0u, 1u, 12345u, (1ULL << 40) + 3u, UINT64_MAX};

/* One draw per sample of a fixed pattern: 2D, 2D, 1D, 2D (dimensions 0-1,
 * 2-3, 4, 5-6), the first 2D being the film position. */
#define DRAWS 4
static const int draw_is_2d[DRAWS] = {1, 1, 0, 1};

/* Values of draws for samples [first, first + count) of one pixel. xs and ys
 * hold count values per draw (ys unused for 1D draws). */
static void draw_run(rtk_sampler_type type, uint64_t seed, uint32_t spp, uint64_t pixel, uint64_t first,
                     uint32_t count, float *xs, float *ys)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    rtk_ctx_set_sampler(&ctx, type, seed, spp);
    for (uint32_t s = 0; s < count; s++) {
        rtk_ctx_start_sample(&ctx, pixel, first + s);
        for (int d = 0; d < DRAWS; d++) {
            if (draw_is_2d[d]) {
                rtk_vec2 p = rtk_sample_2d(&ctx);
                xs[(size_t)d * count + s] = p.x;
                ys[(size_t)d * count + s] = p.y;
            } else {
                xs[(size_t)d * count + s] = rtk_sample_1d(&ctx);
            }
        }
    }
}

/* 1 if v in [0, 1) falls in each of n equal strata exactly once. */
static int one_per_stratum(const float *v, uint32_t n, uint8_t *seen)
{
    memset(seen, 0, n);
    for (uint32_t i = 0; i < n; i++) {
        if (!(v[i] >= 0.0f && v[i] < 1.0f))
            return 0;
        uint64_t k = (uint64_t)floor((double)v[i] * n); /* exact: 24 x 20 bits */
        if (k >= n || seen[k]++)
            return 0;
    }
    return 1;
}

/* 1 if the n points fall in each nx x ny cell exactly once. */
static int one_per_cell(const float *x, const float *y, uint32_t n, uint32_t nx, uint32_t ny, uint8_t *seen)
{
    memset(seen, 0, n);
    for (uint32_t i = 0; i < n; i++) {
        if (!(x[i] >= 0.0f && x[i] < 1.0f && y[i] >= 0.0f && y[i] < 1.0f))
            return 0;
        uint64_t cx = (uint64_t)floor((double)x[i] * nx), cy = (uint64_t)floor((double)y[i] * ny);
        if (cx >= nx || cy >= ny || seen[cy * nx + cx]++)
            return 0;
    }
    return 1;
}

/* ---- independent ---- */

static uint64_t mix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

/* The streams as they were before samplers were selectable: a zeroed ctx
 * with seed set (as the integrator tests use it) and a configured one. */
static void test_independent_unchanged(void)
{
    int same = 1;
    for (size_t si = 0; si < 4; si++)
        for (size_t pi = 0; pi < 5; pi++)
            for (uint64_t s = 0; s < 40; s++) {
                uint64_t sample = s < 20 ? s : 0xfffffff0u + s;
                rtk_pcg32 rng;
                rtk_pcg32_seed(&rng, mix64(seeds[si] ^ mix64(sample)), pixels[pi]);
                rtk_ctx zeroed, configured;
                memset(&zeroed, 0, sizeof zeroed);
                zeroed.gen.seed = seeds[si];
                memset(&configured, 0, sizeof configured);
                rtk_ctx_set_sampler(&configured, RTK_SAMPLER_INDEPENDENT, seeds[si], 16);
                rtk_ctx_start_sample(&zeroed, pixels[pi], sample);
                rtk_ctx_start_sample(&configured, pixels[pi], sample);
                for (int d = 0; d < 6; d++) {
                    float want[2] = {rtk_pcg32_float(&rng), rtk_pcg32_float(&rng)};
                    rtk_vec2 a = rtk_sample_2d(&zeroed);
                    float b = rtk_sample_1d(&configured), c = rtk_sample_1d(&configured);
                    same &= a.x == want[0] && a.y == want[1] && b == want[0] && c == want[1];
                }
            }
    check(same, "independent: the same PCG32 stream per (seed, sample) selected by the pixel as before, "
                "zeroed ctx or configured");
}

/* ---- stratified ---- */

/* The grid the sampler documents: ny the largest divisor <= sqrt(n). */
static void grid_for(uint32_t n, uint32_t *nx, uint32_t *ny)
{
    *ny = 1;
    for (uint32_t d = 2; d * d <= n; d++)
        if (n % d == 0)
            *ny = d;
    *nx = n / *ny;
}

static void test_stratified(void)
{
    const uint32_t spps[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 16, 17, 24, 32, 64, 100, 256, 1000, 1024};
    float *xs = malloc(sizeof(float) * DRAWS * 1024), *ys = malloc(sizeof(float) * DRAWS * 1024);
    uint8_t *seen = malloc(1024);
    for (size_t n_i = 0; n_i < sizeof spps / sizeof spps[0]; n_i++) {
        uint32_t n = spps[n_i], nx, ny;
        grid_for(n, &nx, &ny);
        int cells = 1, rooks = 1, strata = 1;
        uint32_t runs = 0;
        for (size_t si = 0; si < 4; si++)
            for (size_t pi = 0; pi < 5; pi++) {
                /* rounds 0 and 1, and one starting past 2^32 */
                const uint64_t firsts[] = {0, n, ((1ULL << 32) / n + 1) * n};
                for (int f = 0; f < 3; f++) {
                    draw_run(RTK_SAMPLER_STRATIFIED, seeds[si], n, pixels[pi], firsts[f], n, xs, ys);
                    runs++;
                    for (int d = 0; d < DRAWS; d++) {
                        const float *x = xs + (size_t)d * n, *y = ys + (size_t)d * n;
                        if (draw_is_2d[d]) {
                            cells &= one_per_cell(x, y, n, nx, ny, seen);
                            rooks &= one_per_stratum(x, n, seen) && one_per_stratum(y, n, seen);
                        } else {
                            strata &= one_per_stratum(x, n, seen);
                        }
                    }
                }
            }
        check(cells && rooks && strata,
              "stratified spp %u (%ux%u grid): one sample per grid cell%s, per 1/%u along x and y%s, "
              "per 1/%u in 1D%s (%u runs x %d draws)",
              n, nx, ny, cells ? "" : " FAILS", n, rooks ? "" : " FAILS", n, strata ? "" : " FAILS", runs, DRAWS);
    }
    free(xs);
    free(ys);
    free(seen);
}

/* ---- sobol ---- */

/* 1 if the 2^m points fill every elementary interval 2^-a x 2^-(m-a). */
static int is_net(const float *x, const float *y, uint32_t m, uint8_t *seen)
{
    uint32_t n = 1u << m;
    for (uint32_t a = 0; a <= m; a++)
        if (!one_per_cell(x, y, n, 1u << a, 1u << (m - a), seen))
            return 0;
    return 1;
}

static void test_sobol_generator(void)
{
    const double dim0[8] = {0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875};
    const double dim1[8] = {0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875};
    int ok = 1;
    for (uint32_t i = 0; i < 8; i++)
        ok &= rtk_sobol_sample(i, 0) * 0x1p-32 == dim0[i] && rtk_sobol_sample(i, 1) * 0x1p-32 == dim1[i];
    check(ok, "sobol generator: the first 8 points of dimensions 0 and 1 in index (not Gray-code) order, from "
              "index 0 (the first point is not skipped)");
    uint8_t *seen = malloc(1u << 12);
    float *x = malloc(sizeof(float) << 12), *y = malloc(sizeof(float) << 12);
    ok = 1;
    for (uint32_t m = 0; m <= 12; m++)
        for (uint64_t block = 0; block < 3; block++) {
            uint64_t first = block == 2 ? (1ULL << 40) + (5ULL << m) : block << m;
            for (uint32_t i = 0; i < (1u << m); i++) {
                x[i] = rtk_sampler_float(rtk_sobol_sample(first + i, 0));
                y[i] = rtk_sampler_float(rtk_sobol_sample(first + i, 1));
            }
            ok &= is_net(x, y, m, seen);
        }
    check(ok, "sobol generator: aligned runs of 2^m indices (m <= 12, also past 2^40) are (0,m,2)-nets");
    /* Dimension 1 against its direction numbers: v_1 = 1/2, v_(k+1) = v_k ^ v_k / 2 at 64-bit precision. */
    ok = 1;
    uint64_t index = 0x9e3779b97f4a7c15ULL;
    for (int i = 0; i < 100000; i++) {
        index = index * 6364136223846793005ULL + 1442695040888963407ULL;
        uint64_t j = i < 64 ? 1ULL << i : index, v = 1ULL << 63, r = 0;
        for (uint64_t b = j; b; b >>= 1, v ^= v >> 1)
            r ^= b & 1u ? v : 0u;
        uint32_t r0 = 0;
        for (int b = 0; b < 32; b++)
            r0 |= (uint32_t)(j >> b & 1u) << (31 - b);
        ok &= rtk_sobol_sample(j, 1) == (uint32_t)(r >> 32) && rtk_sobol_sample(j, 0) == r0;
    }
    check(ok, "sobol generator: dimension 1 equals the direction-number recurrence for every single index bit "
              "and 10^5 random 64-bit indices; dimension 0 is the radical inverse of the low 32 bits");
    check(rtk_sobol_sample((1ULL << 32) + 5, 1) != rtk_sobol_sample(5, 1) &&
              rtk_sobol_sample((1ULL << 63) + 5, 1) != rtk_sobol_sample(5, 1),
          "sobol generator: index bits 32 and 63 change dimension 1");
    /* The scramble maps aligned blocks onto aligned blocks, for any seed. */
    ok = 1;
    for (size_t si = 0; si < 4; si++)
        for (uint32_t m = 1; m <= 16; m++) {
            uint64_t base = rtk_owen_scramble(0, seeds[si]) >> m;
            for (uint64_t i = 1; i < (1u << m) && ok; i += 1 + (i >> 4))
                ok &= rtk_owen_scramble(i, seeds[si]) >> m == base;
        }
    check(ok, "owen scramble: indices [0, 2^m) stay in one aligned block of 2^m");
    free(seen);
    free(x);
    free(y);
}

static void test_sobol_nets(void)
{
    const uint32_t max_m = 10, n_max = 1u << max_m;
    float *xs = malloc(sizeof(float) * DRAWS * n_max), *ys = malloc(sizeof(float) * DRAWS * n_max);
    uint8_t *seen = malloc(n_max);
    int nets[DRAWS];
    for (int d = 0; d < DRAWS; d++)
        nets[d] = 1;
    uint32_t runs = 0;
    for (uint32_t m = 0; m <= max_m; m++) {
        uint32_t n = 1u << m;
        for (size_t si = 0; si < 4; si++)
            for (size_t pi = 0; pi < 5; pi++) {
                /* the first 2^m, the next 2^m, and a run past 2^32 */
                const uint64_t firsts[] = {0, n, (1ULL << 32) + 3ULL * n};
                for (int f = 0; f < 3; f++) {
                    draw_run(RTK_SAMPLER_SOBOL, seeds[si], n, pixels[pi], firsts[f], n, xs, ys);
                    runs++;
                    for (int d = 0; d < DRAWS; d++) {
                        const float *x = xs + (size_t)d * n, *y = ys + (size_t)d * n;
                        nets[d] &= draw_is_2d[d] ? is_net(x, y, m, seen) : one_per_stratum(x, n, seen);
                    }
                }
            }
    }
    check(nets[0], "sobol: dimensions (0,1) (film position) of the first 2^m samples, m = 0..10, fill every "
                   "2^-a x 2^-(m-a) interval (%u runs: 4 seeds x 5 pixels x 3 aligned runs, incl. past 2^32)",
          runs);
    check(nets[1], "sobol: dimensions (2,3) likewise");
    check(nets[2], "sobol: dimension 4 (a 1D draw) has one sample per 2^-m");
    check(nets[3], "sobol: dimensions (5,6) likewise fill every elementary interval");
    free(xs);
    free(ys);
    free(seen);
}

/* ---- seeking to a dimension ---- */

/* The 2D draw at dimension 1 + 2 k after the camera's draw (li's dimension
 * 2 k) of samples [0, n) of one pixel: reached by seeking after a number of
 * other draws that differs per sample (junk = 1), or draw by draw. */
static void seek_run(rtk_sampler_type type, uint64_t seed, uint32_t n, uint64_t pixel, uint32_t k, int junk,
                     float *x, float *y)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    rtk_ctx_set_sampler(&ctx, type, seed, n);
    for (uint32_t s = 0; s < n; s++) {
        rtk_ctx_start_sample(&ctx, pixel, s);
        (void)rtk_sample_2d(&ctx); /* the camera's draw */
        ctx.pos.dim_base = ctx.pos.dim;    /* as the renderer records it before li */
        if (junk) {
            for (uint32_t j = 0; j < (s * 7u + 3u) % 11u; j++)
                (void)rtk_sample_1d(&ctx);
            rtk_sample_seek(&ctx, 2 * k);
        } else {
            for (uint32_t j = 0; j < k; j++)
                (void)rtk_sample_2d(&ctx);
        }
        rtk_vec2 p = rtk_sample_2d(&ctx);
        x[s] = p.x;
        y[s] = p.y;
    }
}

static void test_seek(void)
{
    const uint32_t n = 64;
    float xa[64], ya[64], xb[64], yb[64];
    uint8_t seen[64];
    int same[3] = {1, 1, 1}, strata = 1, nets = 1;
    for (int t = 0; t < 3; t++)
        for (size_t si = 0; si < 4; si++)
            for (size_t pi = 0; pi < 5; pi++)
                for (uint32_t k = 0; k < 6; k++) {
                    seek_run((rtk_sampler_type)t, seeds[si], n, pixels[pi], k, 1, xa, ya);
                    if (t == RTK_SAMPLER_INDEPENDENT) {
                        /* a second junk pattern: the values must not depend on it */
                        rtk_ctx ctx;
                        memset(&ctx, 0, sizeof ctx);
                        rtk_ctx_set_sampler(&ctx, RTK_SAMPLER_INDEPENDENT, seeds[si], n);
                        for (uint32_t s = 0; s < n; s++) {
                            rtk_ctx_start_sample(&ctx, pixels[pi], s);
                            (void)rtk_sample_2d(&ctx);
                            ctx.pos.dim_base = ctx.pos.dim;
                            for (uint32_t j = 0; j < s % 5u; j++)
                                (void)rtk_sample_2d(&ctx);
                            rtk_sample_seek(&ctx, 2 * k);
                            rtk_vec2 p = rtk_sample_2d(&ctx);
                            xb[s] = p.x, yb[s] = p.y;
                        }
                    } else {
                        seek_run((rtk_sampler_type)t, seeds[si], n, pixels[pi], k, 0, xb, yb);
                        if (t == RTK_SAMPLER_STRATIFIED)
                            strata &= one_per_cell(xa, ya, n, 8, 8, seen);
                        else
                            nets &= is_net(xa, ya, 6, seen);
                    }
                    same[t] &= memcmp(xa, xb, sizeof xa) == 0 && memcmp(ya, yb, sizeof ya) == 0;
                }
    check(same[1] && strata, "stratified: a 2D draw reached by rtk_sample_seek after 0-10 other draws per sample "
                             "equals the draw reached draw by draw, one sample per cell of 8x8 (64 spp, 6 "
                             "dimensions, 20 seed/pixel pairs)");
    check(same[2] && nets, "sobol: likewise, and its 64 samples are a (0,6,2)-net");
    check(same[0], "independent: draws after rtk_sample_seek do not depend on the draws before it");
}

/* ---- values below 1 ---- */

static void test_below_one(void)
{
    int ok = rtk_sampler_float(UINT32_MAX) == 0x1.fffffep-1f && rtk_sampler_float(0) == 0.0f;
    for (uint64_t b = 0xfff00000u; b <= UINT32_MAX; b++)
        ok &= rtk_sampler_float((uint32_t)b) < 1.0f;
    check(ok, "float of a 32-bit fraction: all-ones gives 0x1.fffffep-1, the top 2^20 inputs stay below 1");

    /* The last stratum with the largest jitter, for every n the config allows, and every stratum of
     * smaller n at both jitter ends. */
    int last = 1, inside = 1;
    for (uint32_t n = 1; n <= (1u << 20); n++) {
        float f = rtk_sampler_stratum(n - 1, n, UINT32_MAX);
        last &= f < 1.0f && (double)f * n >= n - 1.0;
    }
    for (uint32_t n = 1; n <= 2048; n++)
        for (uint32_t k = 0; k < n; k++)
            for (int e = 0; e < 2; e++) {
                float f = rtk_sampler_stratum(k, n, e ? UINT32_MAX : 0u);
                inside &= f < 1.0f && (double)f * n >= k && (double)f * n < k + 1.0;
            }
    uint32_t big = 1u << 20;
    for (uint32_t k = 0; k < big; k += 1 + (k & 7u))
        for (int e = 0; e < 2; e++) {
            float f = rtk_sampler_stratum(k, big, e ? UINT32_MAX : 0u);
            inside &= f < 1.0f && (double)f * big >= k && (double)f * big < k + 1.0;
        }
    check(last, "stratum value: the last stratum with jitter 2^32 - 1 stays below 1 for every n in [1, 2^20]");
    check(inside, "stratum value: both jitter ends stay inside their stratum for every stratum of n <= 2048 "
                  "and of n = 2^20");

    /* Every generator over many pixels, adversarial seeds and sample indices near the wrap points. */
    const uint64_t samples[] = {0, 1, 2, 3, UINT32_MAX, 1ULL << 32, UINT64_MAX - 1, UINT64_MAX};
    for (int t = 0; t < 3; t++) {
        float top = 0.0f;
        uint64_t draws = 0, at_max = 0;
        int below = 1;
        for (size_t si = 0; si < 4; si++)
            for (uint64_t px = 0; px < 40000; px++) {
                rtk_ctx ctx;
                memset(&ctx, 0, sizeof ctx);
                rtk_ctx_set_sampler(&ctx, (rtk_sampler_type)t, seeds[si], t == 1 ? 1 + (uint32_t)(px % 7) : 4);
                uint64_t pixel = px < 20000 ? px : UINT64_MAX - px;
                for (size_t s = 0; s < 8; s++) {
                    rtk_ctx_start_sample(&ctx, pixel, samples[s]);
                    for (int d = 0; d < 3; d++) {
                        rtk_vec2 p = rtk_sample_2d(&ctx);
                        float q = rtk_sample_1d(&ctx);
                        float v[3] = {p.x, p.y, q};
                        for (int c = 0; c < 3; c++) {
                            below &= v[c] >= 0.0f && v[c] < 1.0f;
                            top = v[c] > top ? v[c] : top;
                            at_max += v[c] == 0x1.fffffep-1f;
                        }
                        draws += 3;
                    }
                }
            }
        check(below, "%s: %llu values over 160000 (seed, pixel) pairs, 8 sample indices up to 2^64 - 1, all in "
                     "[0, 1) (largest %a, %llu equal to 0x1.fffffep-1)",
              names[t], (unsigned long long)draws, (double)top, (unsigned long long)at_max);
    }
}

/* ---- 64-bit sample indices ---- */

static void test_past_2_32(void)
{
    for (int t = 0; t < 3; t++) {
        uint32_t same = 0, pairs = 0;
        for (uint64_t pixel = 0; pixel < 256; pixel++)
            for (uint64_t k = 0; k < 16; k++) {
                const uint64_t high[] = {(1ULL << 32) + k, (1ULL << 33) + k, (1ULL << 63) + k};
                rtk_ctx ctx;
                memset(&ctx, 0, sizeof ctx);
                rtk_ctx_set_sampler(&ctx, (rtk_sampler_type)t, 11, 16);
                rtk_ctx_start_sample(&ctx, pixel, k);
                rtk_vec2 a = rtk_sample_2d(&ctx), a2 = rtk_sample_2d(&ctx);
                for (int h = 0; h < 3; h++) {
                    rtk_ctx_start_sample(&ctx, pixel, high[h]);
                    rtk_vec2 b = rtk_sample_2d(&ctx), b2 = rtk_sample_2d(&ctx);
                    same += (a.x == b.x && a.y == b.y) + (a2.x == b2.x && a2.y == b2.y);
                    pairs += 2;
                }
            }
        check(same == 0, "%s: samples 2^32 + k, 2^33 + k and 2^63 + k differ from sample k (%u of %u 2D points "
                         "equal; 256 pixels, k < 16, dimensions 0-1 and 2-3)",
              names[t], same, pairs);
    }
}

/* ---- threads ---- */

/* Radiance from three draws of the integrator, so the image shows them. */
static void draws_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state;
    rtk_vec2 a = rtk_sample_2d(ctx);
    float b = rtk_sample_1d(ctx);
    rtk_vec2 c = rtk_sample_2d(ctx);
    out->radiance = rtk_rgb_make(a.x * a.y + ray->dir.x, b, c.x - c.y * ray->dir.y);
}

static const rtk_integrator_fns draws_integrator = {.size = sizeof(rtk_integrator_fns), .li = draws_li};

static float box_radius(const void *state)
{
    (void)state;
    return 0.5f;
}

static float box_eval(const void *state, float dx, float dy)
{
    (void)state;
    return fabsf(dx) <= 0.5f && fabsf(dy) <= 0.5f ? 1.0f : 0.0f;
}

static const rtk_filter_fns box = {.size = sizeof(rtk_filter_fns), .radius = box_radius, .eval = box_eval};

static void test_threads(void)
{
    const uint32_t w = 37, h = 29; /* 3 x 2 tiles, the last ones partial */
    size_t bytes = sizeof(float) * RTK_FILM_CHANNELS * w * h;
    rtk_scene *scene = rtk_scene_new("draws", 0);
    rtk_camera_desc d = {rtk_vec3_make(0, 0, 1), rtk_vec3_make(0, 0, 0), rtk_vec3_make(0, 1, 0), 60.0f};
    rtk_camera cam;
    float *img[3][2];
    rtk_status st = scene ? rtk_camera_init(&cam, &d, w, h) : RTK_ERR_NOMEM;
    const uint32_t spps[] = {4, 6};
    for (size_t n = 0; n < 2; n++) {
        for (int t = 0; t < 3; t++) {
            for (int k = 0; k < 2; k++) {
                img[t][k] = calloc(1, bytes);
                rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
                job.scene = scene;
                job.camera = &cam;
                job.integrator = &draws_integrator;
                job.filter = &box;
                job.spp = spps[n];
                job.sampler = (rtk_sampler_type)t;
                job.seed = 5;
                job.threads = (uint32_t)k + 1;
                if (st == RTK_OK)
                    st = img[t][k] ? rtk_render_film(&job, img[t][k], NULL) : RTK_ERR_NOMEM;
            }
            check(st == RTK_OK && memcmp(img[t][0], img[t][1], bytes) == 0,
                  "%s: %ux%u at %u spp is bit-identical on 1 and 2 threads", names[t], w, h, spps[n]);
        }
        check(st == RTK_OK && memcmp(img[0][0], img[1][0], bytes) != 0 && memcmp(img[0][0], img[2][0], bytes) != 0 &&
                  memcmp(img[1][0], img[2][0], bytes) != 0,
              "the three generators give three different images at %u spp (the choice reaches the workers)",
              spps[n]);
        for (int t = 0; t < 3; t++)
            for (int k = 0; k < 2; k++)
                free(img[t][k]);
    }
    rtk_scene_free(scene);
}

/* ---- config and the sobol warning ---- */

static char tmpdir[256];

/* Writes text to tmpdir/name; returns the path (one of 4 static buffers). */
static const char *write_file(const char *name, const char *text)
{
    static char paths[4][512];
    static int next;
    char *p = paths[next++ % 4];
    snprintf(p, 512, "%s/%s", tmpdir, name);
    FILE *f = fopen(p, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
    return p;
}

/* Loads cfg_path with overrides and renders it with stderr captured in
 * tmpdir/stderr.txt; returns what was printed (static), or NULL on failure. */
static const char *render_capturing(rtk_registry *reg, const char *cfg_path, const char *const *set, size_t n,
                                    char *type, size_t type_size)
{
    static char text[8192];
    rtk_config_options opts = {.size = sizeof opts, .overrides = set, .override_count = n};
    rtk_config *cfg = NULL;
    if (rtk_config_load(cfg_path, reg, &opts, &cfg) != RTK_OK) {
        printf("      config: %s\n", rtk_error_message());
        return NULL;
    }
    snprintf(type, type_size, "%s", cfg->sampler_type);
    char log_path[512];
    snprintf(log_path, sizeof log_path, "%s/stderr.txt", tmpdir);
    fflush(stderr);
    int saved = dup(2), fd = open(log_path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (saved < 0 || fd < 0) {
        rtk_config_destroy(cfg);
        return NULL;
    }
    dup2(fd, 2);
    rtk_render_options ropts = {.size = sizeof ropts, .quiet = 1};
    rtk_render_report report = {.size = sizeof report};
    rtk_status st = rtk_render(cfg, &ropts, &report);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    close(fd);
    rtk_config_destroy(cfg);
    if (st != RTK_OK) {
        printf("      render: %s\n", rtk_error_message());
        return NULL;
    }
    FILE *f = fopen(log_path, "r");
    size_t got = f ? fread(text, 1, sizeof text - 1, f) : 0;
    text[got] = '\0';
    if (f)
        fclose(f);
    return text;
}

static int count_of(const char *text, const char *what)
{
    int n = 0;
    for (const char *p = text; (p = strstr(p, what)); p++)
        n++;
    return n;
}

static void test_config_warning(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/rtk-test-sampler-XXXXXX", base && base[0] ? base : "/tmp");
    rtk_registry *reg = NULL;
    if (!mkdtemp(tmpdir) || rtk_registry_create(&reg) != RTK_OK) {
        check(0, "temporary directory and plugin registry");
        return;
    }
    write_file("tri.obj", "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n");
    const char *cfg = write_file("s.cfg", "scene = \"tri.obj\";\n"
                                          "film = { width = 8; height = 8; spp = 6; output = \"s.png\"; };\n"
                                          "sampler = { type = \"sobol\"; seed = 3; };\n"
                                          "cache = \"off\";\n"
                                          "threads = 2;\n");
    char type[32] = "";
    const char *first = render_capturing(reg, cfg, NULL, 0, type, sizeof type);
    int once = first && count_of(first, "warning") == 1 && count_of(first, "not a power of two") == 1 &&
               strstr(first, cfg) != NULL && strstr(first, "film.spp = 6") != NULL;
    check(once && strcmp(type, "sobol") == 0, "sobol at spp 6: one warning naming the config and the spp (%.*s)",
          first ? (int)strcspn(first, "\n") : 13, first ? first : "render failed");
    const char *again = render_capturing(reg, cfg, NULL, 0, type, sizeof type);
    check(again && count_of(again, "not a power of two") == 0, "sobol at spp 6 again: no second warning");
    const char *const pow2[] = {"film.spp=8"};
    const char *quiet = render_capturing(reg, cfg, pow2, 1, type, sizeof type);
    check(quiet && count_of(quiet, "not a power of two") == 0, "sobol at spp 8: no warning");
    const char *const strat[] = {"sampler.type=stratified"};
    const char *st = render_capturing(reg, cfg, strat, 1, type, sizeof type);
    check(st && strcmp(type, "stratified") == 0 && count_of(st, "not a power of two") == 0,
          "sampler.type = stratified loads and renders, no warning");
    const char *const indep[] = {"sampler.type=independent"};
    const char *in = render_capturing(reg, cfg, indep, 1, type, sizeof type);
    check(in && strcmp(type, "independent") == 0, "sampler.type = independent loads and renders");
    const char *names_to_remove[] = {"tri.obj", "s.cfg", "s.png", "stderr.txt"};
    for (int i = 0; i < 4; i++) {
        char p[512];
        snprintf(p, sizeof p, "%s/%s", tmpdir, names_to_remove[i]);
        unlink(p);
    }
    rmdir(tmpdir);
    rtk_registry_destroy(reg);
}

/* ---- convergence ----
 *
 * An AO-like estimator with a closed form: the fraction of cosine-weighted
 * directions (u -> r = sqrt(u.x), phi = 2 pi u.y) inside a cone of
 * half-angle alpha around an axis tilted beta from the normal, with
 * alpha + beta < 90 degrees. n . w is linear in w and the integral of w
 * over a cap of half-angle alpha is axis * pi sin^2 alpha, so the fraction
 * is cos(beta) sin^2(alpha). The indicator's edge is a curve in u, so
 * scrambled nets converge as n^-3/4 and independent samples as n^-1/2.
 *
 * Each of K (seed, pixel) pairs draws the film position, then the
 * direction, at spp = 4 .. 1024; RMSE over the K pairs; slope by least
 * squares of ln RMSE on ln spp over the 9 points. The spread of the ln spp
 * values about their mean gives sum (x - mean)^2 = 60 ln(2)^2 = 28.8, so
 * the slope's standard error is sd(ln RMSE) / 5.37. ln RMSE from K
 * squared errors has sd about sqrt((kurtosis - 1) / (4K)): sqrt(1/(2K))
 * for normal errors, and up to 3x that for the heavier tails of a few
 * samples of an indicator. K = 1024 gives at most 0.066 / 5.37 = 0.012,
 * 8 standard errors inside the 0.1 margins. The seeds are fixed. */
#define CONV_K 1024

static double cone_estimate(rtk_sampler_type type, uint64_t seed, uint64_t pixel, uint32_t spp, double cos_alpha,
                            const double axis[3])
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    rtk_ctx_set_sampler(&ctx, type, seed, spp);
    uint32_t inside = 0;
    for (uint32_t s = 0; s < spp; s++) {
        rtk_ctx_start_sample(&ctx, pixel, s);
        (void)rtk_sample_2d(&ctx);
        rtk_vec2 u = rtk_sample_2d(&ctx);
        double r = sqrt((double)u.x), phi = 2.0 * M_PI * (double)u.y;
        double w[3] = {r * cos(phi), r * sin(phi), sqrt(1.0 - (double)u.x)};
        inside += w[0] * axis[0] + w[1] * axis[1] + w[2] * axis[2] >= cos_alpha;
    }
    return (double)inside / spp;
}

static double fit_slope(const double *x, const double *y, int n)
{
    double mx = 0, my = 0, sxy = 0, sxx = 0;
    for (int i = 0; i < n; i++)
        mx += x[i] / n, my += y[i] / n;
    for (int i = 0; i < n; i++)
        sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
    return sxy / sxx;
}

static void test_convergence(void)
{
    const double alpha = 25.0 * M_PI / 180.0, beta = 30.0 * M_PI / 180.0;
    const double axis[3] = {sin(beta), 0.0, cos(beta)};
    const double truth = cos(beta) * sin(alpha) * sin(alpha);
    double slope[3];
    for (int t = 0; t < 3; t++) {
        double lx[9], ly[9];
        char line[512];
        int used = 0;
        for (int i = 0; i < 9; i++) {
            uint32_t spp = 4u << i;
            double se = 0.0;
            for (uint64_t k = 0; k < CONV_K; k++) {
                double e = cone_estimate((rtk_sampler_type)t, 1000 + k, 77 * k, spp, cos(alpha), axis) - truth;
                se += e * e;
            }
            lx[i] = log((double)spp);
            ly[i] = 0.5 * log(se / CONV_K);
            used += snprintf(line + used, sizeof line - (size_t)used, " %u:%.3g", spp, exp(ly[i]));
        }
        slope[t] = fit_slope(lx, ly, 9);
        printf("      %s RMSE by spp:%s\n", names[t], line);
    }
    check(fabs(slope[0] + 0.5) <= 0.1, "independent: RMSE slope %.3f over spp 4..1024 (%d seeds), want -0.5 +/- 0.1",
          slope[0], CONV_K);
    check(slope[2] <= -0.65, "sobol: RMSE slope %.3f over spp 4..1024 (%d seeds), want <= -0.65", slope[2], CONV_K);
    check(slope[1] <= -0.65, "stratified: RMSE slope %.3f over spp 4..1024 (%d seeds), want <= -0.65", slope[1],
          CONV_K);
}

int main(void)
{
    test_independent_unchanged();
    test_stratified();
    test_sobol_generator();
    test_sobol_nets();
    test_below_one();
    test_past_2_32();
    test_seek();
    test_threads();
    test_config_warning();
    test_convergence();
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
