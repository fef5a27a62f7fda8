/* abi_major: a filter built for the next ABI major. The kernel must refuse
 * it before touching anything else in the descriptor ("... this rtk has ABI
 * 1.0: rebuild the plugin against this SDK"). Test-only, never installed. */
#include <rtk/rtk.h>

#include "flat_filter.h"

static const rtk_plugin abi_major_plugin = {
    .size = sizeof(rtk_plugin),
    .abi_major = RTK_ABI_MAJOR + 1,
    .abi_minor = RTK_ABI_MINOR,
    .kind = RTK_KIND_FILTER,
    .name = "abi_major",
    .version = "1.0",
    .summary = "broken on purpose: ABI major one above the kernel's",
    .functions = &flat_fns,
};

RTK_PLUGIN_ENTRY(abi_major_plugin)
