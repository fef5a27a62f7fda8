/* box (second copy): a valid filter named "box", built as dup_a/box.so so
 * that a registry holding it and the shipped plugins/filters/box.so sees the
 * name twice. rtk_plugin_open accepts the file; the registry must refuse
 * both ("duplicate filter name 'box': ... and ..."). Test-only. */
#include <rtk/rtk.h>

#include "../flat_filter.h"

static const rtk_plugin box_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_FILTER,
    .name = "box",
    .version = "0.1",
    .summary = "second filter named box, for the duplicate-name test",
    .functions = &flat_fns,
};

RTK_PLUGIN_ENTRY(box_plugin)
