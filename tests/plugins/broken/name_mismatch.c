/* name_mismatch: a valid filter that calls itself "renamed" but is built as
 * name_mismatch.so. rtk_plugin_open accepts the file; a registry scan must
 * refuse it ("file name 'name_mismatch.so' differs from the plugin name
 * 'renamed'") because configs name plugins by file. Test-only. */
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

static const rtk_plugin name_mismatch_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "renamed",
    .version = "1.0",
    .summary = "broken on purpose: plugin name differs from the file name",
    .functions = &stub_fns,
};

RTK_PLUGIN_ENTRY(name_mismatch_plugin)
