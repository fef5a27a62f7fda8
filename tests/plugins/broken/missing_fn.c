/* missing_fn: an integrator whose function table has no li. The kernel
 * must refuse it at load time ("integrator 'missing_fn' lacks the required
 * function 'li'"), not crash at the first camera ray. Test-only. */
#include <rtk/rtk.h>

static rtk_status missing_fn_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static uint32_t missing_fn_needs(const void *state)
{
    (void)state;
    return 0;
}

static void missing_fn_destroy(void *state)
{
    (void)state;
}

static const rtk_integrator_fns missing_fn_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = missing_fn_create,
    .needs = missing_fn_needs,
    .destroy = missing_fn_destroy,
};

static const rtk_plugin missing_fn_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "missing_fn",
    .version = "1.0",
    .summary = "broken on purpose: integrator without li",
    .functions = &missing_fn_fns,
};

RTK_PLUGIN_ENTRY(missing_fn_plugin)
