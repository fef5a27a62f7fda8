/* no_entry: a complete filter whose entry point was exported under the
 * wrong name, so the shared object exports no rtk_plugin_entry. The kernel
 * must refuse it as "not an rtk plugin (no 'rtk_plugin_entry' symbol
 * exported)". Test-only, never installed. */
#include <rtk/rtk.h>

#include "flat_filter.h"

static const rtk_plugin no_entry_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "no_entry",
    .version = "1.0",
    .summary = "broken on purpose: exports no rtk_plugin_entry",
    .functions = &flat_fns,
};

/* The typo a plugin author might make; the loader looks for the exact name. */
RTK_EXPORT const rtk_plugin *rtk_plugin_entrypoint(void);

const rtk_plugin *rtk_plugin_entrypoint(void)
{
    return &no_entry_plugin;
}
