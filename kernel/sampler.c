/* PCG32 random numbers and the independent sampler service. Each pixel
 * sample gets its own stream, seeded from (seed, sample index) and
 * selected by the pixel index, so results do not depend on threads. */
#include "internal.h"

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

void rtk_ctx_start_sample(rtk_ctx *ctx, uint64_t pixel, uint32_t sample)
{
    rtk_pcg32_seed(&ctx->rng, mix64(ctx->seed ^ mix64(sample)), pixel);
}

RTK_API float rtk_sample_1d(rtk_ctx *ctx)
{
    return rtk_pcg32_float(&ctx->rng);
}

RTK_API rtk_vec2 rtk_sample_2d(rtk_ctx *ctx)
{
    rtk_vec2 p;
    p.x = rtk_pcg32_float(&ctx->rng);
    p.y = rtk_pcg32_float(&ctx->rng);
    return p;
}
