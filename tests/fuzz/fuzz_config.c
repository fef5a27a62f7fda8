/* Fuzz target: the config loader (libconfig, the integer-literal check,
 * @include, overrides' schema checks against the shipped plugins). The
 * input is the config file; nothing it names is loaded. */
#include "fuzz_common.h"

static rtk_registry *registry;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!registry) {
        fuzz_quiet();
        if (rtk_registry_create(&registry) != RTK_OK)
            abort();
    }
    const char *path = fuzz_write("fuzz.cfg", data, size);
    rtk_config_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    rtk_config *cfg = NULL;
    if (rtk_config_load(path, registry, &o, &cfg) == RTK_OK)
        rtk_config_destroy(cfg);
    return 0;
}
