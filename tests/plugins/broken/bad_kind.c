/* bad_kind: a descriptor of kind 42, which no kernel knows. The kernel
 * must refuse it ("unknown plugin kind 42") before it reads the function
 * table as any kind's. Test-only, never installed. */
#include <rtk/rtk.h>

static rtk_status stub_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static float stub_radius(const void *state)
{
    (void)state;
    return 0.5f;
}

static float stub_eval(const void *state, float dx, float dy)
{
    (void)state;
    return dx >= -0.5f && dx <= 0.5f && dy >= -0.5f && dy <= 0.5f ? 1.0f : 0.0f;
}

static double stub_integral(const void *state)
{
    (void)state;
    return 1.0;
}

static void stub_destroy(void *state)
{
    (void)state;
}

static const rtk_filter_fns stub_fns = {
    .size = sizeof(rtk_filter_fns),
    .create = stub_create,
    .radius = stub_radius,
    .eval = stub_eval,
    .integral = stub_integral,
    .destroy = stub_destroy,
};

static const rtk_plugin bad_kind_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = (rtk_plugin_kind)42,
    .name = "bad_kind",
    .version = "1.0",
    .summary = "broken on purpose: kind 42",
    .functions = &stub_fns,
};

RTK_PLUGIN_ENTRY(bad_kind_plugin)
