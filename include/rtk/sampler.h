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

RTK_EXTERN_C_END

#endif
