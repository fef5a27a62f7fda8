/* null_entry: exports rtk_plugin_entry, but it returns NULL. The kernel
 * must refuse it ("rtk_plugin_entry() returned NULL") instead of reading
 * through the pointer. Test-only, never installed. */
#include <rtk/rtk.h>

RTK_EXPORT const rtk_plugin *rtk_plugin_entry(void);

const rtk_plugin *rtk_plugin_entry(void)
{
    return NULL;
}
