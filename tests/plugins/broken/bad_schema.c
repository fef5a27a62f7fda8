/* bad_schema: a filter whose parameter schema contradicts itself: the
 * default radius 32 lies outside the declared range [0.001, 16]. The kernel
 * must refuse the schema ("parameter 'radius' has default 32 outside its
 * range") before any config is read. Test-only, never installed. */
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

static const rtk_param_desc bad_schema_params[] = {
    {.name = "radius", .type = RTK_PARAM_FLOAT, .def = 32.0, .min = 0.001, .max = 16.0,
     .doc = "half-width of the support in pixels"},
};

static const rtk_plugin bad_schema_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "bad_schema",
    .version = "1.0",
    .summary = "broken on purpose: default outside its range",
    .params = bad_schema_params,
    .param_count = RTK_COUNTOF(bad_schema_params),
    .functions = &stub_fns,
};

RTK_PLUGIN_ENTRY(bad_schema_plugin)
