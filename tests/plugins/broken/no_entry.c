/* no_entry: a complete filter whose entry point was exported under the
 * wrong name, so the shared object exports no rtk_plugin_entry. The kernel
 * must refuse it as "not an rtk plugin (no 'rtk_plugin_entry' symbol
 * exported)". Test-only, never installed. */
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

static const rtk_plugin no_entry_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "no_entry",
    .version = "1.0",
    .summary = "broken on purpose: exports no rtk_plugin_entry",
    .functions = &stub_fns,
};

/* The typo a plugin author might make; the loader looks for the exact name. */
RTK_EXPORT const rtk_plugin *rtk_plugin_entrypoint(void);

const rtk_plugin *rtk_plugin_entrypoint(void)
{
    return &no_entry_plugin;
}
