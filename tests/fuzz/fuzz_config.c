/* Fuzz target: the config loader (libconfig, the integer-literal check,
 * @include, overrides' schema checks against the shipped plugins). The
 * input is the config file, and after a NUL byte the --set entries, one a
 * line (every other one with a label, as rtk render -o gives); nothing
 * the config names is loaded. */
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
    const uint8_t *nul = memchr(data, 0, size);
    const size_t text = nul ? (size_t)(nul - data) : size;
    const char *path = fuzz_write("fuzz.cfg", data, text);
    enum { MAX_SETS = 16 };
    const char *sets[MAX_SETS], *labels[MAX_SETS];
    size_t count = 0;
    char *lines = NULL;
    if (nul) {
        const size_t rest = size - text - 1;
        if (!(lines = malloc(rest + 1)))
            abort();
        memcpy(lines, nul + 1, rest);
        lines[rest] = '\0';
        for (char *line = lines, *next; line && count < MAX_SETS; line = next) {
            if ((next = strchr(line, '\n')))
                *next++ = '\0';
            labels[count] = count % 2 ? "-o fuzz.png" : NULL;
            sets[count++] = line;
        }
    }
    rtk_config_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.overrides = sets;
    o.override_labels = labels;
    o.override_count = count;
    rtk_config *cfg = NULL;
    if (rtk_config_load(path, registry, &o, &cfg) == RTK_OK)
        rtk_config_destroy(cfg);
    free(lines);
    return 0;
}
