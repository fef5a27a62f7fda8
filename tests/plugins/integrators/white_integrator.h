/* A valid integrator, white wherever the camera ray hits, that the profile
 * test plugins wrap in descriptors declaring conformance profiles. It
 * passes the generic checks and fails every profile's exact tests, so a
 * profile that runs shows. Each test plugin includes it once. */
#ifndef RTK_TEST_WHITE_INTEGRATOR_H
#define RTK_TEST_WHITE_INTEGRATOR_H

#include <rtk/rtk.h>

static rtk_status white_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static uint32_t white_needs(const void *state)
{
    (void)state;
    return 0;
}

static void white_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state;
    rtk_hit hit;
    if (rtk_trace(ctx, ray, &hit))
        out->radiance = rtk_rgb_make(1.0f, 1.0f, 1.0f);
}

static void white_destroy(void *state)
{
    (void)state;
}

static const rtk_integrator_fns white_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = white_create,
    .needs = white_needs,
    .li = white_li,
    .destroy = white_destroy,
};

#endif
