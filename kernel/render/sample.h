/* The sample generators in plain C that nvcc compiles too (RTK_HD,
 * include/rtk/common.h): one source for the kernel's rtk_sample_1d/2d
 * and a GPU backend's, checked against each other by tests/cuda. sampler.c says
 * what each generator draws; here are the arithmetic and the state.
 *
 * A generator (rtk_sample_gen) is set once per render; a sample's
 * position in its stream (rtk_sample_pos) is started per pixel sample and
 * advanced by each draw. A value depends only on (generator, seed, spp,
 * pixel, sample index, dimension). */
#ifndef RTK_KERNEL_SAMPLE_H
#define RTK_KERNEL_SAMPLE_H

#include <rtk/math.h>

#include <math.h>
#include <stdint.h>

/* PCG32 state (O'Neill 2014). */
typedef struct rtk_pcg32 {
    uint64_t state, inc;
} rtk_pcg32;

/* Sample generators of a config's sampler.type. Zero is independent, so a
 * zeroed generator draws PCG32 numbers. */
typedef enum rtk_sampler_type {
    RTK_SAMPLER_INDEPENDENT = 0,
    RTK_SAMPLER_STRATIFIED = 1,
    RTK_SAMPLER_SOBOL = 2
} rtk_sampler_type;

/* A render's generator. */
typedef struct rtk_sample_gen {
    rtk_sampler_type type;
    uint64_t seed;
    uint32_t spp;            /* samples per pixel the strata are made for */
    uint32_t grid_x, grid_y; /* stratified 2D grid, grid_x * grid_y = spp */
} rtk_sample_gen;

/* The current sample's position in its stream. */
typedef struct rtk_sample_pos {
    rtk_pcg32 rng;         /* independent: the draws */
    uint64_t pixel, sample;
    uint64_t sample_hash;  /* of (seed, pixel, stratified pass) */
    uint32_t pass_sample;  /* stratified: sample index within its pass of spp */
    uint32_t dim;          /* dimensions drawn so far in this sample */
    uint32_t dim_base;     /* the first dimension li draws (after the camera's) */
} rtk_sample_pos;

RTK_HD static inline uint32_t rtk_pcg32_next(rtk_pcg32 *rng)
{
    uint64_t old = rng->state;
    rng->state = old * 6364136223846793005ULL + rng->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31u));
}

RTK_HD static inline void rtk_pcg32_seed(rtk_pcg32 *rng, uint64_t initstate, uint64_t initseq)
{
    rng->state = 0u;
    rng->inc = (initseq << 1u) | 1u;
    rtk_pcg32_next(rng);
    rng->state += initstate;
    rtk_pcg32_next(rng);
}

/* Uniform float in [0, 1) from the top 24 bits. */
RTK_HD static inline float rtk_pcg32_float(rtk_pcg32 *rng)
{
    return (float)(rtk_pcg32_next(rng) >> 8) * 0x1p-24f;
}

/* SplitMix64 finaliser: spreads (seed, sample) over the state space. */
RTK_HD static inline uint64_t rtk_mix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

/* x with its 64 bits in reverse order. */
RTK_HD static inline uint64_t rtk_reverse64(uint64_t x)
{
#if defined(__CUDA_ARCH__)
    return __brevll(x);
#else
    x = ((x >> 1) & 0x5555555555555555ULL) | ((x & 0x5555555555555555ULL) << 1);
    x = ((x >> 2) & 0x3333333333333333ULL) | ((x & 0x3333333333333333ULL) << 2);
    x = ((x >> 4) & 0x0f0f0f0f0f0f0f0fULL) | ((x & 0x0f0f0f0f0f0f0f0fULL) << 4);
    return __builtin_bswap64(x);
#endif
}

/* A bijection of 64-bit words whose bit k depends only on bits 0..k and
 * the seed (Laine and Karras 2011; Vegdahl's round order): adding and odd
 * multiplies carry upwards only, x ^= x * even mixes lower bits into
 * higher ones. */
RTK_HD static inline uint64_t rtk_lk_permute(uint64_t x, uint64_t seed)
{
    x ^= x * 0x3d20adea5b3f9e14ULL;
    x += seed;
    x *= (seed >> 32) | 1u;
    x ^= x * 0x05526c56e1d2a7b8ULL;
    x ^= x * 0x53a22864c8e4f3a6ULL;
    return x;
}

/* Nested uniform (Owen) scramble of a 64-bit fraction by hashing (Burley
 * 2020): bit k of the result depends on bits k..63 of x and the seed, so
 * every aligned block of 2^m values maps onto an aligned block. */
RTK_HD static inline uint64_t rtk_owen_scramble(uint64_t x, uint64_t seed)
{
    return rtk_reverse64(rtk_lk_permute(rtk_reverse64(x), seed));
}

/* The digits of a Sobol point, the first (most significant) in bit 0:
 * dimension 0 (van der Corput) is the index itself. Dimension 1
 * (polynomial x + 1, m_k = 2 m_(k-1) ^ m_(k-1), m_1 = 1) is the Pascal
 * matrix mod 2: digit i is the parity of the index bits j with C(j, i)
 * odd, i.e. (Lucas) with i a submask of j; a superset-sum transform over
 * the 6-bit bit positions gives all 64 digits at once, so index bits
 * 32..63 reach the first 32 digits too. */
RTK_HD static inline uint64_t rtk_sobol_digits(uint64_t index, uint32_t dim)
{
    if (dim == 0)
        return index;
    uint64_t w = index;
    w ^= (w >> 1) & 0x5555555555555555ULL;
    w ^= (w >> 2) & 0x3333333333333333ULL;
    w ^= (w >> 4) & 0x0f0f0f0f0f0f0f0fULL;
    w ^= (w >> 8) & 0x00ff00ff00ff00ffULL;
    w ^= (w >> 16) & 0x0000ffff0000ffffULL;
    return w ^ (w >> 32);
}

/* Unscrambled Sobol point index, dimension 0 (van der Corput) or 1, as a
 * 32-bit fraction; index bits past 31 reach dimension 1. */
RTK_HD static inline uint32_t rtk_sobol_sample(uint64_t index, uint32_t dim)
{
    return (uint32_t)(rtk_reverse64(rtk_sobol_digits(index, dim)) >> 32);
}

/* The first 32 digits of a Sobol point, Owen-scrambled: the scramble
 * works on digits in this order, so no reversal is needed before it. */
RTK_HD static inline uint32_t rtk_scrambled_sobol(uint64_t index, uint32_t dim, uint64_t seed)
{
    return (uint32_t)(rtk_reverse64(rtk_lk_permute(rtk_sobol_digits(index, dim), seed)) >> 32);
}

/* The float of a 32-bit fraction, truncated: at most 0x1.fffffep-1. */
RTK_HD static inline float rtk_sampler_float(uint32_t bits)
{
    return (float)(bits >> 8) * 0x1p-24f;
}

/* A float in [k/n, (k+1)/n) (for n <= 2^24, where each such range holds
 * floats), near (k + jitter 2^-32) / n, below 1. */
RTK_HD static inline float rtk_sampler_stratum(uint32_t k, uint32_t n, uint32_t jitter)
{
    double lo = (double)k, hi = (double)k + 1.0;
    float f = (float)((lo + (double)jitter * 0x1p-32) / (double)n);
    /* Rounding to float can leave the stratum by one float at either end;
     * step back in (the products are exact for n < 2^29). */
    if ((double)f * n >= hi)
        f = nextafterf(f, 0.0f);
    else if ((double)f * n < lo)
        f = nextafterf(f, 1.0f);
    return f < 0x1.fffffep-1f ? f : 0x1.fffffep-1f;
}

/* Element i of a permutation of [0, n) chosen by seed: a bijection of the
 * smallest power-of-two range holding n, repeated until it lands below n
 * (cycle walking, as Kensler 2013). */
RTK_HD static inline uint32_t rtk_strata_permute(uint32_t i, uint32_t n, uint64_t seed)
{
    if (n <= 1)
        return 0;
    uint32_t mask = n - 1;
    mask |= mask >> 1;
    mask |= mask >> 2;
    mask |= mask >> 4;
    mask |= mask >> 8;
    mask |= mask >> 16;
    uint32_t a = (uint32_t)seed, b = (uint32_t)(seed >> 32);
    do {
        i = ((i ^ a) * 0xe170893du) & mask;
        i ^= i >> 1;
        i = ((i + b) * (a | 1u)) & mask;
        i ^= i >> 3;
        i = ((i ^ (b >> 16)) * 0x9e501cc3u) & mask;
        i ^= i >> 2;
        i = (i * 0xc860a3dfu + (a >> 16)) & mask;
        i ^= i >> 5;
    } while (i >= n);
    return i;
}

/* Generator type with seed, for spp samples per pixel (0 taken as 1). */
RTK_HD static inline void rtk_sample_gen_init(rtk_sample_gen *g, rtk_sampler_type type, uint64_t seed, uint32_t spp)
{
    g->type = type;
    g->seed = seed;
    g->spp = spp ? spp : 1;
    uint32_t ny = 1;
    for (uint32_t d = 2; (uint64_t)d * d <= g->spp; d++)
        if (g->spp % d == 0)
            ny = d;
    g->grid_x = g->spp / ny;
    g->grid_y = ny;
}

/* Starts sample `sample` of pixel `pixel` at dimension 0. */
RTK_HD static inline void rtk_sample_start(const rtk_sample_gen *g, rtk_sample_pos *p, uint64_t pixel,
                                           uint64_t sample)
{
    p->pixel = pixel;
    p->sample = sample;
    p->dim = 0;
    p->dim_base = 0;
    if (g->type == RTK_SAMPLER_INDEPENDENT) {
        rtk_pcg32_seed(&p->rng, rtk_mix64(g->seed ^ rtk_mix64(sample)), pixel);
        return;
    }
    /* Stratified draws restart their strata every spp samples (a pass);
     * sobol's sequence runs on over all 2^64 indices. */
    uint64_t pass = g->type == RTK_SAMPLER_STRATIFIED ? sample / g->spp : 0;
    p->pass_sample = (uint32_t)(sample - pass * g->spp);
    p->sample_hash = rtk_mix64(g->seed ^ rtk_mix64(pixel ^ rtk_mix64(pass)));
}

/* Makes the next draw dimension dim_base + dim (rtk_sample_seek). */
RTK_HD static inline void rtk_sample_seek_pos(const rtk_sample_gen *g, rtk_sample_pos *p, uint32_t dim)
{
    p->dim = p->dim_base + dim;
    if (g->type == RTK_SAMPLER_INDEPENDENT)
        rtk_pcg32_seed(&p->rng, rtk_mix64(g->seed ^ rtk_mix64(p->sample) ^ rtk_mix64(0x5eedULL + p->dim)), p->pixel);
}

/* Seed of draw dim of the current sample. */
RTK_HD static inline uint64_t rtk_draw_seed(const rtk_sample_pos *p, uint32_t dim)
{
    return rtk_mix64(p->sample_hash ^ ((uint64_t)dim + 1) * 0xd1b54a32d192ed03ULL);
}

/* The next number in [0, 1) of the current sample. */
RTK_HD static inline float rtk_sample_next_1d(const rtk_sample_gen *g, rtk_sample_pos *p)
{
    uint32_t dim = p->dim++;
    if (g->type == RTK_SAMPLER_STRATIFIED) {
        uint64_t h = rtk_draw_seed(p, dim);
        uint32_t k = rtk_strata_permute(p->pass_sample, g->spp, h);
        return rtk_sampler_stratum(k, g->spp, (uint32_t)(rtk_mix64(h ^ p->sample) >> 32));
    }
    if (g->type == RTK_SAMPLER_SOBOL) {
        uint64_t h = rtk_draw_seed(p, dim);
        uint64_t index = rtk_owen_scramble(p->sample, h);
        return rtk_sampler_float(rtk_scrambled_sobol(index, 0, rtk_mix64(h ^ 0x1u)));
    }
    return rtk_pcg32_float(&p->rng);
}

/* The next point in [0, 1)^2 of the current sample. */
RTK_HD static inline rtk_vec2 rtk_sample_next_2d(const rtk_sample_gen *g, rtk_sample_pos *p)
{
    uint32_t dim = p->dim;
    p->dim += 2;
    rtk_vec2 v;
    if (g->type == RTK_SAMPLER_STRATIFIED) {
        uint32_t n = g->spp, nx = g->grid_x, ny = g->grid_y;
        uint64_t h = rtk_draw_seed(p, dim);
        uint32_t cell = rtk_strata_permute(p->pass_sample, n, h);
        uint32_t cx = cell % nx, cy = cell / nx;
        /* Correlated multi-jitter: every row shares one sub-column shuffle
         * and every column one sub-row shuffle, so x and y are also one
         * sample per 1/n stratum. */
        uint32_t sub_x = rtk_strata_permute(cy, ny, rtk_mix64(h ^ 0x1u));
        uint32_t sub_y = rtk_strata_permute(cx, nx, rtk_mix64(h ^ 0x2u));
        uint64_t jitter = rtk_mix64(h ^ p->sample);
        v.x = rtk_sampler_stratum(cx * ny + sub_x, n, (uint32_t)jitter);
        v.y = rtk_sampler_stratum(cy * nx + sub_y, n, (uint32_t)(jitter >> 32));
        return v;
    }
    if (g->type == RTK_SAMPLER_SOBOL) {
        uint64_t h = rtk_draw_seed(p, dim);
        uint64_t index = rtk_owen_scramble(p->sample, h);
        v.x = rtk_sampler_float(rtk_scrambled_sobol(index, 0, rtk_mix64(h ^ 0x1u)));
        v.y = rtk_sampler_float(rtk_scrambled_sobol(index, 1, rtk_mix64(h ^ 0x2u)));
        return v;
    }
    v.x = rtk_pcg32_float(&p->rng);
    v.y = rtk_pcg32_float(&p->rng);
    return v;
}

#endif
