/* profile_unknown: declares a profile rtk does not have. rtk conform must
 * fail and list the known ones. Test-only. */
#include "white_integrator.h"

static const rtk_plugin profile_unknown_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "profile_unknown",
    .version = "1.0",
    .summary = "broken on purpose: an unknown conformance profile",
    .functions = &white_fns,
    .conform = "pathtracer",
};

RTK_PLUGIN_ENTRY(profile_unknown_plugin)
