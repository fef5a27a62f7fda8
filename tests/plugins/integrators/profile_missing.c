/* profile_missing: declares the "ambient-occlusion" profile without its
 * 'distance' parameter. rtk conform must fail, naming the parameter ("has
 * no parameter 'distance'"), not run the profile half-set. Test-only. */
#include "white_integrator.h"

static const rtk_param_desc profile_missing_params[] = {
    {.name = "rays", .type = RTK_PARAM_INT, .def = 16, .min = 1, .max = 4096, .doc = "occlusion rays"},
};

static const rtk_plugin profile_missing_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "profile_missing",
    .version = "1.0",
    .summary = "broken on purpose: the ambient-occlusion profile without 'distance'",
    .params = profile_missing_params,
    .param_count = RTK_COUNTOF(profile_missing_params),
    .functions = &white_fns,
    .conform = "ambient-occlusion",
};

RTK_PLUGIN_ENTRY(profile_missing_plugin)
