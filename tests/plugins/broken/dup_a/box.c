/* box (second copy): a valid filter named "box", built as dup_a/box.so so
 * that a registry holding it and the shipped plugins/filters/box.so sees the
 * name twice. rtk_plugin_open accepts the file; the registry must refuse
 * both ("duplicate filter name 'box': ... and ..."). Test-only. */
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

static const rtk_plugin box_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "box",
    .version = "0.1",
    .summary = "second filter named box, for the duplicate-name test",
    .functions = &stub_fns,
};

RTK_PLUGIN_ENTRY(box_plugin)
