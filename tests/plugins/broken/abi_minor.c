/* abi_minor: a filter built against a newer SDK minor than the kernel's. The
 * kernel must refuse it: it may rely on fields this kernel does not know
 * ("... newer than this rtk's 1.0"). Test-only, never installed. */
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

static const rtk_plugin abi_minor_plugin = {
    .size = sizeof(rtk_plugin),
    .abi_major = RTK_ABI_MAJOR,
    .abi_minor = RTK_ABI_MINOR + 1,
    .kind = RTK_KIND_FILTER,
    .name = "abi_minor",
    .version = "1.0",
    .summary = "broken on purpose: ABI minor one above the kernel's",
    .functions = &stub_fns,
};

RTK_PLUGIN_ENTRY(abi_minor_plugin)
