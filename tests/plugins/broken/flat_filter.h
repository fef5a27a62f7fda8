/* The valid one-pixel box filter that the broken test plugins wrap in a
 * faulty descriptor; each includes it once and breaks one thing. */
#ifndef RTK_TEST_FLAT_FILTER_H
#define RTK_TEST_FLAT_FILTER_H

#include <rtk/rtk.h>

static rtk_status flat_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static float flat_radius(const void *state)
{
    (void)state;
    return 0.5f;
}

static float flat_eval(const void *state, float dx, float dy)
{
    (void)state;
    return dx >= -0.5f && dx <= 0.5f && dy >= -0.5f && dy <= 0.5f ? 1.0f : 0.0f;
}

static double flat_integral(const void *state)
{
    (void)state;
    return 1.0;
}

static void flat_destroy(void *state)
{
    (void)state;
}

static const rtk_filter_fns flat_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = flat_create,
    .radius = flat_radius,
    .eval = flat_eval,
    .integral = flat_integral,
    .destroy = flat_destroy,
};

#endif
