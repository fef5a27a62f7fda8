/* bad_kind: a descriptor of kind 42, which no kernel knows. The kernel
 * must refuse it ("unknown plugin kind 42") before it reads the function
 * table as any kind's. Test-only, never installed. */
#include <rtk/rtk.h>

#include "flat_filter.h"

static const rtk_plugin bad_kind_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = (rtk_plugin_kind)42,
    .name = "bad_kind",
    .version = "1.0",
    .summary = "broken on purpose: kind 42",
    .functions = &flat_fns,
};

RTK_PLUGIN_ENTRY(bad_kind_plugin)
