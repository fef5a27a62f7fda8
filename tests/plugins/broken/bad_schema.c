/* bad_schema: a filter whose parameter schema contradicts itself: the
 * default radius 32 lies outside the declared range [0.001, 16]. The kernel
 * must refuse the schema ("parameter 'radius' has default 32 outside its
 * range") before any config is read. Test-only, never installed. */
#include <rtk/rtk.h>

#include "flat_filter.h"

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
    .functions = &flat_fns,
};

RTK_PLUGIN_ENTRY(bad_schema_plugin)
