/* abi_minor: a filter built against a newer SDK minor than the kernel's. The
 * kernel must refuse it: it may rely on fields this kernel does not know
 * ("... newer than this rtk's 1.0"). Test-only, never installed. */
#include <rtk/rtk.h>

#include "flat_filter.h"

static const rtk_plugin abi_minor_plugin = {
    .size = sizeof(rtk_plugin),
    .abi_major = RTK_ABI_MAJOR,
    .abi_minor = RTK_ABI_MINOR + 1,
    .kind = RTK_KIND_FILTER,
    .name = "abi_minor",
    .version = "1.0",
    .summary = "broken on purpose: ABI minor one above the kernel's",
    .functions = &flat_fns,
};

RTK_PLUGIN_ENTRY(abi_minor_plugin)
