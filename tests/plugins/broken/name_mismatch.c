/* name_mismatch: a valid filter that calls itself "renamed" but is built as
 * name_mismatch.so. rtk_plugin_open accepts the file; a registry scan must
 * refuse it ("file name 'name_mismatch.so' differs from the plugin name
 * 'renamed'") because configs name plugins by file. Test-only. */
#include <rtk/rtk.h>

#include "flat_filter.h"

static const rtk_plugin name_mismatch_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "renamed",
    .version = "1.0",
    .summary = "broken on purpose: plugin name differs from the file name",
    .functions = &flat_fns,
};

RTK_PLUGIN_ENTRY(name_mismatch_plugin)
