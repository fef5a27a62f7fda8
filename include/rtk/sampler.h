/* Sampler service: random numbers for the current pixel sample. Each
 * sample's stream depends only on (seed, pixel, sample index), so images
 * do not depend on thread count or tile order. */
#ifndef RTK_SAMPLER_H
#define RTK_SAMPLER_H

#include <rtk/scene.h>

RTK_EXTERN_C_BEGIN

/* Next number in [0, 1) for this sample. [ctx's thread] */
RTK_API float rtk_sample_1d(rtk_ctx *ctx);

/* Next point in [0, 1)^2 for this sample. [ctx's thread] */
RTK_API rtk_vec2 rtk_sample_2d(rtk_ctx *ctx);

/* Makes the next draw dimension dim of this sample, counted from the first
 * draw li receives (0). Each draw is its own stratified or Sobol pattern
 * over a pixel's samples, so a draw keeps those properties only when every
 * sample spends it on the same decision: a path tracer seeks to
 * bounce x (draws per bounce) at the start of each bounce, so that Russian
 * roulette or a failed sample at one bounce does not shift the draws of the
 * next. With the independent generator the draws after a seek are a PCG32
 * stream of (seed, sample, pixel, dim). [ctx's thread] (ABI 3.3) */
RTK_API void rtk_sample_seek(rtk_ctx *ctx, uint32_t dim);

RTK_EXTERN_C_END

#endif
