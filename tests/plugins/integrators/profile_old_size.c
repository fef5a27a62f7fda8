/* profile_old_size: a 3.0 descriptor, its size ending before `conform`,
 * with "ambient-occlusion" in the memory where conform would be. The
 * kernel must not read past the size: rtk conform runs the generic checks
 * only and passes (the white integrator would fail that profile). Test-only. */
#include "white_integrator.h"

#include <stddef.h>

static const rtk_param_desc profile_old_size_params[] = {
    {.name = "rays", .type = RTK_PARAM_INT, .def = 16, .min = 1, .max = 4096, .doc = "occlusion rays"},
    {.name = "distance", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 1e-30, .max = 1e30, .doc = "occlusion distance"},
};

static const rtk_plugin profile_old_size_plugin = {
    .size = offsetof(rtk_plugin, conform),
    .abi_major = RTK_ABI_MAJOR,
    .abi_minor = 0,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "profile_old_size",
    .version = "1.0",
    .summary = "a 3.0 descriptor: no conform field as far as its size says",
    .params = profile_old_size_params,
    .param_count = RTK_COUNTOF(profile_old_size_params),
    .functions = &white_fns,
    .conform = "ambient-occlusion",
};

RTK_PLUGIN_ENTRY(profile_old_size_plugin)
