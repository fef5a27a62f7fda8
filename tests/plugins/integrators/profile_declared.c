/* profile_declared: a third-party-style integrator declaring the
 * conformance profiles PROFILES (a string its meson line defines, with
 * PLUGIN_NAME and ABI_MINOR), with every parameter those profiles set.
 * Built once per declaration test_profile_list.sh checks; the white integrator fails
 * every exact test, so the output shows which profiles ran. Test-only. */
#include "white_integrator.h"

#include <math.h>

static const rtk_param_desc profile_declared_params[] = {
    {.name = "rays", .type = RTK_PARAM_INT, .def = 16, .min = 1, .max = 4096, .doc = "occlusion rays"},
    {.name = "distance", .type = RTK_PARAM_FLOAT, .def = INFINITY, .min = 1e-30, .max = INFINITY,
     .doc = "occlusion distance"},
    {.name = "light_samples", .type = RTK_PARAM_INT, .def = 1, .min = 1, .max = 4096, .doc = "light samples"},
    {.name = "mis", .type = RTK_PARAM_BOOL, .def = 1, .doc = "combine with BSDF sampling"},
    {.name = "max_depth", .type = RTK_PARAM_INT, .def = 5, .min = 0, .max = 64, .doc = "specular bounces"},
    {.name = "ambient", .type = RTK_PARAM_FLOAT, .def = 0.0, .min = 0.0, .max = 1.0, .doc = "ambient term"},
};

static const rtk_plugin profile_declared_plugin = {
    .size = sizeof(rtk_plugin),
    .abi_major = RTK_ABI_MAJOR,
    .abi_minor = ABI_MINOR,
    .kind = RTK_KIND_INTEGRATOR,
    .name = PLUGIN_NAME,
    .version = "1.0",
    .summary = "declares the conformance profiles " PROFILES,
    .params = profile_declared_params,
    .param_count = RTK_COUNTOF(profile_declared_params),
    .functions = &white_fns,
    .conform = PROFILES,
};

RTK_PLUGIN_ENTRY(profile_declared_plugin)
