/* The sample generators behind rtk_sample_1d/2d.
 *
 * Rules for callers: rtk_ctx_set_sampler picks a context's generator once;
 * rtk_ctx_start_sample(ctx, pixel, sample) starts a pixel sample and resets
 * the dimension counter; then each rtk_sample_2d takes the next two
 * dimensions and each rtk_sample_1d the next one (the renderer's first 2D
 * draw is the film position). A value depends only on (generator, seed,
 * spp, pixel, sample index, dimension), never on threads or tiles, and lies
 * in [0, 0x1.fffffep-1]. Sample indices are 64-bit and never wrap.
 * rtk_sample_seek sets the counter to li's first dimension (dim_base,
 * recorded by the renderer after the camera's draws) plus the one asked;
 * the independent generator, whose draws are a stream, restarts its
 * stream at a hash of the dimension there.
 *
 * independent  PCG32 (O'Neill 2014): one stream per (seed, sample index),
 *              selected by the pixel index; dimensions are consecutive draws.
 * stratified   Correlated multi-jittered strata (Kensler 2013) for each
 *              draw, padded: draw d of a pixel permutes its strata by a hash
 *              of (seed, pixel, d, pass), pass = sample / spp. A 1D draw
 *              puts sample s in stratum perm(s) of spp; a 2D draw puts it in
 *              cell perm(s) of an nx x ny grid, nx * ny = spp, ny the largest
 *              divisor of spp not above sqrt(spp) (8 -> 4 x 2, 7 -> 7 x 1),
 *              and inside the cell in the sub-column and sub-row that make x
 *              and y each one sample per 1/spp as well. Jitter is hashed.
 * sobol        Each draw is the Sobol (0,2)-sequence (van der Corput and
 *              x + 1 dimensions) at a shuffled index, Owen-scrambled by
 *              hashing (Burley 2020): draw d of a pixel shuffles the sample
 *              index with a nested uniform scramble seeded by hash(seed,
 *              pixel, d), which maps the first 2^m indices onto an aligned
 *              block of 2^m, and scrambles each output dimension with its
 *              own seed. So the first 2^m samples of every 2D draw are a
 *              (0,m,2)-net and of every 1D draw a (0,m,1)-net, and the draws
 *              are decorrelated by their independent shuffles (Burley's
 *              padding). Higher Sobol dimensions are not used: no Sobol
 *              pair beyond (0, 1) is a (0,2)-sequence (Joe-Kuo dimensions 2
 *              and 3 have t = 2 at 8 points), so there is no dimension limit
 *              and no fallback. */
#include "render.h"

#include <math.h>
#include <string.h>

void rtk_pcg32_seed(rtk_pcg32 *rng, uint64_t initstate, uint64_t initseq)
{
    rng->state = 0u;
    rng->inc = (initseq << 1u) | 1u;
    rtk_pcg32_next(rng);
    rng->state += initstate;
    rtk_pcg32_next(rng);
}

uint32_t rtk_pcg32_next(rtk_pcg32 *rng)
{
    uint64_t old = rng->state;
    rng->state = old * 6364136223846793005ULL + rng->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31u));
}

float rtk_pcg32_float(rtk_pcg32 *rng)
{
    return (float)(rtk_pcg32_next(rng) >> 8) * 0x1p-24f;
}

/* SplitMix64 finaliser: spreads (seed, sample) over the state space. */
static uint64_t mix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

static uint64_t reverse64(uint64_t x)
{
    x = ((x >> 1) & 0x5555555555555555ULL) | ((x & 0x5555555555555555ULL) << 1);
    x = ((x >> 2) & 0x3333333333333333ULL) | ((x & 0x3333333333333333ULL) << 2);
    x = ((x >> 4) & 0x0f0f0f0f0f0f0f0fULL) | ((x & 0x0f0f0f0f0f0f0f0fULL) << 4);
    return __builtin_bswap64(x);
}

/* A bijection of 64-bit words whose bit k depends only on bits 0..k and
 * the seed (Laine and Karras 2011; Vegdahl's round order): adding and odd
 * multiplies carry upwards only, x ^= x * even mixes lower bits into
 * higher ones. */
static uint64_t lk_permute(uint64_t x, uint64_t seed)
{
    x ^= x * 0x3d20adea5b3f9e14ULL;
    x += seed;
    x *= (seed >> 32) | 1u;
    x ^= x * 0x05526c56e1d2a7b8ULL;
    x ^= x * 0x53a22864c8e4f3a6ULL;
    return x;
}

uint64_t rtk_owen_scramble(uint64_t x, uint64_t seed)
{
    return reverse64(lk_permute(reverse64(x), seed));
}

/* The digits of a Sobol point, the first (most significant) in bit 0:
 * dimension 0 (van der Corput) is the index itself. Dimension 1
 * (polynomial x + 1, m_k = 2 m_(k-1) ^ m_(k-1), m_1 = 1) is the Pascal
 * matrix mod 2: digit i is the parity of the index bits j with C(j, i)
 * odd, i.e. (Lucas) with i a submask of j; a superset-sum transform over
 * the 6-bit bit positions gives all 64 digits at once, so index bits
 * 32..63 reach the first 32 digits too. */
static uint64_t sobol_digits(uint64_t index, uint32_t dim)
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

uint32_t rtk_sobol_sample(uint64_t index, uint32_t dim)
{
    return (uint32_t)(reverse64(sobol_digits(index, dim)) >> 32);
}

/* The first 32 digits of a Sobol point, Owen-scrambled: the scramble
 * works on digits in this order, so no reversal is needed before it. */
static uint32_t scrambled_sobol(uint64_t index, uint32_t dim, uint64_t seed)
{
    return (uint32_t)(reverse64(lk_permute(sobol_digits(index, dim), seed)) >> 32);
}

float rtk_sampler_float(uint32_t bits)
{
    /* The top 24 bits, exactly: at most 0x1.fffffep-1. */
    return (float)(bits >> 8) * 0x1p-24f;
}

float rtk_sampler_stratum(uint32_t k, uint32_t n, uint32_t jitter)
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
static uint32_t permute(uint32_t i, uint32_t n, uint64_t seed)
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

/* Seed of draw dim of the current sample. */
static uint64_t draw_seed(const rtk_ctx *ctx, uint32_t dim)
{
    return mix64(ctx->sample_hash ^ ((uint64_t)dim + 1) * 0xd1b54a32d192ed03ULL);
}

static float stratified_1d(const rtk_ctx *ctx, uint32_t dim)
{
    uint32_t n = ctx->spp;
    uint64_t h = draw_seed(ctx, dim);
    uint32_t k = permute(ctx->pass_sample, n, h);
    return rtk_sampler_stratum(k, n, (uint32_t)(mix64(h ^ ctx->sample) >> 32));
}

static rtk_vec2 stratified_2d(const rtk_ctx *ctx, uint32_t dim)
{
    uint32_t n = ctx->spp, nx = ctx->grid_x, ny = ctx->grid_y;
    uint64_t h = draw_seed(ctx, dim);
    uint32_t cell = permute(ctx->pass_sample, n, h);
    uint32_t cx = cell % nx, cy = cell / nx;
    /* Correlated multi-jitter: every row shares one sub-column shuffle and
     * every column one sub-row shuffle, so x and y are also one sample per
     * 1/n stratum. */
    uint32_t sub_x = permute(cy, ny, mix64(h ^ 0x1u)), sub_y = permute(cx, nx, mix64(h ^ 0x2u));
    uint64_t jitter = mix64(h ^ ctx->sample);
    rtk_vec2 p;
    p.x = rtk_sampler_stratum(cx * ny + sub_x, n, (uint32_t)jitter);
    p.y = rtk_sampler_stratum(cy * nx + sub_y, n, (uint32_t)(jitter >> 32));
    return p;
}

static float sobol_1d(const rtk_ctx *ctx, uint32_t dim)
{
    uint64_t h = draw_seed(ctx, dim);
    uint64_t index = rtk_owen_scramble(ctx->sample, h);
    return rtk_sampler_float(scrambled_sobol(index, 0, mix64(h ^ 0x1u)));
}

static rtk_vec2 sobol_2d(const rtk_ctx *ctx, uint32_t dim)
{
    uint64_t h = draw_seed(ctx, dim);
    uint64_t index = rtk_owen_scramble(ctx->sample, h);
    rtk_vec2 p;
    p.x = rtk_sampler_float(scrambled_sobol(index, 0, mix64(h ^ 0x1u)));
    p.y = rtk_sampler_float(scrambled_sobol(index, 1, mix64(h ^ 0x2u)));
    return p;
}

int rtk_sampler_type_from_name(const char *name, rtk_sampler_type *type)
{
    static const char *const names[] = {"independent", "stratified", "sobol"};
    for (int i = 0; i < 3; i++) {
        if (name && strcmp(name, names[i]) == 0) {
            *type = (rtk_sampler_type)i;
            return 1;
        }
    }
    return 0;
}

void rtk_ctx_set_sampler(rtk_ctx *ctx, rtk_sampler_type type, uint64_t seed, uint32_t spp)
{
    ctx->sampler = type;
    ctx->seed = seed;
    ctx->spp = spp ? spp : 1;
    uint32_t ny = 1;
    for (uint32_t d = 2; (uint64_t)d * d <= ctx->spp; d++)
        if (ctx->spp % d == 0)
            ny = d;
    ctx->grid_x = ctx->spp / ny;
    ctx->grid_y = ny;
}

void rtk_ctx_start_sample(rtk_ctx *ctx, uint64_t pixel, uint64_t sample)
{
    ctx->pixel = pixel;
    ctx->sample = sample;
    ctx->dim = 0;
    ctx->dim_base = 0;
    if (ctx->sampler == RTK_SAMPLER_INDEPENDENT) {
        rtk_pcg32_seed(&ctx->rng, mix64(ctx->seed ^ mix64(sample)), pixel);
        return;
    }
    /* Stratified draws restart their strata every spp samples (a pass);
     * sobol's sequence runs on over all 2^64 indices. */
    uint64_t pass = ctx->sampler == RTK_SAMPLER_STRATIFIED ? sample / ctx->spp : 0;
    ctx->pass_sample = (uint32_t)(sample - pass * ctx->spp);
    ctx->sample_hash = mix64(ctx->seed ^ mix64(pixel ^ mix64(pass)));
}

void rtk_ctx_save_sample(const rtk_ctx *ctx, rtk_sample_state *st)
{
    st->rng = ctx->rng;
    st->pixel = ctx->pixel, st->sample = ctx->sample, st->sample_hash = ctx->sample_hash;
    st->pass_sample = ctx->pass_sample, st->dim = ctx->dim, st->dim_base = ctx->dim_base;
    st->film_x = ctx->film_x, st->film_y = ctx->film_y;
    st->camera_ray = ctx->camera_ray;
}

void rtk_ctx_load_sample(rtk_ctx *ctx, const rtk_sample_state *st)
{
    ctx->rng = st->rng;
    ctx->pixel = st->pixel, ctx->sample = st->sample, ctx->sample_hash = st->sample_hash;
    ctx->pass_sample = st->pass_sample, ctx->dim = st->dim, ctx->dim_base = st->dim_base;
    ctx->film_x = st->film_x, ctx->film_y = st->film_y;
    ctx->camera_ray = st->camera_ray;
}

RTK_API void rtk_ctx_select(rtk_ctx *ctx, uint32_t i)
{
    if (i >= ctx->batch_count || i == ctx->batch_current)
        return;
    rtk_ctx_save_sample(ctx, &ctx->batch[ctx->batch_current]);
    rtk_ctx_load_sample(ctx, &ctx->batch[i]);
    ctx->batch_current = i;
}

RTK_API void rtk_sample_seek(rtk_ctx *ctx, uint32_t dim)
{
    ctx->dim = ctx->dim_base + dim;
    if (ctx->sampler == RTK_SAMPLER_INDEPENDENT)
        rtk_pcg32_seed(&ctx->rng, mix64(ctx->seed ^ mix64(ctx->sample) ^ mix64(0x5eedULL + ctx->dim)), ctx->pixel);
}

RTK_API float rtk_sample_1d(rtk_ctx *ctx)
{
    uint32_t dim = ctx->dim++;
    switch (ctx->sampler) {
    case RTK_SAMPLER_STRATIFIED:
        return stratified_1d(ctx, dim);
    case RTK_SAMPLER_SOBOL:
        return sobol_1d(ctx, dim);
    default:
        return rtk_pcg32_float(&ctx->rng);
    }
}

RTK_API rtk_vec2 rtk_sample_2d(rtk_ctx *ctx)
{
    uint32_t dim = ctx->dim;
    ctx->dim += 2;
    switch (ctx->sampler) {
    case RTK_SAMPLER_STRATIFIED:
        return stratified_2d(ctx, dim);
    case RTK_SAMPLER_SOBOL:
        return sobol_2d(ctx, dim);
    default: {
        rtk_vec2 p;
        p.x = rtk_pcg32_float(&ctx->rng);
        p.y = rtk_pcg32_float(&ctx->rng);
        return p;
    }
    }
}
