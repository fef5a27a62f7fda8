/* profile_type: declares the "direct-area-light" profile with 'mis' an
 * int where the profile sets a bool. rtk conform must fail, naming the
 * type. Test-only. */
#include "white_integrator.h"

static const rtk_param_desc profile_type_params[] = {
    {.name = "light_samples", .type = RTK_PARAM_INT, .def = 1, .min = 1, .max = 4096, .doc = "light samples"},
    {.name = "mis", .type = RTK_PARAM_INT, .def = 1, .min = 0, .max = 1, .doc = "1: combine with BSDF sampling"},
};

static const rtk_plugin profile_type_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "profile_type",
    .version = "1.0",
    .summary = "broken on purpose: the direct-area-light profile with an int 'mis'",
    .params = profile_type_params,
    .param_count = RTK_COUNTOF(profile_type_params),
    .functions = &white_fns,
    .conform = "direct-area-light",
};

RTK_PLUGIN_ENTRY(profile_type_plugin)
