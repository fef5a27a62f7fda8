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

#include <string.h>

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
    rtk_sample_gen_init(&ctx->gen, type, seed, spp);
}

void rtk_ctx_start_sample(rtk_ctx *ctx, uint64_t pixel, uint64_t sample)
{
    rtk_sample_start(&ctx->gen, &ctx->pos, pixel, sample);
}

void rtk_ctx_save_sample(const rtk_ctx *ctx, rtk_sample_state *st)
{
    st->pos = ctx->pos;
    st->film_x = ctx->film_x, st->film_y = ctx->film_y;
    st->camera_ray = ctx->camera_ray;
}

void rtk_ctx_load_sample(rtk_ctx *ctx, const rtk_sample_state *st)
{
    ctx->pos = st->pos;
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
    rtk_sample_seek_pos(&ctx->gen, &ctx->pos, dim);
}

RTK_API float rtk_sample_1d(rtk_ctx *ctx)
{
    return rtk_sample_next_1d(&ctx->gen, &ctx->pos);
}

RTK_API rtk_vec2 rtk_sample_2d(rtk_ctx *ctx)
{
    return rtk_sample_next_2d(&ctx->gen, &ctx->pos);
}
